// The HTTP API (/v1/...), as the dashboard uses it. Errors carry the API's {error, detail, path}.

/** An API error response. */
export class ApiError extends Error {
  constructor(status, body) {
    super(body && body.detail ? body.detail : `HTTP ${status}`);
    this.status = status;
    this.code = body && body.error;
    this.path = body && body.path;
  }
}

function authHeaders() {
  const token = sessionStorage.getItem("wsm-token");
  return token ? { Authorization: `Bearer ${token}` } : {};
}

/** Whether the user gave a token (the server may then require it on reads too). */
export function hasToken() {
  return Boolean(sessionStorage.getItem("wsm-token"));
}

/**
 * Save the file at `url` under `filename`, fetched with the token (a plain link cannot send the
 * Authorization header).
 */
export async function download(url, filename) {
  const response = await fetch(url, { headers: authHeaders() });
  if (!response.ok) {
    let body = null;
    try {
      body = await response.json();
    } catch {
      /* not JSON */
    }
    throw new ApiError(response.status, body);
  }
  const link = document.createElement("a");
  link.href = URL.createObjectURL(await response.blob());
  link.download = filename;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(link.href), 10000);
}

async function request(method, url, body) {
  const init = { method, headers: { Accept: "application/json", ...authHeaders() } };
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  const response = await fetch(url, init);
  const text = await response.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = { error: "malformed_response", detail: text.slice(0, 200) };
  }
  if (!response.ok) throw new ApiError(response.status, data);
  return data;
}

export const api = {
  labels: () => request("GET", "/v1/labels"),
  examples: () => request("GET", "/v1/examples"),
  example: (name) => request("GET", `/v1/examples/${encodeURIComponent(name)}`),
  jobs: () => request("GET", "/v1/jobs?limit=50"),
  job: (id) => request("GET", `/v1/jobs/${id}`),
  result: (id) => request("GET", `/v1/jobs/${id}/result`),
  history: (id) => request("GET", `/v1/jobs/${id}/history`),
  scene: (id) => request("GET", `/v1/jobs/${id}/scene`),
  fields: (id, scenario, criterion) =>
    request("GET", `/v1/jobs/${id}/fields?scenario=${scenario}&criterion=${criterion}`),
  submit: (body) => request("POST", "/v1/jobs", body),
  solve: (body) => request("POST", "/v1/solve", body),
  cancel: (id) => request("POST", `/v1/jobs/${id}/cancel`),
  eventsUrl: (id) => `/v1/jobs/${id}/events`,
  resultUrl: (id) => `/v1/jobs/${id}/result`,
  csvUrl: (id) => `/v1/jobs/${id}/evaluations?format=csv`,
  vtuUrl: (id, scenario, criterion) =>
    `/v1/jobs/${id}/fields?scenario=${scenario}&criterion=${criterion}&format=vtu`,
};
