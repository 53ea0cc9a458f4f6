// Loads the GLB named by ?model=URL (default model.glb), builds the MSFT_lod chain as a
// THREE.LOD, and exposes `window.octowrap` for tests: ready/error, the level names, the level shown
// at a camera distance, and how much of the frame the model covers.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { applyMsftLod } from './msft_lod.js';

const FOV = 45;
const BACKGROUND = new THREE.Color(0x1e2630);
const status = document.getElementById('status');
const state = { ready: false, error: null };
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

function render() {
  renderer.render(scene, camera);
}

async function main() {
  const url = new URLSearchParams(location.search).get('model') || 'model.glb';
  const loader = new GLTFLoader();
  loader.setMeshoptDecoder(MeshoptDecoder);
  const gltf = await loader.loadAsync(url);
  scene.add(gltf.scene);
  const lods = await applyMsftLod(gltf, FOV);
  const lod = lods[0] || null;
  // Frame the most detailed level (coarse levels, such as a root cube, can be much larger).
  const framed = lod ? lod.levels[0].object : gltf.scene;
  gltf.scene.updateMatrixWorld(true);
  const sphere = new THREE.Box3().setFromObject(framed).getBoundingSphere(new THREE.Sphere());
  let triangles = 0; // over every level
  gltf.scene.traverse((o) => {
    if (o.isMesh) triangles += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
  });
  // Places the camera `distance` from the model's centre (looking along -Z, slightly from above),
  // renders, and returns the shown level's index and name.
  state.setDistance = (distance) => {
    const dir = new THREE.Vector3(0.25, 0.3, 1).normalize();
    camera.position.copy(sphere.center).addScaledVector(dir, distance);
    camera.near = Math.max(distance / 100, 1e-6);
    camera.far = distance + sphere.radius * 4;
    camera.updateProjectionMatrix();
    camera.lookAt(sphere.center);
    render();
    if (!lod) return { level: 0, name: gltf.scene.children[0] ? gltf.scene.children[0].name : '' };
    lod.update(camera);
    render();
    const k = lod.getCurrentLevel();
    return { level: k, name: lod.levels[k].object.name };
  };
  // Fraction of pixels that differ from the background in the last frame.
  state.coverage = () => {
    const gl = renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const bg = BACKGROUND.clone().convertLinearToSRGB();
    const ref = [bg.r * 255, bg.g * 255, bg.b * 255];
    let hit = 0;
    for (let i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - ref[0]) + Math.abs(px[i + 1] - ref[1]) + Math.abs(px[i + 2] - ref[2]) > 24) hit++;
    }
    return hit / (w * h);
  };
  state.radius = sphere.radius;
  state.lod = lod ? lod.userData.msftLod : null;
  state.triangles = triangles;
  state.extensionsUsed = gltf.parser.json.extensionsUsed || [];
  state.setDistance(sphere.radius * 2.6);
  state.ready = true;
  status.textContent = `${url}: ${lod ? lod.levels.length + ' levels (MSFT_lod)' : 'one level'}`;
}

main().catch((err) => {
  state.error = String(err && err.stack ? err.stack : err);
  status.textContent = `error: ${err}`;
});
