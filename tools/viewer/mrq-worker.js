// The MRQ viewer's Web Worker: fetches the byte ranges the WebAssembly stream names
// (crates/wasm), decodes each level as its bytes complete, and posts the triangle arrays to the
// page (transferred, not copied). The next range is in flight while a level decodes.
//
// Messages in:  {type: 'open', url, budget}          budget: bytes of decoding memory
// Messages out: {type: 'info', levels: [{offset, stored, vertices, faces}], cube}
//               {type: 'level', level, vertices, faces, triangles, positions, indices, decodeMs, stats}
//               {type: 'done', stats} | {type: 'error', message, stats}
// stats: {requests, bytes, total}, counted when each response has arrived (total: the file's length).
import init, { MrqStream } from './pkg/octowrap_wasm.js';
import { fetchRange } from './mrq-loader.js';

const ready = init({ module_or_path: new URL('./pkg/octowrap_wasm_bg.wasm', import.meta.url) });

self.onmessage = async (e) => {
  if (e.data.type !== 'open') return;
  const stats = { requests: 0, bytes: 0, total: null };
  try {
    await ready;
    await stream(e.data.url, e.data.budget, stats);
    self.postMessage({ type: 'done', stats });
  } catch (err) {
    self.postMessage({ type: 'error', message: err && err.message ? err.message : String(err), stats });
  }
};

async function stream(url, budget, stats) {
  const s = new MrqStream(budget);
  let range = s.nextRange();
  let inflight = range && fetchRange(url, range[0], range[1], stats);
  let shown = -1;
  let infoSent = false;
  while (inflight) {
    const got = await inflight;
    stats.total = got.total;
    if (got.total !== null) s.setFileLength(got.total);
    s.push(range[0], got.bytes);
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
