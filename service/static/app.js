// The evomesh viewer: wires the region input, the parameter form, jobs, the mesh view and the
// figures together. Everything it needs comes from this service (no CDN).

import { ApiError, api, apiKey, setApiKey } from "./api.js";
import { drawColorBar, drawHistogram, histogram } from "./charts.js";
import { DrawTool } from "./draw.js";
import {
  LonLatDisplay, SQUARE_METRES_PER_UNIT, crsChoices, crsOf, forDisplay, isGeographic, partsForDisplay,
} from "./geo.js";
import { FINAL, JobList, stageLabel, watchJob } from "./jobs.js";
import { ColourRange, readoutText, renderTagLegend } from "./legend.js";
import { controlOf, renderLayerToggles } from "./control.js";
import { METRICS, colorRange, meshesOf, namesById } from "./meshdata.js";
import { ParamsForm } from "./params.js";
import { EXAMPLES, estimateTriangles, parseRegion, regionStats, suggestSize } from "./region.js";
import { recall, remember } from "./rerun.js";
import { renderDownloads, renderSummary } from "./summary.js";
import { MeshView } from "./view.js";

const $ = (id) => document.getElementById(id);

const state = {
  region: null,        // {text, parsed, stats, object, display}
  regionText: null,    // the text last read
  regionCrs: "",       // the CRS it was read in
  sizeTouched: false,  // the user typed a size: stop suggesting one
  job: null,           // the job shown: {id, doc, meshes}
  watcher: null,
  colorBy: "quality",
  which: "after",
  timings: {},         // what the last result cost the browser (ms), for people and tests
};

const view = new MeshView({
  canvas: $("mesh-canvas"),
  overlay: $("overlay-canvas"),
  box: $("canvas-box"),
  renderer: new URLSearchParams(location.search).get("renderer") || "webgl2",
});

const colourRange = new ColourRange($("range-lo"), $("range-hi"), $("range-reset"), () => showMesh());
let params = null;
let drawTool = null;

// -- messages -------------------------------------------------------------------------------------

function showError(err, where = $("submit-error")) {
  if (!err) {
    where.hidden = true;
    where.replaceChildren();
    return;
  }
  const problem = err instanceof ApiError ? err.problem : { title: "Error", detail: String(err.message || err) };
  const strong = document.createElement("strong");
  strong.textContent = problem.title || "Error";
  const detail = document.createElement("span");
  detail.textContent = problem.detail || "";
  where.replaceChildren(strong, detail);
  where.hidden = false;
}

function setStatus(status) {
  document.body.dataset.jobStatus = status;
}

// -- the region ----------------------------------------------------------------------------------

function readRegion() {
  const area = $("region-text");
  const text = area.value.trim();
  const crs = $("crs").value.trim();
  // Unchanged text and CRS: nothing to do (keeps an error's marker).
  if (text === state.regionText && crs === state.regionCrs) return;
  state.regionText = text;
  state.regionCrs = crs;
  showCrsUnits();
  view.setMarker(null);
  if (!text) {
    state.region = null;
    area.classList.remove("invalid");
    $("region-status").textContent = "No region yet.";
    view.setRegion(null);
    $("empty").hidden = Boolean(state.job || view.tool);
    updateSizeHint();
    return;
  }
  try {
    const object = JSON.parse(text);
    const parsed = parseRegion(object);
    const legacy = object && object.crs && object.crs.properties && object.crs.properties.name;
    if (legacy && !crs) {
      // A pre-RFC 7946 file names its CRS: take it (readRegion runs again with it).
      $("crs").value = legacy;
      state.regionText = null;
      readRegion();
      return;
    }
    const points = parsed.parts.flat(2);
    setCrsChoices(points);
    // Lon/lat is drawn true to shape and measured in metres (what the service meshes in).
    const display = isGeographic(crs) ? LonLatDisplay.of(points) : null;
    const parts = display ? partsForDisplay(parsed.parts, display) : parsed.parts;
    const stats = regionStats({ parts });
    if (display) stats.area *= SQUARE_METRES_PER_UNIT;
    state.region = { text, object, parsed, stats, display };
    area.classList.remove("invalid");
    const h = parsed.properties && parsed.properties.h;
    const areaText = display ? `${(stats.area / 1e6).toPrecision(4)} km²` : stats.area.toPrecision(4);
    $("region-status").textContent =
      `${parsed.kind} · ${stats.rings} ring${stats.rings > 1 ? "s" : ""} · ${stats.vertices} vertices · ` +
      `area ${areaText}` + (h ? ` · h ${h}` : "");
    view.setRegion(parts);
    if (!state.job && !view.tool) view.fit(stats.box);
    $("empty").hidden = true;
    if (!state.sizeTouched) $("size").value = h || suggestSize(stats.area);
  } catch (err) {
    state.region = null;
    area.classList.add("invalid");
    $("region-status").textContent = `Not a region: ${err.message}`;
    view.setRegion(null);
  }
  updateSizeHint();
}

/** Offer the common CRS codes (and the region's UTM zone when it could be lon/lat). */
function setCrsChoices(points) {
  const list = $("crs-list");
  const choices = crsChoices(points);
  const key = choices.map((c) => c.value).join(" ");
  if (list.dataset.key === key) return;
  list.dataset.key = key;
  list.replaceChildren(...choices.map((c) => new Option(c.label, c.value)));
}

/** Sizes are metres for lon/lat (the service meshes it in metres), else the CRS's own units. */
function showCrsUnits() {
  const crs = $("crs").value.trim();
  $("size-unit").textContent = !crs
    ? "target edge length"
    : isGeographic(crs) ? "target edge length, metres" : "target edge length, CRS units";
  document.body.dataset.crs = crs ? (isGeographic(crs) ? "geographic" : "projected") : "planar";
}

function updateSizeHint() {
  const size = Number($("size").value);
  const hint = $("size-hint");
  if (!state.region || !(size > 0)) {
    hint.textContent = "";
    return;
  }
  const n = estimateTriangles(state.region.stats.area, size);
  hint.textContent = `about ${n.toLocaleString("en-US")} triangles`;
}

function setRegionText(text) {
  $("region-text").value = text;
  state.sizeTouched = false;
  readRegion();
}

function initRegion() {
  const select = $("example");
  for (const name of Object.keys(EXAMPLES)) select.add(new Option(name, name));
  select.addEventListener("change", () => {
    if (!select.value) return;
    stopDrawing();
    showJob(null);
    setRegionText(JSON.stringify(EXAMPLES[select.value], null, 1));
    select.value = "";
  });
  let timer = null;
  $("region-text").addEventListener("input", () => {
    clearTimeout(timer);
    timer = setTimeout(readRegion, 200);
  });
  $("upload").addEventListener("change", async (e) => {
    const file = e.target.files[0];
    if (file) loadFile(file);
    e.target.value = "";
  });
  // Dropping a file anywhere on the page loads it.
  document.addEventListener("dragover", (e) => e.preventDefault());
  document.addEventListener("drop", (e) => {
    e.preventDefault();
    const file = e.dataTransfer.files[0];
    if (file) loadFile(file);
  });
  $("crs").addEventListener("change", () => {
    state.sizeTouched = false; // degrees and metres differ: suggest again
    readRegion();
  });
  $("size").addEventListener("input", () => {
    state.sizeTouched = true;
    updateSizeHint();
  });
  $("draw-button").addEventListener("click", () => (view.tool ? stopDrawing() : startDrawing()));
}

async function loadFile(file) {
  stopDrawing();
  showJob(null);
  setRegionText(await file.text());
}

function startDrawing() {
  showJob(null);
  drawTool = new DrawTool((polygon) => {
    $("region-text").value = polygon ? JSON.stringify(polygon) : "";
    readRegion();
  });
  view.tool = drawTool;
  $("region-text").value = "";
  state.sizeTouched = false;
  readRegion();
  if (!Number.isFinite(view.scale) || view.scale <= 0) view.fit([0, 0, 1, 1]);
  $("canvas-box").classList.add("drawing");
  $("draw-button").classList.add("active");
  $("draw-button").textContent = "Done";
  $("draw-help").hidden = false;
  $("empty").hidden = true;
  view.invalidate();
}

function stopDrawing() {
  if (!view.tool) return;
  drawTool.closeRing(view);
  view.tool = null;
  $("canvas-box").classList.remove("drawing");
  $("draw-button").classList.remove("active");
  $("draw-button").textContent = "Draw";
  $("draw-help").hidden = true;
  $("empty").hidden = Boolean(state.region || state.job);
  view.invalidate();
}

// -- submitting and following a job -------------------------------------------------------------

function setBusy(busy) {
  $("submit").disabled = busy;
  $("cancel").hidden = !busy;
  $("progress").hidden = !busy;
}

function showProgress(status) {
  const pct = status.status === "successful" ? 100 : status.progress || 0;
  $("progress-fill").style.width = `${pct}%`;
  $("progress-pct").textContent = `${pct}%`;
  $("progress-stage").textContent = stageLabel(status);
  setStatus(status.status);
}

async function submit(e) {
  e.preventDefault();
  showError(null);
  stopDrawing();
  readRegion();
  if (!state.region) {
    showError(new Error("Give a region first: pick an example, paste, upload or draw one."));
    return;
  }
  const inputs = meshInputs();
  for (const el of document.querySelectorAll(".invalid")) el.classList.remove("invalid");
  setBusy(true);
  showProgress({ status: "accepted", progress: 0, message: "" });
  let status;
  try {
    status = await api.execute("mesh", inputs);
  } catch (err) {
    setBusy(false);
    reportProblem(err);
    return;
  }
  remember(status.jobID, inputs, state.region.text);
  jobs.setCurrent(status.jobID);
  jobs.refresh();
  follow(status.jobID);
}

/** The mesh process's inputs from the region and the form. */
function meshInputs() {
  const inputs = { boundary: state.region.object, ...params.values() };
  const size = $("size").value;
  // Empty: the service takes the region's h property (and says so when there is none).
  if (size !== "") inputs.size = Number(size);
  return inputs;
}

/** Show a problem by the input it points at (and where on the region, if it says). */
function reportProblem(err) {
  showError(err);
  const problem = err instanceof ApiError ? err.problem : {};
  const pointer = problem.pointer || "";
  if (pointer.startsWith("/inputs/boundary")) $("region-text").classList.add("invalid");
  const input = params.inputAt(pointer);
  if (input) input.classList.add("invalid");
  if (Array.isArray(problem.location)) {
    const [x, y] = problem.location;
    view.setMarker({ x, y, label: "here" });
  }
  setStatus("error");
}

async function follow(id) {
  if (state.watcher) state.watcher.stop();
  setBusy(true);
  const started = performance.now();
  const watcher = watchJob(id, showProgress);
  state.watcher = watcher;
  $("cancel").onclick = async () => {
    try {
      await api.dismiss(id);
    } catch (err) {
      showError(err);
    }
  };
  let final;
  try {
    final = await watcher.done;
  } catch (err) {
    if (state.watcher === watcher) setBusy(false);
    showError(err);
    return;
  }
  if (state.watcher !== watcher) return; // another job took over
  state.watcher = null;
  jobs.refresh();
  state.timings.jobMs = performance.now() - started;
  if (!final || final.status !== "successful") {
    setBusy(false);
    if (final && final.status === "failed") showError(new ApiError({ title: "The job failed", detail: final.message }));
    if (final && final.status === "dismissed") showError(new ApiError({ title: "Dismissed", detail: "the job was stopped" }));
    return;
  }
  $("progress-stage").textContent = "loading the result";
  await openResult(id);
  setBusy(false);
}

async function openResult(id) {
  let doc;
  const t0 = performance.now();
  try {
    doc = await api.results(id);
  } catch (err) {
    showError(err);
    return;
  }
  const t1 = performance.now();
  // A lon/lat result is drawn like its region: true to shape, continuous across 180 degrees.
  const display = isGeographic(crsOf(doc)) ? LonLatDisplay.of(doc.points) : null;
  const meshes = meshesOf(display ? forDisplay(doc, display) : doc);
  const t2 = performance.now();
  state.timings.fetchMs = t1 - t0;
  state.timings.prepareMs = t2 - t1;
  showJob({ id, doc, meshes, display });
  view.setControl(controlOf(id, doc, display));
  renderLayerToggles($("legend-layers"), view);
  view.render(true);
  state.timings.firstFrameMs = performance.now() - t2;
  document.body.dataset.rendered = id;
}

/** Put what a job was asked for back in the form (its region too, when this browser sent it). */
function restoreInputs(asked) {
  if (!asked) return;
  params.setValues(asked.inputs);
  if (asked.regionText !== null) {
    $("region-text").value = asked.regionText;
    state.regionText = null; // read it again, with the restored CRS
    readRegion();
  }
  if (asked.inputs.size !== undefined) {
    $("size").value = asked.inputs.size;
    state.sizeTouched = true;
  }
  updateSizeHint();
}

async function openJob(job) {
  showError(null);
  stopDrawing();
  jobs.setCurrent(job.jobID);
  const asked = recall(job.jobID);
  restoreInputs(asked);
  if (FINAL.has(job.status)) {
    if (state.watcher) state.watcher.stop();
    state.watcher = null;
    setBusy(false);
    showProgress(job);
    if (job.status === "successful") {
      await openResult(job.jobID);
      // Not sent from this browser: the parameters its result says it used (no region).
      if (!asked && state.job && state.job.id === job.jobID) restoreInputs(recall(job.jobID, state.job.doc));
    } else {
      showJob(null);
      showError(new ApiError({ title: `The job ${job.status}`, detail: job.message || "" }));
    }
    return;
  }
  follow(job.jobID);
}

// -- showing a result ----------------------------------------------------------------------------

function showJob(job) {
  if (!job || !state.job || job.id !== state.job.id) colourRange.clear();
  state.job = job;
  if (!job) {
    view.setMesh(null);
    $("legend").hidden = true;
    $("readout").hidden = true;
    $("job-title").textContent = "";
    $("toolbar").classList.add("idle");
    $("empty").hidden = Boolean(state.region) || Boolean(view.tool);
    history.replaceState(null, "", location.pathname + location.search);
    $("hist-box").hidden = true;
    $("hist-hint").hidden = false;
    return;
  }
  $("empty").hidden = true;
  $("toolbar").classList.remove("idle");
  $("job-title").textContent = `job ${job.id.slice(0, 8)}`;
  $("job-title").title = job.id;
  history.replaceState(null, "", `${location.pathname}${location.search}#job=${job.id}`);
  const hasBefore = Boolean(job.meshes.before);
  document.querySelector('[data-which="before"]').disabled = !hasBefore;
  if (!hasBefore) state.which = "after";
  showMesh(true);
  renderSummary($("summary"), job.doc);
  renderDownloads($("downloads"), job.id, { color: state.colorBy, compare: hasBefore });
  drawHistograms();
}

/** Draw the chosen mesh (before or after) coloured by the chosen metric. */
function showMesh(fit = false) {
  const job = state.job;
  if (!job) return;
  const mesh = state.which === "before" && job.meshes.before ? job.meshes.before : job.meshes.after;
  if (!mesh.values(state.colorBy)) state.colorBy = "quality"; // a result without node fitness
  const metric = METRICS[state.colorBy];
  // One scale for before and after, so the two compare by colour.
  const all = [job.meshes.after, job.meshes.before].filter(Boolean).map((m) => m.values(state.colorBy)).filter(Boolean);
  let [lo, hi] = colorRange(metric, all);
  const regionIds = mesh.cell.region;
  const byRegion = state.colorBy === "region";
  if (byRegion) [lo, hi] = [1, regionIds.reduce((m, v) => Math.max(m, v), 2)];
  else [lo, hi] = colourRange.apply(state.colorBy, lo, hi);
  document.querySelector("[data-color=region]").hidden = !regionIds;
  if (view.mesh !== mesh) view.setMesh(mesh);
  view.setColors(mesh.values(state.colorBy), metric.on === "point", lo, hi);
  if (fit) fitView();
  for (const b of document.querySelectorAll("[data-color]")) b.classList.toggle("on", b.dataset.color === state.colorBy);
  for (const b of document.querySelectorAll("[data-which]")) b.classList.toggle("on", b.dataset.which === state.which);
  $("legend").hidden = false;
  $("legend-title").textContent = state.colorBy === "region"
    ? `region: ${[...namesById(job.doc.regions).values()].join(", ")}`
    : metric.label;
  renderTagLegend($("legend-tags"), mesh, job.doc.tags);
  $("legend-range").hidden = byRegion;
  $("legend-lo").textContent = lo.toFixed(2);
  $("legend-hi").textContent = hi.toFixed(2);
  $("legend-worst").textContent = view.showWorst && mesh.worst.length
    ? `red: the ${mesh.worst.length} lowest-quality triangles`
    : "";
}

function drawHistograms() {
  const job = state.job;
  $("hist-box").hidden = false;
  $("hist-hint").hidden = true;
  const after = job.meshes.after.cell.quality;
  const before = job.meshes.before ? job.meshes.before.cell.quality : null;
  const [lo] = colorRange(METRICS.quality, [after, before].filter(Boolean));
  const top = Math.max(...[after, before].filter(Boolean).map((q) => Math.max(...histogram(q, lo))));
  drawHistogram($("hist-before"), before, after, lo, top, "after");
  drawHistogram($("hist-after"), after, before, lo, top, "before");
}

function showReadout({ detail }) {
  const out = $("readout");
  out.hidden = detail.x === null || detail.x === undefined;
  if (out.hidden) return;
  const display = state.job ? state.job.display : state.region && state.region.display;
  out.textContent = readoutText(detail, view.mesh, display, state.colorBy);
}

// -- the toolbar and keys --------------------------------------------------------------------------

function initToolbar() {
  for (const b of document.querySelectorAll("[data-color]")) {
    b.addEventListener("click", () => {
      state.colorBy = b.dataset.color;
      showMesh();
      if (state.job) renderDownloads($("downloads"), state.job.id, { color: state.colorBy, compare: Boolean(state.job.meshes.before) });
    });
  }
  for (const b of document.querySelectorAll("[data-which]")) {
    b.addEventListener("click", () => {
      state.which = b.dataset.which;
      showMesh();
    });
  }
  $("edges").addEventListener("change", (e) => {
    view.showEdges = e.target.checked;
    view.invalidate();
  });
  $("worst").addEventListener("change", (e) => {
    view.showWorst = e.target.checked;
    showMesh();
    view.invalidate();
  });
  $("fit").addEventListener("click", fitView);
  let resizing = null;
  window.addEventListener("resize", () => {
    clearTimeout(resizing);
    resizing = setTimeout(() => state.job && drawHistograms(), 150);
  });
  view.addEventListener("hover", showReadout);
  document.addEventListener("keydown", (e) => {
    if (e.target.closest("input, textarea, select")) return;
    if (view.tool) {
      if (e.key === "Enter") drawTool.closeRing(view);
      else if (e.key === "Backspace") drawTool.undo(view);
      else if (e.key === "Escape") stopDrawing();
      else return;
      e.preventDefault();
      return;
    }
    if (e.key === "f" || e.key === "F") fitView();
    else if (e.key === "c" || e.key === "C") document.querySelector(`[data-color="${state.colorBy === "quality" ? "fitness" : "quality"}"]`).click();
    else if (e.key === "b" || e.key === "B") document.querySelector(`[data-which="${state.which === "after" ? "before" : "after"}"]`).click();
  });
}

/** Room the floating legend takes at the bottom of the view. */
const LEGEND_PAD = [24, 24, 96, 24];

function fitView() {
  if (view.mesh) view.fit(view.mesh.box, LEGEND_PAD);
  else if (state.region) view.fit(state.region.stats.box);
}

function initApiKey() {
  const dialog = $("api-key-dialog");
  $("api-key-button").addEventListener("click", () => {
    $("api-key").value = apiKey();
    dialog.showModal();
  });
  dialog.addEventListener("close", () => {
    if (dialog.returnValue === "save") {
      setApiKey($("api-key").value.trim());
      location.reload();
    }
  });
}

// -- start ---------------------------------------------------------------------------------------

const jobs = new JobList($("jobs"), {
  onOpen: openJob,
  onDismissed: (id) => {
    if (state.job && state.job.id === id) showJob(null);
  },
  onError: (err) => {
    if (err instanceof ApiError && (err.status === 401 || err.status === 403)) showError(err);
  },
});

async function main() {
  initRegion();
  initToolbar();
  initApiKey();
  drawColorBar($("legend-bar"));
  $("params").addEventListener("submit", submit);
  $("jobs-refresh").addEventListener("click", () => jobs.refresh());
  try {
    params = new ParamsForm($("params"), await api.processDescription("mesh"));
  } catch (err) {
    showError(err);
    $("submit").disabled = true;
    return;
  }
  jobs.start();
  view.fit([0, 0, 1, 1]);
  const hash = /job=([\w-]+)/.exec(location.hash);
  if (hash) {
    try {
      await openJob(await api.job(hash[1]));
    } catch (err) {
      showError(err);
    }
  }
  document.body.dataset.ready = "true";
}

// For people poking at the page, and for the end-to-end test.
window.evomesh = { state, view, openResult, meshInputs };

main();
