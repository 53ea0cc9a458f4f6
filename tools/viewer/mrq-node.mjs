// The WebAssembly MRQ decoder (pkg/, tools/viewer/build-wasm.sh) in Node, for the check and bench
// scripts: the module loaded once, and the finest level of a whole file decoded into the
// viewer's typed arrays, as the page's Worker does.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const root = path.dirname(fileURLToPath(import.meta.url));

/// The wasm-bindgen module, initialized.
export async function loadDecoder() {
  const wasm = await import(path.join(root, 'pkg/octowrap_wasm.js'));
  wasm.initSync({ module: await readFile(path.join(root, 'pkg/octowrap_wasm_bg.wasm')) });
  return wasm;
}

/// The finest level of the MRQ file `bytes` (the coarser levels decoded on the way, as the
/// format requires): `{ vertices, triangles, positions, indices }`.
export function decodeFinest(wasm, bytes) {
  const s = new wasm.MrqStream(Number.MAX_SAFE_INTEGER);
  s.setFileLength(bytes.length);
  s.push(0, bytes);
  const m = s.decode(s.levelCount() - 1);
  const level = { vertices: m.vertices(), triangles: m.triangleCount(), positions: m.takePositions(), indices: m.takeTriangles() };
  m.free();
  s.free();
  return level;
}
