//! Local repair of intersecting faces (beyond the paper).
//!
//! The wrapped lattice mesh of a level is free of intersections, but the vertex mapping, the
//! relaxation and the fit move every vertex onto the points independently: where the data has
//! holes or thin parts (the bunny's open bottom, a roof edge of a LiDAR tile) a face can fold
//! over its neighbour or two sheets can pass through each other (the bunny's levels 1-7: 7, 30,
//! 69, 23, 12, 13 and 131 intersecting pairs before this stage).
//!
//! The repair keeps the connectivity, so the level stays two-manifold with the same boundary
//! loops and every parent link stays valid; it moves only vertices. The intersecting pairs are
//! found with the validator's exact test ([`octowrap_validate::intersecting_face_pairs`]); the
//! corners of the faces involved are *active*. Each round moves every active vertex half way
//! towards the centroid of its neighbours along edges (all at once, from the positions before
//! the round), which unfolds a fold and pulls a stray vertex back into its ring, then tests the
//! faces around the active vertices again (those faces and every face whose box overlaps one of
//! theirs). The corners of faces still intersecting join the active set; after every
//! [`GROW_EVERY`] rounds without success the active set also grows by its neighbours. At most
//! [`ROUNDS`] rounds; what is left is reported.
//!
//! Deterministic: the pairs come sorted, the vertices move in one parallel map from the
//! previous positions, and every set is sorted.

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, Mesh, PointCloud};
use rayon::prelude::*;

/// Rounds of the repair at most.
pub(crate) const ROUNDS: usize = 24;

/// Rounds without success after which the active set grows by one ring.
const GROW_EVERY: usize = 4;

/// What the repair did to a level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Untangled {
    /// Intersecting face pairs before.
    pub(crate) before: usize,
    /// Intersecting face pairs after.
    pub(crate) after: usize,
    /// Vertices moved.
    pub(crate) moved: usize,
}

/// Sorted, distinct neighbours along edges of every vertex (compressed rows).
fn neighbours(quads: &[[u32; 4]], n: usize) -> (Vec<u32>, Vec<u32>) {
    let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(quads.len() * 8);
    for q in quads {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            pairs.push((a, b));
            pairs.push((b, a));
        }
    }
    pairs.par_sort_unstable();
    pairs.dedup();
    let mut starts = vec![0u32; n + 1];
    for &(a, _) in &pairs {
        starts[a as usize + 1] += 1;
    }
    for i in 0..n {
        starts[i + 1] += starts[i];
    }
    (starts, pairs.into_iter().map(|p| p.1).collect())
}

/// The faces of every vertex (compressed rows, faces ascending).
fn faces_of(quads: &[[u32; 4]], n: usize) -> (Vec<u32>, Vec<u32>) {
    let mut starts = vec![0u32; n + 1];
    for q in quads {
        for &v in q {
            starts[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        starts[i + 1] += starts[i];
    }
    let mut fill = starts.clone();
    let mut items = vec![0u32; starts[n] as usize];
    for (f, q) in quads.iter().enumerate() {
        for &v in q {
            items[fill[v as usize] as usize] = f as u32;
            fill[v as usize] += 1;
        }
    }
    (starts, items)
}

fn face_box(q: &[u32; 4], p: &[DVec3]) -> (DVec3, DVec3) {
    let c = q.map(|v| p[v as usize]);
    (c[0].min(c[1]).min(c[2]).min(c[3]), c[0].max(c[1]).max(c[2]).max(c[3]))
}

/// The intersecting pairs among `faces` and the faces whose boxes overlap theirs, as global
/// face pairs, sorted.
fn pairs_near(quads: &[[u32; 4]], p: &[DVec3], faces: &[u32]) -> Vec<(u32, u32)> {
    let boxes: Vec<(DVec3, DVec3)> = faces.iter().map(|&f| face_box(&quads[f as usize], p)).collect();
    let (mut lo, mut hi, mut size) = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64);
    for b in &boxes {
        lo = lo.min(b.0);
        hi = hi.max(b.1);
        size = size.max((b.1 - b.0).max_element());
    }
    // The boxes by the cells (of the largest box's size) their lower corners lie in: a box
    // overlapping another lies in the cells around the other's.
    let cell = size.max((hi - lo).max_element() / 1e6).max(f64::MIN_POSITIVE);
    let key = |x: DVec3| ((x - lo) / cell).floor().as_i64vec3();
    let mut by_cell: std::collections::HashMap<_, Vec<usize>> = std::collections::HashMap::new();
    for (i, b) in boxes.iter().enumerate() {
        by_cell.entry(key(b.0)).or_default().push(i);
    }
    // Faces overlapping some box of `faces`.
    let mut chosen: Vec<u32> = (0..quads.len() as u32)
        .into_par_iter()
        .filter(|&g| {
            let (a, b) = face_box(&quads[g as usize], p);
            if !(a.cmple(hi).all() && lo.cmple(b).all()) {
                return false;
            }
            let (ka, kb) = (key(a) - 1, key(b));
            if (kb - ka).max_element() > 8 {
                // A long face: test every box.
                return boxes.iter().any(|(l, h)| a.cmple(*h).all() && l.cmple(b).all());
            }
            for x in ka.x..=kb.x {
                for y in ka.y..=kb.y {
                    for z in ka.z..=kb.z {
                        let hit = by_cell.get(&octowrap_geom::glam::I64Vec3::new(x, y, z)).is_some_and(|list| {
                            list.iter().any(|&i| a.cmple(boxes[i].1).all() && boxes[i].0.cmple(b).all())
                        });
                        if hit {
                            return true;
                        }
                    }
                }
            }
            false
        })
        .collect();
    chosen.sort_unstable();
    // The sub-mesh of those faces, vertices renumbered.
    let mut map = std::collections::BTreeMap::new();
    let mut pos = Vec::new();
    let sub: Vec<[u32; 4]> = chosen
        .iter()
        .map(|&g| {
            quads[g as usize].map(|v| {
                *map.entry(v).or_insert_with(|| {
                    pos.push(p[v as usize]);
                    pos.len() as u32 - 1
                })
            })
        })
        .collect();
    let mesh = Mesh { vertices: PointCloud::from_positions(pos), faces: FaceList::from_quads(&sub) };
    let mut out: Vec<(u32, u32)> = octowrap_validate::intersecting_face_pairs(&mesh)
        .into_iter()
        .map(|(a, b)| {
            let (a, b) = (chosen[a as usize], chosen[b as usize]);
            (a.min(b), a.max(b))
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Repairs the intersecting faces of one level (`quads` over `positions`, world coordinates)
/// by moving vertices; see the module docs.
pub(crate) fn untangle(quads: &[[u32; 4]], positions: &mut [DVec3]) -> Untangled {
    let mesh = Mesh { vertices: PointCloud::from_positions(positions.to_vec()), faces: FaceList::from_quads(quads) };
    let pairs = octowrap_validate::intersecting_face_pairs(&mesh);
    drop(mesh);
    let mut result = Untangled { before: pairs.len(), after: pairs.len(), moved: 0 };
    if pairs.is_empty() {
        return result;
    }
    let n = positions.len();
    let (nstart, nbrs) = neighbours(quads, n);
    let (fstart, vfaces) = faces_of(quads, n);
    let mut active = vec![false; n];
    let mut moved = vec![false; n];
    let mark = |pairs: &[(u32, u32)], active: &mut [bool]| {
        for &(f, g) in pairs {
            for v in quads[f as usize].iter().chain(&quads[g as usize]) {
                active[*v as usize] = true;
            }
        }
    };
    mark(&pairs, &mut active);
    let mut left = pairs;
    let mut stuck = 0;
    for _ in 0..ROUNDS {
        let list: Vec<u32> = (0..n as u32).filter(|&v| active[v as usize]).collect();
        let new: Vec<DVec3> = list
            .par_iter()
            .map(|&v| {
                let ring = &nbrs[nstart[v as usize] as usize..nstart[v as usize + 1] as usize];
                let x = positions[v as usize];
                if ring.is_empty() {
                    return x;
                }
                let c = ring.iter().fold(DVec3::ZERO, |s, &u| s + positions[u as usize]) / ring.len() as f64;
                x + 0.5 * (c - x)
            })
            .collect();
        for (&v, x) in list.iter().zip(new) {
            positions[v as usize] = x;
            moved[v as usize] = true;
        }
        let mut faces: Vec<u32> = list
            .iter()
            .flat_map(|&v| &vfaces[fstart[v as usize] as usize..fstart[v as usize + 1] as usize])
            .copied()
            .collect();
        faces.sort_unstable();
        faces.dedup();
        let now = pairs_near(quads, positions, &faces);
        if now.is_empty() {
            left = now;
            break;
        }
        if now.len() >= left.len() {
            stuck += 1;
        }
        mark(&now, &mut active);
        if stuck > 0 && stuck % GROW_EVERY == 0 {
            for &v in &list {
                for &u in &nbrs[nstart[v as usize] as usize..nstart[v as usize + 1] as usize] {
                    active[u as usize] = true;
                }
            }
        }
        left = now;
    }
    result.after = left.len();
    result.moved = moved.iter().filter(|&&m| m).count();
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 4 grid of quads in the plane z = 0 with its centre vertex pushed through a far
    /// face: the faces around it cross the grid's other faces.
    fn folded() -> (Vec<[u32; 4]>, Vec<DVec3>) {
        let k = 4u32;
        let mut pos = Vec::new();
        for y in 0..=k {
            for x in 0..=k {
                pos.push(DVec3::new(f64::from(x), f64::from(y), 0.0));
            }
        }
        let mut quads = Vec::new();
        for y in 0..k {
            for x in 0..k {
                let v = y * (k + 1) + x;
                quads.push([v, v + 1, v + k + 2, v + k + 1]);
            }
        }
        // The centre vertex (2, 2) moved past its neighbour, over the grid's corner cells.
        pos[12] = DVec3::new(3.6, 3.5, 0.0);
        (quads, pos)
    }

    #[test]
    fn unfolds_a_fold_and_keeps_the_rest() {
        let (quads, mut pos) = folded();
        let mesh = Mesh { vertices: PointCloud::from_positions(pos.clone()), faces: FaceList::from_quads(&quads) };
        let before = octowrap_validate::intersecting_face_pairs(&mesh).len();
        assert!(before > 0);
        let r = untangle(&quads, &mut pos);
        assert_eq!((r.before, r.after), (before, 0), "{r:?}");
        let mesh = Mesh { vertices: PointCloud::from_positions(pos.clone()), faces: FaceList::from_quads(&quads) };
        assert!(octowrap_validate::intersecting_face_pairs(&mesh).is_empty());
        // The corner far from the fold did not move.
        assert_eq!(pos[0], DVec3::ZERO);
        assert!(r.moved > 0 && r.moved < 25);
    }

    #[test]
    fn a_clean_mesh_is_left_alone() {
        let (quads, mut pos) = folded();
        pos[12] = DVec3::new(2.0, 2.0, 0.1);
        let before = pos.clone();
        assert_eq!(untangle(&quads, &mut pos), Untangled { before: 0, after: 0, moved: 0 });
        assert_eq!(pos, before);
    }
}
