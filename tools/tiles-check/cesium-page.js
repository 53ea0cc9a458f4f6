// Loads the tileset named by ?tileset=URL with CesiumJS and exposes `window.octowrap` for
// check-clients.mjs: ready / error; view(name) moves the camera to a view of views.js, renders
// until the tileset reports every needed tile loaded and the drawn set is stable, and returns the
// drawn tiles (content URI, geometric error, depth, distance from the camera); `placement` says
// where Cesium put the root tile's origin (longitude and latitude in degrees, ellipsoidal height
// in metres, ECEF) and whether the tileset is on the globe.
//
// Nothing comes from the network: no Cesium ion, no imagery, no terrain. A tileset whose root
// transform puts it near the Earth's surface is drawn over a bare WGS 84 globe (one colour, no
// imagery layer); a tileset in a local frame (no CRS: its origin near the Earth's centre) is drawn
// with no globe at all.
import { views, pageState, SIZE, FOV_DEG } from './views.js';

const Cesium = window.Cesium;
const { state, params, url, ERROR_TARGET } = pageState();

let widget;
let tileset;
let placed;
let drawnNow = [];

const frame = () => new Promise((ok) => requestAnimationFrame(() => ok()));

function place(name) {
  const v = placed.views[name];
  if (!v) throw new Error(`no view named ${name}`);
  const eye = Cesium.Cartesian3.fromArray(v.eye);
  const target = Cesium.Cartesian3.fromArray(v.target);
  const direction = Cesium.Cartesian3.normalize(Cesium.Cartesian3.subtract(target, eye, new Cesium.Cartesian3()), new Cesium.Cartesian3());
  const up0 = Cesium.Cartesian3.fromArray(v.up);
  const right = Cesium.Cartesian3.normalize(Cesium.Cartesian3.cross(direction, up0, new Cesium.Cartesian3()), new Cesium.Cartesian3());
  const up = Cesium.Cartesian3.cross(right, direction, new Cesium.Cartesian3());
  widget.camera.setView({ destination: eye, orientation: { direction, up } });
  widget.camera.frustum.fov = Cesium.Math.toRadians(FOV_DEG);
  widget.camera.frustum.near = Math.max(placed.radius * 1e-3, 1e-3);
}

async function settle() {
  let key = '';
  let still = 0;
  for (let n = 1; n <= 2000; n++) {
    drawnNow = [];
    widget.render();
    await frame();
    if (state.error) throw new Error(state.error);
    const now = drawnNow.map((t) => t.uri || '').sort().join('|');
    if (tileset.tilesLoaded && now === key && drawnNow.length > 0) {
      if (++still >= 4) return n;
    } else {
      still = 0;
    }
    key = now;
  }
  throw new Error('the tiles did not settle in 2000 frames');
}

state.view = async (name) => {
  place(name);
  const frames = await settle();
  const tiles = [...drawnNow].sort((a, b) => a.distance - b.distance);
  return { name, frames, eye: placed.views[name].eye, tiles };
};

async function main() {
  if (!url) throw new Error('no ?tileset=URL');
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const json = await response.json();
  placed = views(json, params.get('view'));
  const m = json.root.transform || [];
  const origin = m.length === 16 ? [m[12], m[13], m[14]] : [0, 0, 0];
  const onGlobe = Math.hypot(...origin) > 6.0e6;
  Cesium.Ion.defaultAccessToken = '';
  const globe = onGlobe ? new Cesium.Globe(Cesium.Ellipsoid.WGS84) : false;
  if (globe) {
    globe.baseColor = Cesium.Color.fromCssColorString('#35506b');
    globe.showGroundAtmosphere = false;
  }
  widget = new Cesium.CesiumWidget('view', {
    baseLayer: false,
    globe,
    skyBox: false,
    skyAtmosphere: false,
    terrainProvider: onGlobe ? new Cesium.EllipsoidTerrainProvider() : undefined,
    useDefaultRenderLoop: false,
    showRenderLoopErrors: false,
    creditContainer: 'credits',
    msaaSamples: 1,
    contextOptions: { webgl: { preserveDrawingBuffer: true } },
  });
  widget.scene.backgroundColor = Cesium.Color.fromCssColorString('#1e2630');
  widget.resize();
  tileset = await Cesium.Cesium3DTileset.fromUrl(url, { maximumScreenSpaceError: ERROR_TARGET });
  tileset.tileFailed.addEventListener((e) => { state.error = `tile failed: ${e.url}: ${e.message}`; });
  tileset.tileVisible.addEventListener((tile) => {
    const header = tile._contentHeader || {};
    drawnNow.push({
      uri: header.uri || null,
      geometricError: tile.geometricError,
      depth: tile._depth,
      leaf: tile.children.length === 0,
      distance: tile._distanceToCamera,
    });
  });
  widget.scene.primitives.add(tileset);
  const o = Cesium.Matrix4.getTranslation(tileset.root.computedTransform, new Cesium.Cartesian3());
  const carto = Cesium.Cartographic.fromCartesian(o, Cesium.Ellipsoid.WGS84);
  state.placement = {
    onGlobe,
    ecef: [o.x, o.y, o.z],
    longitude: carto ? Cesium.Math.toDegrees(carto.longitude) : null,
    latitude: carto ? Cesium.Math.toDegrees(carto.latitude) : null,
    height: carto ? carto.height : null,
  };
  state.radius = placed.radius;
  state.views = Object.keys(placed.views);
  state.ready = true;
}

main().catch((e) => { state.error = String(e && e.message || e); });
