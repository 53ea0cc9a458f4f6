// Loads the tileset named by ?tileset=URL with 3DTilesRendererJS (three.js) and exposes
// `window.octowrap` for check-clients.mjs:
//   ready / error;
//   view(name): moves the camera to a view of views.js, updates and renders until no tile is
//     loading and the drawn set is stable, and returns the drawn tiles (content URI, geometric
//     error, tree depth, distance from the camera) and how many frames it took;
//   cracks(name): at that view, the pixels a render of the finest level covers that the tiled
//     view leaves empty, as a count and a fraction of the finest level's pixels; and of those,
//     the holes: the ones with the tiled view's surface on both sides within a few pixels (a gap
//     in the surface), which leaves out where a coarser tile's silhouette differs from the
//     finest level's.
// The finest level's render is a second TilesRenderer on the same tileset with an error target of
// zero, which draws only the tiles whose geometric error is 0: the finest level's tiles. Both
// renders use one flat, front-face-only material, so a crack shows as an empty pixel (a back face
// seen through it is not drawn).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { TilesRenderer } from '3d-tiles-renderer';
import { ImplicitTilingPlugin } from '3d-tiles-renderer/core/plugins';
import { views, pageState, SIZE, FOV_DEG } from './views.js';

const { state, params, url, ERROR_TARGET } = pageState();

const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(SIZE, SIZE);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1e2630);
scene.add(new THREE.HemisphereLight(0xffffff, 0x445566, 1.6));
const camera = new THREE.PerspectiveCamera(FOV_DEG, 1, 1, 1e8);
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(0.3, 1, 1);
camera.add(sun);
scene.add(camera);

function makeTiles(errorTarget) {
  const tiles = new TilesRenderer(url);
  tiles.registerPlugin(new ImplicitTilingPlugin());
  const loader = new GLTFLoader(tiles.manager);
  loader.setMeshoptDecoder(MeshoptDecoder);
  tiles.manager.addHandler(/\.(gltf|glb)$/g, loader);
  tiles.errorTarget = errorTarget;
  // Tests load everything at once from localhost: more parallel downloads and parses per frame.
  tiles.downloadQueue.maxJobs = 32;
  tiles.parseQueue.maxJobs = 32;
  tiles.setCamera(camera);
  tiles.setResolution(camera, SIZE, SIZE);
  tiles.addEventListener('load-error', (e) => { state.error = `load error: ${e.url || ''} ${e.error && e.error.message}`; });
  return tiles;
}

const tiled = makeTiles(ERROR_TARGET);
scene.add(tiled.group);
let finest = null;
let tilesetJson = null;
let placed = null;

const frame = () => new Promise((ok) => requestAnimationFrame(() => ok()));

function place(name) {
  const v = placed.views[name];
  if (!v) throw new Error(`no view named ${name}`);
  camera.position.set(...v.eye);
  camera.up.set(...v.up);
  camera.lookAt(...v.target);
  camera.near = Math.max(placed.radius * 1e-3, 1e-3);
  camera.far = placed.radius * 100;
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld(true);
}

function loading(tiles) {
  const s = tiles.stats || {};
  return (s.queued || 0) + (s.downloading || 0) + (s.parsing || 0) + (s.loading || 0);
}

// Updates and renders until nothing loads and the drawn set has not changed for a few frames.
async function settle(tiles, draw) {
  let key = '';
  let still = 0;
  for (let n = 1; n <= 2000; n++) {
    camera.updateMatrixWorld(true);
    tiles.update();
    draw();
    await frame();
    const now = [...tiles.visibleTiles].map((t) => (t.content && t.content.uri) || '').sort().join('|');
    if (state.error) throw new Error(state.error);
    if (loading(tiles) === 0 && now === key && now !== '' && tiles.loadProgress === 1) {
      if (++still >= 4) return n;
    } else {
      still = 0;
    }
    key = now;
  }
  throw new Error('the tiles did not settle in 2000 frames');
}

function drawn(tiles) {
  return [...tiles.visibleTiles].map((t) => ({
    uri: (t.content && t.content.uri) || null,
    geometricError: t.geometricError,
    depth: t.internal ? t.internal.depth : null,
    leaf: !t.children || t.children.length === 0,
    distance: t.traversal ? t.traversal.distanceFromCamera : null,
  })).sort((a, b) => a.distance - b.distance);
}

state.view = async (name) => {
  place(name);
  const frames = await settle(tiled, () => renderer.render(scene, camera));
  return { name, frames, eye: placed.views[name].eye, tiles: drawn(tiled) };
};

const flat = new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.FrontSide });
const target = new THREE.WebGLRenderTarget(SIZE, SIZE);

function mask(group) {
  const only = new THREE.Scene();
  only.background = new THREE.Color(0x000000);
  only.overrideMaterial = flat;
  const parent = group.parent;
  only.add(group);
  renderer.setRenderTarget(target);
  renderer.render(only, camera);
  const px = new Uint8Array(SIZE * SIZE * 4);
  renderer.readRenderTargetPixels(target, 0, 0, SIZE, SIZE, px);
  renderer.setRenderTarget(null);
  if (parent) parent.add(group);
  const out = new Uint8Array(SIZE * SIZE);
  for (let i = 0; i < out.length; i++) out[i] = px[i * 4] > 127 ? 1 : 0;
  return out;
}

state.cracks = async (name) => {
  place(name);
  await settle(tiled, () => renderer.render(scene, camera));
  const shown = mask(tiled.group);
  if (!finest) finest = makeTiles(0);
  const holder = new THREE.Scene();
  holder.add(finest.group);
  const frames = await settle(finest, () => renderer.render(holder, camera));
  const levels = drawn(finest);
  if (levels.some((t) => t.geometricError !== 0)) throw new Error('the error-0 renderer drew a tile with a positive error');
  const full = mask(finest.group);
  let model = 0;
  let missing = 0;
  for (let i = 0; i < full.length; i++) {
    model += full[i];
    if (full[i] && !shown[i]) missing++;
  }
  const inside = bridged(shown);
  let holes = 0;
  for (let i = 0; i < full.length; i++) {
    if (full[i] && !shown[i] && inside[i]) holes++;
  }
  renderer.render(scene, camera);
  // The picture of the measure: grey where both cover, white where the tiled view covers alone,
  // red where only the finest level does inside the tiled view's surface (the holes), orange
  // where it does at a silhouette; rows flipped to the screen's order.
  const canvas = document.createElement('canvas');
  canvas.width = SIZE;
  canvas.height = SIZE;
  const g = canvas.getContext('2d');
  const img = g.createImageData(SIZE, SIZE);
  for (let y = 0; y < SIZE; y++) {
    for (let x = 0; x < SIZE; x++) {
      const i = (SIZE - 1 - y) * SIZE + x;
      const o = (y * SIZE + x) * 4;
      const c = full[i] && !shown[i] ? (inside[i] ? [255, 0, 0] : [255, 160, 0]) : full[i] ? [128, 128, 128] : shown[i] ? [255, 255, 255] : [0, 0, 0];
      img.data.set([...c, 255], o);
    }
  }
  g.putImageData(img, 0, 0);
  const picture = canvas.toDataURL('image/png');
  return {
    name,
    frames,
    modelPixels: model,
    missingPixels: missing,
    fraction: model ? missing / model : 0,
    holePixels: holes,
    holeFraction: model ? holes / model : 0,
    finestTiles: levels.length,
    picture,
  };
};

// Per pixel, whether the tiled view covers pixels on both sides of it within GAP pixels along
// a row, a column or a diagonal: an empty pixel so bridged is a gap in the surface (a crack),
// where one beside the background is the edge of a silhouette.
const GAP = 6;
function bridged(shown) {
  const out = new Uint8Array(shown.length);
  const at = (x, y) => x >= 0 && y >= 0 && x < SIZE && y < SIZE && shown[y * SIZE + x] === 1;
  const reaches = (x, y, dx, dy) => {
    for (let k = 1; k <= GAP; k++) if (at(x + k * dx, y + k * dy)) return true;
    return false;
  };
  for (let y = 0; y < SIZE; y++) {
    for (let x = 0; x < SIZE; x++) {
      if (shown[y * SIZE + x]) continue;
      for (const [dx, dy] of [[1, 0], [0, 1], [1, 1], [1, -1]]) {
        if (reaches(x, y, dx, dy) && reaches(x, y, -dx, -dy)) {
          out[y * SIZE + x] = 1;
          break;
        }
      }
    }
  }
  return out;
}

async function main() {
  if (!url) throw new Error('no ?tileset=URL');
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  tilesetJson = await response.json();
  placed = views(tilesetJson, params.get('view'));
  state.radius = placed.radius;
  state.views = Object.keys(placed.views);
  state.ready = true;
}

main().catch((e) => { state.error = String(e && e.message || e); });
