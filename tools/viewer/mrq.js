// The MRQ viewer: streams `?src=URL.mrq` through HTTP range requests, decoded by the WebAssembly
// module (crates/wasm) in a Web Worker. A chunked file (format version 5, more chunks than levels)
// streams view-dependently: after a coarse first frame, each camera position fetches the chunks
// its view needs at `px` pixels of screen-space error (fine where it looks, coarse farther away,
// none out of view) and shows them as one crack-free mesh. Other files, or `mode=levels`, stream
// level by level (coarse first), each level shown as soon as its bytes are in, replacing (and
// freeing) the one before. Orbit controls; a panel with bytes fetched, requests, level, chunks,
// faces, frame rate and memory.
//
//   mrq.html?src=URL.mrq[&budget=MB][&mode=auto|view|levels][&px=N][&cam=JSON]
//       budget: decoding memory (levels) or file bytes held (view), MiB (default 512)
//       px: the largest screen-space error in view mode, pixels (default 1)
//       cam: the first view's camera in view mode, JSON {position, target, up, fov_y_degrees}
//            (default: the whole model)
//
// `window.octowrap` is the page's state for tests (tools/viewer/check-mrq.mjs): ready, done,
// error, firstFrame, shown, stats, lastCut, and `crackCheck`, `bench`, `setView`, `viewTo`.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const FOV = 45;
const BACKGROUND = new THREE.Color(0x1e2630);
const params = new URLSearchParams(location.search);
const src = params.get('src');
const budgetMiB = Number(params.get('budget') || 512);
// View mode for chunked files unless `mode=levels`; the worker says which it chose.
const modeAsked = params.get('mode') || 'auto';
let viewMode = modeAsked === 'view';
const pixelError = Number(params.get('px') || 1);
// `cam={"position": [...], "target": [...], "up": [...], "fov_y_degrees": N}`: the first view.
const startCamera = params.get('cam') ? JSON.parse(params.get('cam')) : null;
const panel = document.getElementById('panel');
const errorBox = document.getElementById('error');
const state = {
  ready: false, done: false, error: null, src, budget: budgetMiB * 2 ** 20,
  info: null, shown: [], firstFrame: null, stats: { requests: 0, bytes: 0 }, fps: 0, fileSize: null,
};
window.octowrap = state;

const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = BACKGROUND;
scene.add(new THREE.HemisphereLight(0xffffff, 0x445566, 1.6));
const camera = new THREE.PerspectiveCamera(FOV, window.innerWidth / window.innerHeight, 0.01, 1000);
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(0.5, 1, 1);
camera.add(sun);
scene.add(camera);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = true;
const material = new THREE.MeshStandardMaterial({ color: 0xc8b89a, flatShading: true, roughness: 0.8 });
let mesh = null;
let framed = null; // the bounding sphere the camera was framed on

window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
});

let frames = 0;
let fpsStart = performance.now();
function loop(now) {
  controls.update();
  renderer.render(scene, camera);
  frames += 1;
  if (now - fpsStart >= 1000) {
    state.fps = Math.round((frames * 1000) / (now - fpsStart));
    frames = 0;
    fpsStart = now;
    updatePanel();
  }
  requestAnimationFrame(loop);
}

function kb(n) {
  return n >= 1 << 20 ? `${(n / 2 ** 20).toFixed(1)} MB` : `${(n / 1024).toFixed(1)} KB`;
}

function updatePanel() {
  const s = state.stats;
  const info = state.info;
  const last = state.shown[state.shown.length - 1];
  const total = state.fileSize;
  const lines = [
    `${src}`,
    `bytes fetched  ${kb(s.bytes)}${total ? ` of ${kb(total)} (${((100 * s.bytes) / total).toFixed(0)} %)` : ''} in ${s.requests} range requests`,
    `level          ${last ? last.level : '–'} of ${info ? info.levelCount - 1 : '?'}${state.done ? '' : ' (streaming)'}`,
    viewMode
      ? `chunks         ${state.lastCut ? `${state.lastCut.drawn} drawn (${state.lastCut.finestDrawn} of the finest level) of ${info ? info.chunks : '?'}` : '–'}`
      : `chunks         whole levels (${state.shown.length} decoded)`,
    `faces          ${last ? last.faces.toLocaleString('en') : '–'} (${last ? last.triangles.toLocaleString('en') : '–'} triangles)`,
    viewMode
      ? `memory         ${kb(state.lastCut ? state.lastCut.held : 0)} of the file held, ${kb(state.budget)} budget`
      : `memory         ~${kb(last ? info.levels[last.level].memory : 0)} of ${kb(state.budget)} budget`,
    `frame rate     ${state.fps} fps`,
  ];
  panel.textContent = lines.join('\n');
}

function fail(message) {
  state.error = message;
  errorBox.textContent = `error: ${message}`;
  updatePanel();
}

function frame(geometry) {
  geometry.computeBoundingSphere();
  const sphere = geometry.boundingSphere;
  framed = sphere.clone();
  state.radius = sphere.radius;
  state.setView([0.25, 0.3, 1], 2.6);
}

// Places the camera `factor` radii from the framed centre along `dir`.
state.setView = (dir, factor) => {
  if (!framed) return;
  const d = new THREE.Vector3(...dir).normalize();
  const distance = framed.radius * factor;
  controls.target.copy(framed.center);
  camera.position.copy(framed.center).addScaledVector(d, distance);
  camera.near = Math.max(distance / 100, 1e-6);
  camera.far = distance + framed.radius * 4;
  camera.updateProjectionMatrix();
  camera.lookAt(framed.center);
  controls.update();
  renderer.render(scene, camera);
  if (viewMode) requestView();
};

// View mode: asks the worker for the cut of the current camera (the latest request wins);
// `coarse` asks for a quick first one at 1000 times the error (coarse levels only, one chunk
// each right after the preamble: one more request). Returns the request's id.
let worker = null;
let viewId = 0;
const viewWaiters = new Map();
function requestView(coarse = false) {
  viewId += 1;
  const t = controls.target;
  const cam = [camera.position.x, camera.position.y, camera.position.z, t.x, t.y, t.z,
    camera.up.x, camera.up.y, camera.up.z, camera.fov, renderer.domElement.height, coarse ? 1000 * pixelError : pixelError];
  worker.postMessage({ type: 'view', id: viewId, camera: cam, aspect: camera.aspect });
  return viewId;
}
let viewTimer = null;
controls.addEventListener('change', () => {
  if (!viewMode || !worker || !framed) return;
  clearTimeout(viewTimer);
  viewTimer = setTimeout(() => requestView(), 150);
});

// Places the camera at `position` looking at `target` (`up`, vertical field of view `fov`
// degrees) and, in view mode, resolves with the cut for it once shown.
state.viewTo = (position, target, up, fov) => {
  placeCamera(position, target, up, fov);
  if (!viewMode) return Promise.resolve(null);
  const id = requestView();
  return new Promise((ok) => viewWaiters.set(id, ok));
};

function placeCamera(position, target, up, fov) {
  camera.position.set(...position);
  camera.up.set(...up);
  camera.fov = fov;
  controls.target.set(...target);
  const d = camera.position.distanceTo(controls.target);
  camera.near = Math.max(d / 1000, 1e-6);
  camera.far = d + (framed ? framed.radius * 4 : d * 10);
  camera.updateProjectionMatrix();
  camera.lookAt(controls.target);
  controls.update();
  clearTimeout(viewTimer);
  renderer.render(scene, camera);
}

function geometryOf(positions, indices) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(new THREE.BufferAttribute(indices, 1));
  return g;
}

function show(msg) {
  const g = geometryOf(msg.positions, msg.indices);
  if (mesh) {
    // Eviction: the coarser level's arrays leave the GPU and the heap.
    mesh.geometry.dispose();
    scene.remove(mesh);
  }
  mesh = new THREE.Mesh(g, material);
  scene.add(mesh);
  if (!framed) frame(g);
  renderer.render(scene, camera);
  state.stats = msg.stats;
  state.fileSize = msg.stats.total;
  const entry = { level: msg.level, vertices: msg.vertices, faces: msg.faces, triangles: msg.triangles,
    decodeMs: msg.decodeMs, requests: msg.stats.requests, bytes: msg.stats.bytes, ms: performance.now() };
  state.shown.push(entry);
  if (!state.firstFrame) {
    state.firstFrame = entry;
    state.ready = true;
  }
  updatePanel();
}

// Renders `object` alone, flat white on black, and returns which pixels it covers.
function coverMask(object) {
  const saved = { bg: scene.background, material: object.material, children: scene.children.slice() };
  scene.background = new THREE.Color(0x000000);
  for (const c of saved.children) if (c !== camera) scene.remove(c);
  object.material = new THREE.MeshBasicMaterial({ color: 0xffffff });
  scene.add(object);
  renderer.render(scene, camera);
  const gl = renderer.getContext();
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const mask = new Uint8Array(w * h);
  for (let i = 0; i < mask.length; i++) mask[i] = px[4 * i] > 127 ? 1 : 0;
  object.material.dispose();
  object.material = saved.material;
  scene.remove(object);
  for (const c of saved.children) if (c !== camera) scene.add(c);
  scene.background = saved.bg;
  return mask;
}

let wasmModule = null;
async function wasm() {
  if (!wasmModule) {
    wasmModule = await import('./pkg/octowrap_wasm.js');
    await wasmModule.default({ module_or_path: new URL('./pkg/octowrap_wasm_bg.wasm', import.meta.url) });
  }
  return wasmModule;
}

// The whole file in one plain GET, decoded to its finest level on this thread.
async function finestOf(bytes) {
  const { MrqStream } = await wasm();
  const s = new MrqStream(Number.MAX_SAFE_INTEGER);
  s.setFileLength(bytes.length);
  s.push(0, bytes);
  const k = s.levelCount() - 1;
  const m = s.decode(k);
  const out = { level: k, vertices: m.vertices(), positions: m.takePositions(), indices: m.takeTriangles() };
  m.free();
  s.free();
  return out;
}

// The crack check: pixels covered by a render of the finest level (decoded from the whole file)
// but not by the streamed view, from the same camera, as a fraction of the finest level's pixels.
state.crackCheck = async () => {
  const bytes = new Uint8Array(await (await fetch(src, { cache: 'no-store' })).arrayBuffer());
  const ref = await finestOf(bytes);
  const refMesh = new THREE.Mesh(geometryOf(ref.positions, ref.indices));
  const streamed = coverMask(mesh);
  const finest = coverMask(refMesh);
  refMesh.geometry.dispose();
  let covered = 0, missing = 0, extra = 0;
  for (let i = 0; i < finest.length; i++) {
    covered += finest[i];
    if (finest[i] && !streamed[i]) missing++;
    if (streamed[i] && !finest[i]) extra++;
  }
  renderer.render(scene, camera);
  return { referenceLevel: ref.level, covered, missing, extra, fraction: covered ? missing / covered : 1 };
};

// Decoding speed on this page's main thread: the WebAssembly stream decoding the finest level
// from the whole file (the coarser levels included, as the format requires), against the draco3d
// decoder on `drc` (the same level, Draco-coded), each to typed arrays; the median of `runs`.
state.bench = async (drcBytes, dracoWasm, runs = 9) => {
  const bytes = new Uint8Array(await (await fetch(src, { cache: 'no-store' })).arrayBuffer());
  const median = (xs) => xs.slice().sort((a, b) => a - b)[xs.length >> 1];
  let vertices = 0;
  const wasmMs = [];
  await finestOf(bytes); // warm-up: compile and first-touch memory
  for (let i = 0; i < runs; i++) {
    const t0 = performance.now();
    vertices = (await finestOf(bytes)).vertices;
    wasmMs.push(performance.now() - t0);
  }
  const draco = await dracoDecoder(dracoWasm);
  const dracoMs = [];
  let dracoVertices = 0;
  const decodeDraco = () => {
    const decoder = new draco.Decoder();
    const buffer = new Uint8Array(drcBytes);
    const m = new draco.Mesh();
    const status = decoder.DecodeArrayToMesh(buffer, buffer.length, m);
    if (!status.ok()) throw new Error(`draco: ${status.error_msg()}`);
    const n = m.num_points();
    const attr = decoder.GetAttribute(m, decoder.GetAttributeId(m, draco.POSITION));
    const ptr = draco._malloc(n * 12);
    decoder.GetAttributeDataArrayForAllPoints(m, attr, draco.DT_FLOAT32, n * 12, ptr);
    const positions = new Float32Array(draco.HEAPF32.buffer, ptr, n * 3).slice();
    draco._free(ptr);
    const t = m.num_faces() * 3;
    const iptr = draco._malloc(t * 4);
    decoder.GetTrianglesUInt32Array(m, t * 4, iptr);
    const indices = new Uint32Array(draco.HEAPU32.buffer, iptr, t).slice();
    draco._free(iptr);
    draco.destroy(m);
    draco.destroy(decoder);
    dracoVertices = n;
    return positions.length + indices.length;
  };
  decodeDraco();
  for (let i = 0; i < runs; i++) {
    const t0 = performance.now();
    decodeDraco();
    dracoMs.push(performance.now() - t0);
  }
  const w = median(wasmMs), d = median(dracoMs);
  return {
    vertices, dracoVertices, wasmMs: w, dracoMs: d,
    wasmMVps: vertices / w / 1000, dracoMVps: dracoVertices / d / 1000, speedup: (dracoVertices / d) ? (vertices / w) / (dracoVertices / d) : null,
  };
};

// draco3d's decoder: its Emscripten module run as a classic script. A page that has it already
// (the check script adds node_modules/draco3d/draco_decoder_nodejs.js and passes the
// draco_decoder.wasm bytes) uses those; otherwise both come from ./node_modules/draco3d/ beside
// the page (a static server over tools/viewer; `octowrap view` embeds three.js alone).
let dracoModule = null;
async function dracoDecoder(wasmBinary) {
  if (!dracoModule) {
    const base = new URL('./node_modules/draco3d/', import.meta.url);
    if (!window.DracoDecoderModule) {
      await new Promise((ok, bad) => {
        const s = document.createElement('script');
        s.src = new URL('draco_decoder_nodejs.js', base).href;
        s.onload = ok;
        s.onerror = () => bad(new Error(`cannot load draco3d from ${s.src}`));
        document.head.appendChild(s);
      });
    }
    const binary = wasmBinary ?? await (await fetch(new URL('draco_decoder.wasm', base))).arrayBuffer();
    dracoModule = await window.DracoDecoderModule({ wasmBinary: binary });
  }
  return dracoModule;
}

// View mode: frames the camera on the file's chunk boxes, then a coarse first cut and the real one.
function openView(msg) {
  viewMode = true;
  state.info = { levels: [], levelCount: msg.levelCount, chunks: msg.chunks, mode: 'view' };
  const b = msg.bounds;
  const min = new THREE.Vector3(b[0], b[1], b[2]), max = new THREE.Vector3(b[3], b[4], b[5]);
  framed = new THREE.Sphere(min.clone().add(max).multiplyScalar(0.5), min.distanceTo(max) / 2);
  state.radius = framed.radius;
  if (startCamera) {
    // `cam=`: the first view is this camera's, not the whole model.
    placeCamera(startCamera.position, startCamera.target, startCamera.up ?? [0, 0, 1], startCamera.fov_y_degrees ?? FOV);
  } else {
    const eye = framed.center.clone().addScaledVector(new THREE.Vector3(0.25, 0.3, 1).normalize(), framed.radius * 2.6);
    placeCamera(eye.toArray(), framed.center.toArray(), [0, 1, 0], FOV);
  }
  requestView(true);
  state.firstView = requestView();
}

function showCut(msg) {
  state.lastCut = { id: msg.id, level: msg.level, drawn: msg.drawn, finestDrawn: msg.finestDrawn, refined: msg.refined,
    unresolved: msg.unresolved, faces: msg.faces, held: msg.held, stats: msg.stats };
  show(msg);
  if (msg.id >= state.firstView) state.done = true;
  for (const [id, ok] of viewWaiters) {
    if (id <= msg.id) {
      viewWaiters.delete(id);
      ok(state.lastCut);
    }
  }
  updatePanel();
}

function main() {
  if (!src) {
    fail('no file given: open mrq.html?src=URL.mrq');
    return;
  }
  requestAnimationFrame(loop);
  worker = new Worker(new URL('./mrq-worker.js', import.meta.url), { type: 'module' });
  worker.onerror = (e) => fail(`the decoder worker failed: ${e.message || 'it could not start (is pkg/ built? tools/viewer/build-wasm.sh)'}`);
  worker.onmessage = (e) => {
    const msg = e.data;
    if (msg.type === 'info' && msg.mode === 'view') {
      openView(msg);
    } else if (msg.type === 'info') {
      state.info = { levels: msg.levels, levelCount: msg.levels.length, cube: msg.cube };
    } else if (msg.type === 'cut') {
      showCut(msg);
    } else if (msg.type === 'level') {
      show(msg);
    } else if (msg.type === 'done') {
      state.stats = msg.stats;
      state.done = true;
      updatePanel();
    } else if (msg.type === 'error') {
      state.stats = msg.stats;
      fail(msg.message);
    }
  };
  state.start = performance.now();
  worker.postMessage({ type: 'open', url: new URL(src, location.href).href, budget: state.budget, mode: modeAsked });
  updatePanel();
}

main();
