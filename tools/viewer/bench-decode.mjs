// Times the WebAssembly MRQ decoder (pkg/, tools/viewer/build-wasm.sh) in Node on one file: the
// finest level decoded from the whole file (the coarser levels too, as the format requires) into
// the viewer's typed arrays, as the page's Worker does. Prints one JSON line:
// {"vertices": N, "triangles": N, "medianMs": ms, "bestMs": ms, "runs": N}.
//
//   node tools/viewer/bench-decode.mjs FILE.mrq [RUNS]
import { readFile } from 'node:fs/promises';
import { decodeFinest, loadDecoder } from './mrq-node.mjs';

const [file, runsArg] = process.argv.slice(2);
if (!file) {
  console.error('usage: node bench-decode.mjs FILE.mrq [RUNS]');
  process.exit(2);
}
const runs = Number(runsArg ?? 15);
const wasm = await loadDecoder();
const bytes = new Uint8Array(await readFile(file));
const finest = () => {
  const { vertices, triangles } = decodeFinest(wasm, bytes);
  return { vertices, triangles };
};

let counts = finest(); // warm-up: compile and first-touch memory
const ms = [];
for (let i = 0; i < runs; i++) {
  const t0 = performance.now();
  counts = finest();
  ms.push(performance.now() - t0);
}
ms.sort((a, b) => a - b);
process.stdout.write(JSON.stringify({ ...counts, medianMs: ms[ms.length >> 1], bestMs: ms[0], runs }) + '\n');
