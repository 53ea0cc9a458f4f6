// Times the WebAssembly MRQ decoder (pkg/, tools/viewer/build-wasm.sh) in Node on one file: the
// finest level decoded from the whole file (the coarser levels too, as the format requires) into
// the viewer's typed arrays, as the page's Worker does. Prints one JSON line:
// {"vertices": N, "triangles": N, "medianMs": ms, "bestMs": ms, "runs": N}.
//
//   node tools/viewer/bench-decode.mjs FILE.mrq [RUNS]
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [file, runsArg] = process.argv.slice(2);
if (!file) {
  console.error('usage: node bench-decode.mjs FILE.mrq [RUNS]');
  process.exit(2);
}
const runs = Number(runsArg ?? 15);
const root = path.dirname(fileURLToPath(import.meta.url));
const wasm = await import(path.join(root, 'pkg/octowrap_wasm.js'));
wasm.initSync({ module: await readFile(path.join(root, 'pkg/octowrap_wasm_bg.wasm')) });
const bytes = new Uint8Array(await readFile(file));

function finest() {
  const s = new wasm.MrqStream(Number.MAX_SAFE_INTEGER);
  s.setFileLength(bytes.length);
  s.push(0, bytes);
  const m = s.decode(s.levelCount() - 1);
  const counts = { vertices: m.vertices(), triangles: m.triangleCount() };
  m.takePositions();
  m.takeTriangles();
  m.free();
  s.free();
  return counts;
}

let counts = finest(); // warm-up: compile and first-touch memory
const ms = [];
for (let i = 0; i < runs; i++) {
  const t0 = performance.now();
  counts = finest();
  ms.push(performance.now() - t0);
}
ms.sort((a, b) => a - b);
process.stdout.write(JSON.stringify({ ...counts, medianMs: ms[ms.length >> 1], bestMs: ms[0], runs }) + '\n');
