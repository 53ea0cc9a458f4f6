// The cameras both client pages use, from the tileset's root box and transform, so that the
// 3DTilesRendererJS and CesiumJS pages see the same thing from the same place.
//
// Views are placed in the root tile's frame (z up) and carried to the world by the root transform:
//   far:  the whole model from four times its bounding radius, a little from above;
//   near: from the face of the root box at one end of its longest horizontal axis, at a third of its
//         height, looking along that axis at the other end, so the near end fills the foreground
//         and the far end stays far.
// A view can also be given in the page's URL as `view=ex,ey,ez,tx,ty,tz` (root frame).
// Every view is a square image with a 60-degree field of view (both clients then agree on the
// vertical angle that their screen-space error uses).

export const SIZE = 600;
export const FOV_DEG = 60;

// A client page's state for check-clients.mjs (`window.octowrap`: ready, error, and what the page
// adds), with any uncaught error or rejection kept as the page's error, and the page's parameters:
// `?tileset=URL&errorTarget=PIXELS` (16 by default).
export function pageState() {
  const state = { ready: false, error: null };
  window.octowrap = state;
  window.addEventListener('error', (e) => { state.error = String(e.message || e); });
  window.addEventListener('unhandledrejection', (e) => { state.error = String(e.reason && e.reason.message || e.reason); });
  const params = new URLSearchParams(location.search);
  return { state, params, url: params.get('tileset'), ERROR_TARGET: Number(params.get('errorTarget') || 16) };
}

function apply(m, p) {
  return [0, 1, 2].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
}

function applyDir(m, d) {
  return [0, 1, 2].map((r) => m[r] * d[0] + m[4 + r] * d[1] + m[8 + r] * d[2]);
}

export function views(tileset, given) {
  const b = tileset.root.boundingVolume.box;
  const m = tileset.root.transform || [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
  const c = [b[0], b[1], b[2]];
  const h = [Math.hypot(b[3], b[4], b[5]), Math.hypot(b[6], b[7], b[8]), Math.hypot(b[9], b[10], b[11])];
  const radius = Math.hypot(...h);
  const long = h[0] >= h[1] ? 0 : 1;
  const side = 1 - long;
  const local = {};
  {
    const d = [0, 0, 0];
    d[long] = -0.8;
    d[side] = -0.45;
    d[2] = 0.4;
    const n = Math.hypot(...d);
    local.far = { eye: c.map((x, k) => x + (d[k] / n) * radius * 4), target: c };
  }
  {
    const eye = [...c];
    eye[long] -= h[long] * 1.0;
    eye[2] += h[2] * 0.35;
    const target = [...c];
    target[long] += h[long];
    local.near = { eye, target };
  }
  if (given) {
    const v = given.split(',').map(Number);
    if (v.length === 6 && v.every(Number.isFinite)) local.given = { eye: v.slice(0, 3), target: v.slice(3) };
  }
  const out = {};
  for (const [name, v] of Object.entries(local)) {
    out[name] = { eye: apply(m, v.eye), target: apply(m, v.target), up: applyDir(m, [0, 0, 1]), local: v };
  }
  return { radius, views: out };
}
