// The parameter form, built from the service's own description of the mesh process
// (GET /processes/mesh): its smoothing methods, fitness functions, defaults and bounds, so the
// page offers exactly what the service accepts.

/** Which smoothing parameters matter to which method (the others are hidden). */
const GA_FIELDS = ["population", "generations", "crossover_rate", "mutation_rate", "tolerance", "max_sweeps", "threshold"];
const FITNESS_FIELDS = ["fitness", "alpha", "beta"];
const LABELS = {
  population: "Population",
  generations: "Generations",
  crossover_rate: "Crossover rate",
  mutation_rate: "Mutation rate",
  tolerance: "Tolerance",
  max_sweeps: "Max sweeps",
  threshold: "Fitness threshold",
  fitness: "Fitness function",
  alpha: "α (angle weight)",
  beta: "β (aspect weight)",
  iterations: "Iterations",
  seed: "Seed",
};

function relevant(method, name) {
  if (name === "seed") return method !== "none";
  if (FITNESS_FIELDS.includes(name)) return true; // the node fitness is computed for every mesh
  if (GA_FIELDS.includes(name)) return method === "ga";
  if (name === "iterations") return method !== "ga" && method !== "none";
  return method !== "none";
}

/** The number (or enum) schema inside a property schema (optional ones are anyOf [x, null]). */
function core(schema) {
  if (schema.anyOf) return schema.anyOf.find((s) => s.type && s.type !== "null") || schema;
  return schema;
}

export class ParamsForm {
  constructor(form, description) {
    this.form = form;
    const inputs = description.inputs;
    const smoothing = inputs.smoothing.schema.properties;
    this.fields = {};
    form.growth.value = inputs.growth.schema.default ?? 1.2;
    this._bounds(form.growth, inputs.growth.schema);
    form.swap.checked = inputs.swap.schema.default !== false;
    const methods = smoothing.method.enum || [smoothing.method.default];
    for (const m of methods) form.method.add(new Option(m === "ga" ? "ga (genetic algorithm)" : m, m));
    const preferred = [smoothing.method.default, "ga"].find((m) => methods.includes(m));
    form.method.value = preferred || methods[0];
    form.method.title = smoothing.method.description || "";
    const box = form.querySelector("#smoothing-fields");
    for (const [name, schema] of Object.entries(smoothing)) {
      if (name === "method") continue;
      box.append(this._field(name, schema));
    }
    form.method.addEventListener("change", () => this._showRelevant());
    this._showRelevant();
  }

  /** Put a job's inputs back in the form; smoothing fields it did not send go back to defaults. */
  setValues(inputs) {
    const f = this.form;
    const smoothing = inputs.smoothing || {};
    if (inputs.swap !== undefined) f.swap.checked = inputs.swap !== false;
    if (inputs.growth !== undefined) f.growth.value = inputs.growth;
    if (f.crs) f.crs.value = inputs.crs || "";
    if ([...f.method.options].some((o) => o.value === smoothing.method)) f.method.value = smoothing.method;
    for (const [name, field] of Object.entries(this.fields)) {
      const v = smoothing[name];
      field.input.value = v === undefined || v === null ? field.initial : String(v);
    }
    this._showRelevant();
  }

  _bounds(input, schema) {
    const s = core(schema);
    if (s.minimum !== undefined) input.min = s.minimum;
    if (s.exclusiveMinimum !== undefined) input.min = s.exclusiveMinimum;
    if (s.maximum !== undefined) input.max = s.maximum;
    input.step = s.type === "integer" ? "1" : "any";
  }

  _field(name, schema) {
    const wrap = document.createElement("div");
    const label = document.createElement("label");
    label.textContent = LABELS[name] || name.replace(/_/g, " ");
    label.htmlFor = `p-${name}`;
    let input;
    const s = core(schema);
    if (s.enum) {
      input = document.createElement("select");
      for (const v of s.enum) input.add(new Option(v, v));
      input.value = schema.default ?? s.enum[0];
    } else {
      input = document.createElement("input");
      input.type = "number";
      this._bounds(input, schema);
      if (schema.default !== undefined && schema.default !== null) input.value = schema.default;
      else input.placeholder = name === "seed" ? "random" : "off";
    }
    input.id = `p-${name}`;
    input.name = name;
    input.title = schema.description || "";
    wrap.append(label, input);
    this.fields[name] = { wrap, input, integer: s.type === "integer", initial: input.value };
    return wrap;
  }

  _showRelevant() {
    const method = this.form.method.value;
    for (const [name, field] of Object.entries(this.fields)) field.wrap.hidden = !relevant(method, name);
  }

  /** The mesh process's inputs from the form (the boundary and size are added by the caller). */
  values() {
    const f = this.form;
    const smoothing = { method: f.method.value };
    for (const [name, field] of Object.entries(this.fields)) {
      if (field.wrap.hidden || field.input.value === "") continue;
      const raw = field.input.value;
      smoothing[name] = field.input.tagName === "SELECT" ? raw : field.integer ? parseInt(raw, 10) : Number(raw);
    }
    const inputs = { swap: f.swap.checked, smoothing };
    // Planar regions send no crs: the service meshes plain x, y as before.
    const crs = f.crs ? f.crs.value.trim() : "";
    if (crs) inputs.crs = crs;
    if (f.growth.value !== "") inputs.growth = Number(f.growth.value);
    return inputs;
  }

  /** The input a JSON pointer of a problem points at, if the form has it. */
  inputAt(pointer) {
    const m = /^\/inputs\/(?:smoothing\/)?([a-z_]+)/.exec(pointer || "");
    if (!m) return null;
    if (this.fields[m[1]]) return this.fields[m[1]].input;
    return this.form.elements.namedItem(m[1]);
  }
}
