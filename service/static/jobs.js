// Jobs: following one job's status until it ends, and the list of recent jobs.

import { ApiError, api } from "./api.js";

export const FINAL = new Set(["successful", "failed", "dismissed"]);

/** What a job's message (its current stage) means to a person. */
const STAGES = {
  "": "queued",
  accepted: "queued",
  started: "starting",
  boundary: "discretising the boundary",
  mesh: "meshing",
  swap: "swapping diagonals",
  smooth: "smoothing",
  quality: "assessing quality",
  done: "done",
};

export function stageLabel(status) {
  if (status.status === "accepted") return "queued";
  if (status.status === "dismissed") return "dismissed";
  if (status.status === "failed") return `failed: ${status.message}`;
  return STAGES[status.message] ?? status.message;
}

/**
 * Poll GET /jobs/{id} until the job ends; `onUpdate(status)` sees every answer. Resolves with
 * the final status; `stop()` ends the polling early (resolving with the last status seen).
 */
export function watchJob(id, onUpdate, interval = 250) {
  const controller = new AbortController();
  let last = null;
  let stopped = false;
  const done = (async () => {
    let failures = 0;
    while (!stopped) {
      try {
        last = await api.job(id, controller.signal);
        failures = 0;
        onUpdate(last);
        if (FINAL.has(last.status)) return last;
      } catch (err) {
        if (err.name === "AbortError") return last;
        // A busy or restarting service: keep trying for a while before giving up.
        if (++failures > 20 || (err instanceof ApiError && err.status === 404)) throw err;
      }
      await new Promise((r) => setTimeout(r, failures ? interval * 4 : interval));
    }
    return last;
  })();
  return {
    done,
    stop() {
      stopped = true;
      controller.abort();
    },
  };
}

function ago(iso) {
  const s = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
  if (s < 60) return "just now";
  if (s < 3600) return `${Math.floor(s / 60)} min ago`;
  if (s < 86400) return `${Math.floor(s / 3600)} h ago`;
  return new Date(iso).toLocaleDateString();
}

/** The list of recent jobs: click one to open it, × to dismiss it. */
export class JobList {
  constructor(list, { onOpen, onDismissed, onError }) {
    this.list = list;
    this.onOpen = onOpen;
    this.onDismissed = onDismissed;
    this.onError = onError;
    this.current = null;
    this.timer = null;
  }

  start(every = 4000) {
    this.refresh();
    this.timer = setInterval(() => {
      if (document.visibilityState === "visible") this.refresh();
    }, every);
  }

  setCurrent(id) {
    this.current = id;
    for (const li of this.list.querySelectorAll("li.job")) li.classList.toggle("current", li.dataset.job === id);
  }

  async refresh() {
    let doc;
    try {
      doc = await api.jobs(15);
    } catch (err) {
      this.onError(err);
      return;
    }
    this.list.replaceChildren(...doc.jobs.map((job) => this._item(job)));
    if (!doc.jobs.length) {
      const li = document.createElement("li");
      li.className = "hint";
      li.textContent = "No jobs yet.";
      this.list.append(li);
    }
  }

  _item(job) {
    const li = document.createElement("li");
    li.className = "job";
    li.dataset.job = job.jobID;
    li.classList.toggle("current", job.jobID === this.current);
    const pill = document.createElement("span");
    pill.className = `pill ${job.status}`;
    pill.textContent = job.status === "running" ? `${job.progress}%` : job.status;
    const id = document.createElement("span");
    id.className = "job-id";
    id.textContent = `${job.processID} ${job.jobID.slice(0, 8)}`;
    id.title = job.jobID;
    const dismiss = document.createElement("button");
    dismiss.type = "button";
    dismiss.className = "dismiss";
    dismiss.textContent = "×";
    dismiss.title = FINAL.has(job.status) ? "Dismiss: delete this job and its results" : "Dismiss: stop this job";
    dismiss.hidden = job.status === "dismissed";
    dismiss.addEventListener("click", async (e) => {
      e.stopPropagation();
      try {
        await api.dismiss(job.jobID);
        this.onDismissed(job.jobID);
      } catch (err) {
        this.onError(err);
      }
      this.refresh();
    });
    const meta = document.createElement("span");
    meta.className = "job-meta";
    meta.textContent = `${ago(job.created)}${job.status === "failed" && job.message ? ` · ${job.message}` : ""}`;
    li.append(pill, id, dismiss, meta);
    li.addEventListener("click", () => this.onOpen(job));
    return li;
  }
}
