//! The trusted level chosen per region (Keller et al., §4.2, read per region instead of per
//! level): where the points are too sparse for the next level, that region is subdivided while
//! the rest is wrapped, inside one lattice mesh.
//!
//! Regions start past the global limit ([`crate::ReconOptions::min_median_points`]): up to
//! [`crate::ReconOptions::region_levels`] levels are wrapped there where some region is dense.
//!
//! Reading: the paper fixes the topology at a coarser level where the data is too sparse, and
//! leaves open how "where" is measured. A global criterion ([`crate::ReconOptions::min_median_points`])
//! either trusts the sparse rims of a scan (the bunny's bottom fragments at level 5) or refuses
//! the dense rest. Here, before level `j + 1` is built, every occupied voxel `p` of level `j` is
//! marked *sparse* when the points of its 3x3x3 block, divided by the occupied level-`(j + 1)`
//! children of the block, are fewer than [`crate::ReconOptions::region_density`] (about 10: a
//! plane fit per child and the sheets of [`crate::sheet`] need several points); the sparse set
//! then grows by one voxel (its 26 neighbours), and stays sparse at every deeper level. At level
//! `j + 1`, the children of dense voxels are the occupied ones, as always; the eight children of
//! a sparse voxel are all present (*filled*, with their points if they have any). The mixed
//! level is then wrapped as usual (§3.4-3.5): a filled block reproduces its parent's faces split
//! 1:4, so the sparse region is in effect subdivided, while the whole level stays one lattice
//! mesh, so the border between the two is crack-free and two-manifold with no special faces.
//! Three rules make a filled region reproduce its parent (in [`crate::sheet`], [`crate::irregular`]
//! and the crate root):
//!
//! * a filled voxel allows the slot `(c, d)` of a child `c` on the `d` side of a parent face
//!   `(p, d)` of `M_j`; and, for the steps of the transition (without which the border cracks
//!   open), a slot looking into an empty child of a dense voxel, when it is not inwards of a parent
//!   face the child lies on or is not behind some oriented sheet around it (see
//!   [`crate::sheet`]);
//! * a diagonal edge between two filled voxels takes the decision (with its flips) of their
//!   parents' pair, recursively;
//! * the vertices of a filled voxel's subfaces start at the bilinear interpolation of the parent
//!   face's mapped corners, and a vertex whose faces all lie on filled voxels is mapped as on a
//!   subdivided level ([`crate::mapping`]).

use octowrap_geom::DVec3;
use octowrap_mesh::FaceOrigin;
use rayon::prelude::*;

use crate::lattice::{axis, corner_offset, offset, plane_axes, unslot};
use crate::octree::{BLOCK, Cells};

/// Number of occupied children of every voxel of `cells` (`children`: the next level's
/// occupied voxels, each a child of a voxel of `cells`).
fn child_counts(cells: &Cells, children: &Cells) -> Vec<u32> {
    let mut kids = vec![0u32; cells.len()];
    let mut p = 0;
    for &k in &children.keys {
        let parent = k >> 3;
        while p < cells.len() && cells.keys[p] != parent {
            p += 1;
        }
        if p == cells.len() {
            break;
        }
        kids[p] += 1;
    }
    kids
}

/// Whether voxel `i` of `cells` is dense by its block: at least `tau` points of the block per
/// occupied child in the block (a block with no children is not sparse).
#[inline]
fn dense(cells: &Cells, kids: &[u32], i: usize, tau: f64) -> bool {
    let key = cells.keys[i];
    let (mut points, mut occupied) = (0usize, 0u64);
    for off in BLOCK {
        if let Some(k) = offset(key, off, cells.level).and_then(|k| cells.find(k)) {
            points += cells.range(k).len();
            occupied += u64::from(kids[k]);
        }
    }
    occupied == 0 || points as f64 >= tau * occupied as f64
}

/// The sparse voxels of `cells` (level `j`) for the next level, whose occupied voxels are
/// `children`: the filled voxels (sparse below), those whose block has fewer than `tau` points
/// per occupied child, and their 26 neighbours.
pub(crate) fn mark(cells: &Cells, children: &Cells, tau: f64) -> Vec<bool> {
    let kids = child_counts(cells, children);
    let mut sparse: Vec<bool> =
        (0..cells.len()).into_par_iter().map(|i| cells.is_filled(i) || !dense(cells, &kids, i, tau)).collect();
    let grow: Vec<usize> = (0..cells.len())
        .into_par_iter()
        .filter(|&i| sparse[i])
        .flat_map_iter(|i| {
            let key = cells.keys[i];
            BLOCK.iter().filter_map(move |&off| offset(key, off, cells.level).and_then(|k| cells.find(k)))
        })
        .collect();
    for i in grow {
        sparse[i] = true;
    }
    sparse
}

/// Whether some voxel of `cells` is dense for the next level (`children`), by the test of
/// [`mark`] without the inherited sparse regions: decides whether a level past the global density
/// limit is wrapped at all.
pub(crate) fn any_dense(cells: &Cells, children: &Cells, tau: f64) -> bool {
    let kids = child_counts(cells, children);
    (0..cells.len()).into_par_iter().any(|i| dense(cells, &kids, i, tau))
}

/// Adds the eight children of every sparse voxel of `parents` to `children` (without points
/// where they had none) and marks them filled. Returns the number of filled voxels.
pub(crate) fn fill(children: &mut Cells, parents: &Cells, sparse: &[bool]) -> usize {
    if !sparse.iter().any(|&s| s) {
        return 0;
    }
    let mut extra: Vec<u64> = (0..parents.len())
        .into_par_iter()
        .filter(|&i| sparse[i])
        .flat_map_iter(|i| (0..8u64).map(move |o| parents.keys[i] << 3 | o))
        .filter(|&k| !children.occupied(k))
        .collect();
    extra.par_sort_unstable();
    children.insert_empty(&extra);
    let filled: Vec<bool> =
        children.keys.par_iter().map(|&k| parents.find(k >> 3).is_some_and(|p| sparse[p])).collect();
    let count = filled.iter().filter(|&&f| f).count();
    children.filled = filled;
    count
}

/// A level's faces: slots, origins, quads and the vertices' lattice corners.
pub(crate) struct Faces<'a> {
    pub slots: &'a [u64],
    pub origins: &'a [FaceOrigin],
    pub quads: &'a [[u32; 4]],
    pub corners: &'a [[u32; 3]],
}

/// The level above: quads, lattice corners and mapped positions (local coordinates).
pub(crate) struct Parents<'a> {
    pub quads: &'a [[u32; 4]],
    pub corners: &'a [[u32; 3]],
    pub positions: &'a [DVec3],
}

/// Starts every vertex of a subface on a filled voxel at the bilinear interpolation of its
/// parent face's mapped corners (the first such face of a vertex decides; faces sharing a parent
/// edge agree on it). Other vertices keep `positions`.
pub(crate) fn start_on_parents(faces: &Faces<'_>, cells: &Cells, parents: &Parents<'_>, positions: &mut [DVec3]) {
    let mut done = vec![false; positions.len()];
    for (f, (&s, origin)) in faces.slots.iter().zip(faces.origins).enumerate() {
        let FaceOrigin::Subface { parent, .. } = *origin else { continue };
        let (code, d) = unslot(s);
        if !cells.find(code).is_some_and(|i| cells.is_filled(i)) {
            continue;
        }
        let pq = parents.quads[parent as usize];
        // Corner 0 of a face is its smallest corner in the plane (offsets (0, 0)).
        let p0 = parents.corners[pq[0] as usize];
        let (b, c) = plane_axes(axis(d));
        for &v in &faces.quads[f] {
            if std::mem::replace(&mut done[v as usize], true) {
                continue;
            }
            let l = faces.corners[v as usize];
            let u = 0.5 * (f64::from(l[b]) - 2.0 * f64::from(p0[b]));
            let w = 0.5 * (f64::from(l[c]) - 2.0 * f64::from(p0[c]));
            positions[v as usize] = (0..4)
                .map(|k| {
                    let o = corner_offset(d, k);
                    let wu = if o[0] == 1 { u } else { 1.0 - u };
                    let wv = if o[1] == 1 { w } else { 1.0 - w };
                    parents.positions[pq[k] as usize] * (wu * wv)
                })
                .sum();
        }
    }
}

#[cfg(test)]
mod tests {
    use octowrap_geom::{DVec3, morton};

    use super::*;
    use crate::octree::Octree;

    /// A flat sheet at level 3, dense (many points per level-4 voxel) for x < 0.5, sparse beyond.
    fn half_dense_sheet() -> Octree {
        let mut pts = vec![DVec3::ZERO, DVec3::ONE];
        for i in 0..64 {
            for k in 0..64 {
                let x = (f64::from(i) + 0.5) / 64.0;
                // Every point on the dense half; one in 16 on the other.
                if x < 0.5 || (i % 4 == 0 && k % 4 == 0) {
                    pts.push(DVec3::new(x, (f64::from(k) + 0.5) / 64.0, 0.5 + 1.0 / 64.0));
                }
            }
        }
        let mut o = Octree::new(&pts, 0.0);
        for _ in 0..5 {
            o.push_level();
        }
        o.finish(5);
        o
    }

    #[test]
    fn sparse_regions_are_marked_grown_and_filled() {
        let mut o = half_dense_sheet();
        let sparse = mark(&o.levels[3], &o.levels[4], 10.0);
        let cells = &o.levels[3];
        let at = |x: u32, y: u32| cells.find(morton::encode(x, y, 4)).expect("occupied");
        // Dense: 16 points per occupied child; sparse: 1.
        assert!(!sparse[at(1, 3)]);
        assert!(sparse[at(6, 3)]);
        // The border voxel on the dense side (x = 3) is sparse by growth, x = 2 is not.
        assert!(sparse[at(3, 3)]);
        assert!(!sparse[at(2, 3)]);
        assert!(any_dense(&o.levels[3], &o.levels[4], 10.0));
        assert!(!any_dense(&o.levels[3], &o.levels[4], 100.0));
        let parents = std::mem::take(&mut o.levels[3]);
        let before = o.levels[4].len();
        let filled = fill(&mut o.levels[4], &parents, &sparse);
        let fine = &o.levels[4];
        let sparse_parents = sparse.iter().filter(|&&s| s).count();
        assert_eq!(filled, 8 * sparse_parents);
        assert!(fine.len() > before);
        assert!(fine.keys.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(fine.starts.len(), fine.len() + 1);
        assert_eq!(fine.moments.len(), fine.len());
        for (i, &k) in fine.keys.iter().enumerate() {
            assert_eq!(fine.find(k), Some(i));
            let p = parents.find(k >> 3).expect("every voxel has a parent here");
            assert_eq!(fine.is_filled(i), sparse[p]);
        }
        // Points are kept: every point still lies in exactly one voxel.
        assert_eq!(*fine.starts.last().unwrap() as usize, o.points.len());
        let total: usize = (0..fine.len()).map(|i| fine.range(i).len()).sum();
        assert_eq!(total, o.points.len());
        // Filled voxels stay sparse at the next level, whatever their points.
        let again = mark(fine, &o.levels[5], 0.0);
        assert!((0..fine.len()).any(|i| fine.is_filled(i)));
        assert!((0..fine.len()).all(|i| !fine.is_filled(i) || again[i]));
        assert!((0..fine.len()).any(|i| !again[i]));
    }
}
