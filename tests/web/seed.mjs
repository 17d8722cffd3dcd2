// Puts the test scene into a running server over its REST API, as an admin and a vehicle
// would: import the prior map, upload one session of the changed scene, commit, wait.
import * as S from './scene.mjs';

async function call(base, token, method, path, { json, body, type } = {}) {
  const headers = { Authorization: `Bearer ${token}` };
  if (json !== undefined) headers['Content-Type'] = 'application/json';
  if (type) headers['Content-Type'] = type;
  const res = await fetch(base + path, {
    method, headers, body: json !== undefined ? JSON.stringify(json) : body,
  });
  const text = await res.text();
  if (!res.ok) throw new Error(`${method} ${path}: HTTP ${res.status}: ${text.slice(0, 300)}`);
  return text ? JSON.parse(text) : {};
}

export function api(base, token) {
  return {
    get: (p) => call(base, token, 'GET', p),
    post: (p, json) => call(base, token, 'POST', p, { json }),
    bytes: async (p) => {
      const res = await fetch(base + p, { headers: { Authorization: `Bearer ${token}` } });
      if (!res.ok) throw new Error(`GET ${p}: HTTP ${res.status}: ${(await res.text()).slice(0, 300)}`);
      return res.arrayBuffer();
    },
  };
}

export async function importPrior(base, adminToken, log) {
  const points = S.sampleBoxes(S.PRIOR_BOXES, 0.5).map(S.toMap);
  const frame = `origin=${S.MAP_ORIGIN.join(',')}&crs=${S.MAP_CRS}`;
  const r = await call(base, adminToken, 'POST', `/v1/admin/prior?format=pcd&${frame}`,
    { body: S.pcdAscii(points), type: 'application/octet-stream' });
  log(`prior imported: ${points.length} points -> ${JSON.stringify(r)}`);
  return r;
}

export async function uploadSession(base, vehicleToken, log, { timeoutMs = 120000 } = {}) {
  const cam = S.CAMERA;
  const { session_id: id } = await call(base, vehicleToken, 'POST', '/v1/sessions', {
    json: { vehicle_id: 'web-e2e-car', camera: cam, depth_scale: 1000 },
  });
  const positions = S.keyframePositions();
  for (const [seq, pos] of positions.entries()) {
    const depth = S.renderDepth(S.CHANGED_BOXES, pos);
    const form = new FormData();
    const meta = {
      t_ns: 1_000_000_000 + seq * 200_000_000,
      T_map_cam: { t: S.toMap(pos), q: S.Q_MAP_CAM },
      covariance: null,
    };
    form.append('meta', new Blob([JSON.stringify(meta)], { type: 'application/json' }), 'meta.json');
    form.append('depth', new Blob([S.png16(depth, cam.width, cam.height)], { type: 'image/png' }), `${seq}.png`);
    const res = await fetch(`${base}/v1/sessions/${id}/keyframes/${seq}`, {
      method: 'PUT', headers: { Authorization: `Bearer ${vehicleToken}` }, body: form,
    });
    if (!res.ok) throw new Error(`PUT keyframe ${seq}: HTTP ${res.status}: ${await res.text()}`);
  }
  log(`session ${id}: ${positions.length} keyframes uploaded`);
  const commit = await call(base, vehicleToken, 'POST', `/v1/sessions/${id}/commit`, { json: {} });
  const t0 = Date.now();
  for (;;) {
    const s = await call(base, vehicleToken, 'GET', `/v1/sessions/${id}`);
    const state = s.state ?? s.session?.state;
    if (state === 'committed') { log(`session ${id} committed in ${Date.now() - t0} ms`); return { id, ...commit, session: s }; }
    if (state === 'failed') throw new Error(`session ${id} commit failed: ${JSON.stringify(s)}`);
    if (Date.now() - t0 > timeoutMs) throw new Error(`session ${id} not committed after ${timeoutMs} ms: ${JSON.stringify(s)}`);
    await new Promise((r) => setTimeout(r, 300));
  }
}
