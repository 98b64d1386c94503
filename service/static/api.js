// The service's HTTP API, as the page uses it. URLs are relative to the page, so the viewer
// works wherever the service is mounted. Errors are RFC 9457 problems: ApiError carries one.

const KEY_STORAGE = "evomesh.apiKey";

export class ApiError extends Error {
  /** @param {object} problem an RFC 9457 document (or one made up for a network failure) */
  constructor(problem) {
    super(problem.detail || problem.title || "request failed");
    this.problem = problem;
    this.status = problem.status || 0;
  }

  /** "Title: detail", as the command line prints it. */
  get oneLine() {
    const { title, detail } = this.problem;
    return title && detail ? `${title}: ${detail}` : title || detail || "request failed";
  }
}

export function apiKey() {
  try {
    return localStorage.getItem(KEY_STORAGE) || "";
  } catch {
    return "";
  }
}

export function setApiKey(key) {
  try {
    if (key) localStorage.setItem(KEY_STORAGE, key);
    else localStorage.removeItem(KEY_STORAGE);
  } catch {
    /* storage may be off (private windows): the key lasts for this page only */
  }
}

/** An absolute URL of an API path such as "jobs/abc" (no leading slash: relative to the page). */
export function url(path, params) {
  const u = new URL(path.replace(/^\//, ""), document.baseURI);
  for (const [k, v] of Object.entries(params || {})) u.searchParams.set(k, v);
  return u.toString();
}

/**
 * JSON.parse, except that seeds stay exact: they are 63-bit integers, more than a double holds,
 * so they are read as strings.
 */
export function parseJson(text) {
  return JSON.parse(text.replace(/"seed":\s*(\d{16,})/g, '"seed":"$1"'));
}

async function request(method, path, { body, params, as = "json", signal } = {}) {
  const headers = { Accept: as === "json" ? "application/json" : "*/*" };
  const key = apiKey();
  if (key) headers["X-API-Key"] = key;
  if (body !== undefined) headers["Content-Type"] = "application/json";
  let response;
  try {
    response = await fetch(url(path, params), {
      method,
      headers,
      body: body === undefined ? undefined : JSON.stringify(body),
      signal,
    });
  } catch (err) {
    if (err.name === "AbortError") throw err;
    throw new ApiError({ title: "Service unreachable", detail: String(err.message || err) });
  }
  if (!response.ok) {
    let problem = { title: response.statusText || `HTTP ${response.status}`, status: response.status };
    try {
      problem = { ...problem, ...(await response.json()) };
    } catch {
      /* not a problem document */
    }
    throw new ApiError(problem);
  }
  if (as === "json") return parseJson(await response.text());
  if (as === "blob") return response.blob();
  return response;
}

export const api = {
  processDescription: (id) => request("GET", `processes/${id}`),
  execute: (id, inputs) => request("POST", `processes/${id}/execution`, { body: { inputs } }),
  job: (id, signal) => request("GET", `jobs/${encodeURIComponent(id)}`, { signal }),
  jobs: (limit = 15) => request("GET", "jobs", { params: { limit } }),
  dismiss: (id) => request("DELETE", `jobs/${encodeURIComponent(id)}`),
  results: (id, signal) => request("GET", `jobs/${encodeURIComponent(id)}/results`, { signal }),
  resultBlob: (id, params) =>
    request("GET", `jobs/${encodeURIComponent(id)}/results`, { params, as: "blob" }),
};

/** The link of a result format (downloads without an API key are plain links). */
export function resultUrl(id, params) {
  return url(`jobs/${encodeURIComponent(id)}/results`, params);
}
