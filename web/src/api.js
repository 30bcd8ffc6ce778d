// The server's REST routes and WebSocket stream (docs/web-ui.md#routes). The page's ?token= (when
// `cdff serve --listen` requires one) goes with every request.

const token = new URLSearchParams(window.location.search).get('token');

function withToken(path, params = {}) {
  const query = new URLSearchParams();
  for (const [key, value] of Object.entries(params)) {
    for (const v of [].concat(value)) if (v !== undefined && v !== '') query.append(key, v);
  }
  if (token) query.set('token', token);
  const q = query.toString();
  return q ? `${path}?${q}` : path;
}

/** GET a JSON route; throws the server's {"error"} message on a refusal. */
export async function getJson(path, params) {
  const response = await fetch(withToken(path, params));
  const body = await response.json();
  if (!response.ok) throw new Error(`${path}: ${body.error ?? response.statusText}`);
  return body;
}

/** GET a binary route (a mesh body) as an ArrayBuffer; throws the server's {"error"} message. */
export async function getBinary(path, params) {
  const response = await fetch(withToken(path, params));
  if (!response.ok) {
    const body = await response.json().catch(() => ({}));
    const error = new Error(`${path}: ${body.error ?? response.statusText}`);
    error.status = response.status;
    throw error;
  }
  return response.arrayBuffer();
}

/** A JSON request (POST, DELETE...) with an optional JSON body; throws the server's error. */
export async function sendJson(method, path, body) {
  const init = { method };
  if (body !== undefined) {
    init.headers = { 'Content-Type': 'application/json' };
    init.body = JSON.stringify(body);
  }
  const response = await fetch(withToken(path), init);
  const answer = await response.json();
  if (!response.ok) throw new Error(`${method} ${path}: ${answer.error ?? response.statusText}`);
  return answer;
}

export function url(path, params) {
  return withToken(path, params);
}

/** A WebSocket on the same server (ws: for http:, wss: behind an https proxy). */
export function openSocket(path, params) {
  const scheme = window.location.protocol === 'https:' ? 'wss:' : 'ws:';
  const socket = new WebSocket(`${scheme}//${window.location.host}${withToken(path, params)}`);
  socket.binaryType = 'arraybuffer';
  return socket;
}

/** A binary frame: 4 bytes of header length (little endian), a JSON header, the payload. */
export function splitFrame(buffer) {
  const length = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  return { header, payload: new Uint8Array(buffer, 4 + length) };
}
