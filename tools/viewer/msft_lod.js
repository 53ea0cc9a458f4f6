// A three.js post-processing step for GLTFLoader results: builds a THREE.LOD from every node that
// carries MSFT_lod, since three.js has no built-in support for the extension.
//
// MSFT_lod: the node with the extension is the most detailed level; `ids` lists lower levels in
// decreasing detail. `extras.MSFT_screencoverage[i]` is the screen coverage (projected bounding
// sphere height over viewport height) down to which level i is shown. For a perspective camera
// with vertical field of view `fov`, coverage c of a sphere of radius r is reached at distance
// r / (c * tan(fov / 2)): that distance is where THREE.LOD switches to level i + 1.
import * as THREE from 'three';

function objectForNode(gltf, nodeIndex) {
  let found = null;
  gltf.scene.traverse((o) => {
    const a = gltf.parser.associations.get(o);
    if (!found && a && a.nodes === nodeIndex) found = o;
  });
  return found;
}

/** Replaces each MSFT_lod node of `gltf.scene` by a THREE.LOD; returns the LOD objects. */
export async function applyMsftLod(gltf, fovDegrees) {
  const json = gltf.parser.json;
  const made = [];
  const nodes = json.nodes || [];
  for (let i = 0; i < nodes.length; i++) {
    const ext = nodes[i].extensions && nodes[i].extensions.MSFT_lod;
    if (!ext || !Array.isArray(ext.ids)) continue;
    const high = objectForNode(gltf, i);
    if (!high || !high.parent) continue;
    const lower = await Promise.all(ext.ids.map((id) => gltf.parser.getDependency('node', id)));
    const coverage = (nodes[i].extras && nodes[i].extras.MSFT_screencoverage) || [];
    const parent = high.parent;
    parent.updateWorldMatrix(true, false);
    const sphere = new THREE.Box3().setFromObject(high).getBoundingSphere(new THREE.Sphere());
    const centre = parent.worldToLocal(sphere.center.clone());
    const tanHalf = Math.tan(THREE.MathUtils.degToRad(fovDegrees) / 2);
    const lod = new THREE.LOD();
    lod.name = `MSFT_lod of ${high.name}`;
    lod.position.copy(centre);
    const levels = [high, ...lower];
    const distances = [];
    levels.forEach((object, k) => {
      const c = k === 0 ? null : coverage[k - 1];
      const distance = k === 0 ? 0 : c > 0 ? sphere.radius / (c * tanHalf) : Infinity;
      const holder = new THREE.Group();
      holder.name = object.name;
      holder.position.copy(centre).negate();
      holder.add(object);
      lod.addLevel(holder, distance);
      distances.push(distance);
    });
    parent.remove(high);
    parent.add(lod);
    lod.userData.msftLod = { radius: sphere.radius, distances, names: levels.map((o) => o.name) };
    made.push(lod);
  }
  return made;
}
