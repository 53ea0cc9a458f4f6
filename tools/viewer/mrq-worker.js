// The MRQ viewer's Web Worker: fetches the byte ranges the WebAssembly decoder names
// (crates/wasm), and posts triangle arrays to the page (transferred, not copied).
//
// Two modes. View (chunked files, format version 5, with more chunks than levels): for each
// camera the page sends, the chunks the view needs (fine where it looks, coarse farther away,
// none out of view), fetched by range, and their crack-free cut (spec §11.5). Levels (other
// files, or `mode: 'levels'`): each level as its bytes complete, coarse to fine; the next range
// is in flight while a level decodes. `mode: 'auto'` (the default) chooses after the preamble.
//
// Messages in:  {type: 'open', url, budget, mode}     mode: 'auto', 'view' or 'levels';
//                                                     budget: bytes of decoding memory (levels)
//                                                     or of file bytes held (view)
//               {type: 'view', id, camera, aspect}    camera: eye, target, up, fov_y, viewport
//                                                     height, pixel error (12 numbers)
// Messages out: {type: 'info', levels: [{offset, stored, vertices, faces}], cube, mode, bounds, chunks}
//               {type: 'level', level, vertices, faces, triangles, positions, indices, decodeMs, stats}
//               {type: 'cut', id, level, drawn, finestDrawn, refined, unresolved, faces, triangles,
//                positions, indices, decodeMs, held, stats}
//               {type: 'done', stats} | {type: 'error', message, stats}
// stats: {requests, bytes, total}, counted when each response has arrived (total: the file's length).
import init, { MrqStream, MrqView } from './pkg/octowrap_wasm.js';
import { fetchRange } from './mrq-loader.js';

const ready = init({ module_or_path: new URL('./pkg/octowrap_wasm_bg.wasm', import.meta.url) });
const stats = { requests: 0, bytes: 0, total: null };
let view = null; // {v: MrqView, url, pending, busy}

const message = (err) => (err && err.message ? err.message : String(err));

self.onmessage = async (e) => {
  if (e.data.type === 'view') {
    if (view) {
      view.pending = e.data;
      if (!view.busy) runViews();
    }
    return;
  }
  if (e.data.type !== 'open') return;
  try {
    await ready;
    if (e.data.mode === 'levels') {
      await stream(e.data.url, e.data.budget, []);
      self.postMessage({ type: 'done', stats });
      return;
    }
    // View mode for chunked files (asked for, or `auto` and the file has more chunks than
    // levels); otherwise the levels, from the preamble bytes already here.
    const { v, pieces } = await preamble(e.data.url, e.data.budget);
    if (e.data.mode === 'view' || (v.version() >= 5 && v.chunkCount() > v.levelCount())) {
      openView(e.data.url, v);
      return;
    }
    v.free();
    await stream(e.data.url, e.data.budget, pieces);
    self.postMessage({ type: 'done', stats });
  } catch (err) {
    self.postMessage({ type: 'error', message: message(err), stats });
  }
};

// Fetches `ranges` ([start, end, start, end, ...]) in parallel into the view; returns the pieces
// as [start, bytes, total].
async function fetchInto(v, url, ranges) {
  const got = [];
  for (let i = 0; i < ranges.length; i += 2) {
    got.push(fetchRange(url, ranges[i], ranges[i + 1], stats).then((r) => [ranges[i], r]));
  }
  const pieces = [];
  for (const [start, r] of await Promise.all(got)) {
    stats.total = r.total;
    if (r.total !== null) v.setFileLength(r.total);
    v.push(start, r.bytes);
    pieces.push([start, r.bytes, r.total]);
  }
  return pieces;
}

// The file's preamble, into a view (and the pieces fetched, for the level stream).
async function preamble(url, budget) {
  const v = new MrqView(budget);
  const pieces = [];
  while (!v.isOpen()) {
    const r = v.nextRanges();
    if (!r.length) throw new Error(`${url}: no MRQ preamble`);
    pieces.push(...await fetchInto(v, url, r));
  }
  return { v, pieces };
}

// View mode: one cut per camera the page sends (the latest wins).
function openView(url, v) {
  view = { v, url, pending: null, busy: false };
  self.postMessage({
    type: 'info', mode: 'view', levels: [], cube: null, bounds: v.bounds(), chunks: v.chunkCount(),
    levelCount: v.levelCount(), version: v.version(),
  });
}

async function runViews() {
  view.busy = true;
  try {
    while (view.pending) {
      const req = view.pending;
      view.pending = null;
      await cutFor(req);
    }
  } catch (err) {
    self.postMessage({ type: 'error', message: message(err), stats });
  }
  view.busy = false;
}

async function cutFor(req) {
  const { v, url } = view;
  v.select(Float64Array.from(req.camera), req.aspect);
  for (let round = 0; round < 16; round++) {
    const r = v.nextRanges();
    if (r.length) await fetchInto(v, url, r);
    const t0 = performance.now();
    const m = v.cut();
    if (!m) continue;
    const [drawn, finestDrawn, level, refined, unresolved] = v.lastCut();
    const counts = { faces: m.faces(), triangles: m.triangleCount(), vertices: m.vertices() };
    const positions = m.takePositions();
    const indices = m.takeTriangles();
    m.free();
    self.postMessage({
      type: 'cut', id: req.id, level, drawn, finestDrawn, refined, unresolved, ...counts, positions, indices,
      decodeMs: performance.now() - t0, held: v.held(), stats: { ...stats },
    }, [positions.buffer, indices.buffer]);
    return;
  }
  throw new Error('the cut still misses chunks after 16 rounds of range requests');
}

// Level mode: `pieces` ([start, bytes, total], from offset 0 on) are the bytes already fetched.
async function stream(url, budget, pieces) {
  const s = new MrqStream(budget);
  const have = pieces.slice();
  let range = have.length ? null : s.nextRange();
  let inflight = range && fetchRange(url, range[0], range[1], stats);
  let shown = -1;
  let infoSent = false;
  while (have.length || inflight) {
    let got;
    if (have.length) {
      const [start, bytes, total] = have.shift();
      range = [start, start + bytes.length];
      got = { bytes, total };
    } else {
      got = await inflight;
    }
    stats.total = got.total;
    if (got.total !== null) s.setFileLength(got.total);
    s.push(range[0], got.bytes);
    if (have.length) continue;
    if (!infoSent && s.levelCount() > 0) {
      infoSent = true;
      const levels = [];
      for (let k = 0; k < s.levelCount(); k++) {
        const [offset, stored, vertices, faces] = s.levelInfo(k);
        levels.push({ offset, stored, vertices, faces, memory: s.memoryEstimate(k) });
      }
      self.postMessage({ type: 'info', levels, cube: s.cube() ?? null });
    }
    // Ask for the next range before decoding, so that it arrives while the level decodes; a
    // failure (a truncated file) is reported after the levels already complete are shown.
    let failure = null;
    try {
      range = s.nextRange();
      inflight = range ? fetchRange(url, range[0], range[1], stats) : null;
      if (inflight) inflight.catch(() => {});
    } catch (err) {
      failure = err;
      inflight = null;
    }
    let k = s.readyLevel();
    if (k !== undefined && k > shown) {
      const t0 = performance.now();
      let m = null;
      try {
        m = s.decode(k);
      } catch (err) {
        // A damaged level: show the finest intact level above it, then report the damage.
        failure = failure ?? err;
        for (k -= 1; k > shown && m === null; ) {
          try { m = s.decode(k); } catch { k -= 1; }
        }
        if (m === null) throw failure;
      }
      shown = k;
      // The counts first: taking the arrays leaves the decoded level empty.
      const counts = { vertices: m.vertices(), faces: m.faces(), triangles: m.triangleCount() };
      const positions = m.takePositions();
      const indices = m.takeTriangles();
      const msg = {
        type: 'level', level: k, ...counts, positions, indices, decodeMs: performance.now() - t0, stats: { ...stats },
      };
      m.free();
      self.postMessage(msg, [positions.buffer, indices.buffer]);
    }
    if (failure) throw failure;
  }
  s.free();
}
