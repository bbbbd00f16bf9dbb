// Talking to the service: one place that turns failures into readable messages.
//
// Every 4xx/5xx answer of softgrasp has the body {"error": {"code", "message", "field"}}; the
// page shows that message as it is, naming the field at fault.

/** An error answer of the API, or a failure to reach it. */
export class ApiError extends Error {
  constructor(status, code, message, field = '') {
    super(message);
    this.name = 'ApiError';
    this.status = status;
    this.code = code;
    this.field = field;
  }
}

/** Reads an error body; falls back to the status line when the body is not the API's JSON. */
export function parseErrorBody(status, statusText, bodyText) {
  try {
    const body = JSON.parse(bodyText);
    const e = body && body.error;
    if (e && typeof e.message === 'string') {
      return new ApiError(status, String(e.code || 'error'), e.message, e.field ? String(e.field) : '');
    }
  } catch {
    // not JSON: fall through
  }
  const line = `${status} ${statusText || ''}`.trim();
  return new ApiError(status, 'http_error', `The service answered ${line}.`);
}

/** One line for a person: the API's message, then the field it concerns. */
export function describeError(error) {
  if (error instanceof ApiError) {
    return error.field ? `${error.message} (field: ${error.field})` : error.message;
  }
  if (error && error.name === 'AbortError') return 'The request took too long and was stopped.';
  return `Could not reach the service: ${error && error.message ? error.message : error}`;
}

const DEFAULT_TIMEOUT_MS = 120_000;

/**
 * fetch() that throws ApiError for non-2xx answers and for network failures.
 * @returns {Promise<Response>}
 */
export async function call(url, init = {}, timeoutMs = DEFAULT_TIMEOUT_MS) {
  const controller = new AbortController();
  const timer = setTimeout(() => controller.abort(), timeoutMs);
  let response;
  try {
    response = await fetch(url, { ...init, signal: controller.signal });
  } catch (error) {
    clearTimeout(timer);
    if (error && error.name === 'AbortError') throw error;
    throw new ApiError(0, 'network', describeError(error));
  }
  if (!response.ok) {
    const text = await response.text().catch(() => '');
    clearTimeout(timer);
    const error = parseErrorBody(response.status, response.statusText, text);
    // 503 from the robot routes says when a robot may be back (docs/robot-api.md).
    const retryAfterS = Number(response.headers.get('Retry-After'));
    if (Number.isFinite(retryAfterS) && retryAfterS > 0) error.retryAfterS = retryAfterS;
    throw error;
  }
  clearTimeout(timer);
  return response;
}

/** GET /v1/info: version, limits, defaults, strategies, formats. */
export async function fetchInfo() {
  return (await call('/v1/info')).json();
}

/** The file name in a Content-Disposition header, or `fallback`. */
export function fileNameFromDisposition(header, fallback) {
  if (!header) return fallback;
  const quoted = /filename="([^"]+)"/i.exec(header);
  const bare = /filename=([^;\s]+)/i.exec(header);
  const name = quoted ? quoted[1] : bare ? bare[1] : '';
  // Only a plain name: the browser would strip paths anyway, but keep it tidy.
  const base = name.split(/[\\/]/).pop();
  return base || fallback;
}
