// Small fetch wrappers for the ArtRo Gait Studio REST API.
// Every call resolves to parsed JSON or throws an ApiError carrying the HTTP status and the
// server's human-readable `detail` (a string, or FastAPI's list of validation errors).

export class ApiError extends Error {
  constructor(status, detail, raw = null) {
    super(detail);
    this.status = status;
    this.detail = detail;
    this.raw = raw; // the server's `detail` as sent: a list of {loc, msg} for validation errors
  }
}

/** "gait.swing.v" for a FastAPI / import problem's `loc`; "" where it names no field of a body
 *  (the URL's path or query, a header, a job): the message says it in words. */
export const locText = (loc) => {
  if (!Array.isArray(loc) || ["path", "query", "header", "job"].includes(loc[0])) return "";
  return loc.filter((p) => p !== "body").join(".");
};

// The API's messages name the endpoint that mends a refusal, for API clients; the page names its
// own control instead (or nothing, where it has none).
const PAGE_WORDS = [
  [/ \(POST \/api\/sim\/reset\)/g, " (⟲ Reset)"],
  [/ \(POST \/api\/recording\/live(?:, 'Back to live')?\)/g, " ('Back to live')"],
  [/ \(DELETE \/api\/jobs\/[\w-]+(?: or DELETE \/api\/jobs\/[\w-]+)*\)/g, " (its Cancel button)"],
  [/ \(PUT \/api\/sim\/drive\)/g, " (pulses: model, at the top)"],
  [/ \(PUT \/api\/robot\)/g, " (the World panel's robot)"],
  [/POST \/api\/jobs\/(?:\{id\}|[\w-]+)\/apply with the version to apply it onto/g, "'Apply it anyway' applies it"],
  [/; GET \/api\/params and try again/g, "; try again"],
  [/ \((?:GET|POST|PUT|PATCH|DELETE) \/api\/[^)]*\)/g, ""],
];

/** A server message in the page's words: its controls where the API names an endpoint. */
export function pageWords(text) {
  return PAGE_WORDS.reduce((t, [pattern, words]) => t.replace(pattern, words), String(text));
}

/** Turn FastAPI's `detail` (string | [{loc, msg}, ...] | object) into one readable line. */
export function formatDetail(detail) {
  if (detail == null) return "";
  if (typeof detail === "string") return detail;
  if (Array.isArray(detail)) {
    return detail
      .map((d) => {
        const loc = locText(d.loc);
        return loc ? `${loc}: ${d.msg}` : d.msg || JSON.stringify(d);
      })
      .join("; ");
  }
  return JSON.stringify(detail);
}

async function request(method, path, { json, body, headers } = {}) {
  const init = { method, headers: { ...(headers || {}) } };
  if (json !== undefined) {
    init.body = JSON.stringify(json);
    init.headers["Content-Type"] = "application/json";
  } else if (body !== undefined) {
    init.body = body;
  }
  let res;
  try {
    res = await fetch(path, init);
  } catch (err) {
    throw new ApiError(0, `server unreachable (${err.message})`);
  }
  const text = await res.text();
  let data = null;
  if (text) {
    try {
      data = JSON.parse(text);
    } catch {
      data = text;
    }
  }
  if (!res.ok) {
    const detail = data && typeof data === "object" && "detail" in data ? data.detail : data;
    throw new ApiError(res.status, formatDetail(detail) || `${res.status} ${res.statusText}`, detail);
  }
  return data;
}

export const api = {
  get: (path) => request("GET", path),
  post: (path, json) => request("POST", path, json === undefined ? {} : { json }),
  put: (path, json) => request("PUT", path, json === undefined ? {} : { json }),
  patch: (path, json, headers) => request("PATCH", path, { json, headers }),
  del: (path) => request("DELETE", path),
  /** POST raw bytes (file upload) with an explicit Content-Type. */
  postRaw: (path, body, contentType) =>
    request("POST", path, { body, headers: { "Content-Type": contentType } }),
};

/** Call `fn` now and every `ms` milliseconds; never overlaps two calls. Returns a stop function. */
export function poll(fn, ms) {
  let stopped = false;
  let timer = null;
  const tick = async () => {
    try {
      await fn();
    } catch (err) {
      console.debug("poll:", err);
    }
    if (!stopped) timer = setTimeout(tick, ms);
  };
  tick();
  return () => {
    stopped = true;
    clearTimeout(timer);
  };
}
