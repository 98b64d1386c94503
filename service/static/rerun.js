// What a job was asked for, so opening it puts its region and parameters back in the form (to
// rerun it with tweaks). The service keeps a job's parameters in its result's summary, not its
// region: the page remembers what it submitted itself, in this browser, by job id.

const PREFIX = "evomesh.job.";
const INDEX = "evomesh.jobs";
/** Jobs remembered; the oldest are forgotten first (a region can be large). */
const KEEP = 30;

/** Remember the inputs submitted for a job and the region's text as it was typed. */
export function remember(id, inputs, regionText) {
  try {
    const ids = JSON.parse(localStorage.getItem(INDEX) || "[]").filter((i) => i !== id);
    ids.push(id);
    for (const old of ids.splice(0, Math.max(0, ids.length - KEEP))) localStorage.removeItem(PREFIX + old);
    localStorage.setItem(PREFIX + id, JSON.stringify({ inputs, regionText }));
    localStorage.setItem(INDEX, JSON.stringify(ids));
  } catch {
    /* storage off or full: the job still runs, it just cannot be restored later */
  }
}

/**
 * What a job was asked for: {inputs, regionText} from this browser's memory, else the parameters
 * its result's summary holds ({inputs: {swap, smoothing}}, no region), else null.
 */
export function recall(id, doc = null) {
  try {
    const saved = localStorage.getItem(PREFIX + id);
    if (saved) return JSON.parse(saved);
  } catch {
    /* storage off: fall back to the result */
  }
  const used = doc && doc.summary && doc.summary.parameters;
  if (!used || !used.smoothing) return null;
  const smoothing = { ...used.smoothing };
  // The seed it ran with, when a double holds it exactly (the form sends numbers; 63-bit seeds
  // arrive as strings and are left out: that rerun draws a new seed).
  const seed = used.seed ?? smoothing.seed;
  if (Number.isSafeInteger(seed)) smoothing.seed = seed;
  else delete smoothing.seed;
  return { inputs: { swap: used.swap, smoothing }, regionText: null };
}
