//! Irregular mesh refinement `I` (Keller et al., §3.5): reconnect the subfaces of `R(M_j)` and
//! close the breaks by adopting or creating the partner face across every edge.
//!
//! Reading (see also [`crate::lattice`] for the four edge cases):
//!
//! * The partner of face `(v, d)` across its edge towards `t` depends only on which of `v + t` and
//!   `v + t + d` are occupied: convex `(v, t)`, flat `(v + t, d)`, concave `(v + t + d, -t)`, and the
//!   diagonal case (only `v + t + d` occupied, the paper's Fig. 4(d)), where the surface either
//!   passes, `(v + t + d, -t)` (the paper's `n0`), or breaks, `(v, t)` (`n1`). The relation is
//!   symmetric (the unit test `partners_are_symmetric` checks all 2 x 8 configurations), so two
//!   faces are linked exactly when each is the other's partner and both exist.
//! * The diagonal case is decided once per voxel pair, so both sides agree. The paper compares
//!   "the principal orientation of the points within v and w"; comparing the two voxels' own
//!   normals makes false breaks on a sampled sphere (the surface then leaks inside), so one plane
//!   is fitted to the points of both voxels together, and they break only when both
//!   hold at least 4 points and the joint plane's RMS residual exceeds 0.2 voxel: one sheet
//!   passes, two sheets meeting at an edge (a crease or two parts touching) break.
//! * The sets `A` and `B` of the paper are a fixed-point iteration. We run it in synchronous
//!   waves: collect every missing partner of the newest faces, keep those the mask
//!   ([`crate::sheet`]) allows, add them, repeat until no face is added. The mask is a predicate
//!   on slots, so the result is the least closed superset of `R(M_j)`, independent of the order of
//!   visits and of the number of threads. Created faces have no parent.

use std::collections::BTreeSet;

use octowrap_geom::morton;
use octowrap_mesh::FaceOrigin;
use rayon::prelude::*;

use crate::keymap::KeyMap;
use crate::lattice::{EdgeCase, edge_case, edge_side, pair_key, partner, unslot};
use crate::octree::Cells;
use crate::rankmap::RankMap;
use crate::sheet::Mask;

/// The diagonal-case decisions of one level.
#[derive(Debug)]
pub(crate) struct Decisions<'a> {
    cells: &'a Cells,
    /// The coarser levels' voxels (index = level) and their flips, for diagonal edges between
    /// filled voxels ([`crate::regions`]), which take their parents' decision.
    coarse: &'a [Cells],
    coarse_flips: &'a [BTreeSet<(u64, u64)>],
    /// Voxel pairs whose decision was flipped to split a pinched edge ([`crate::extract`]).
    pub flips: BTreeSet<(u64, u64)>,
}

impl<'a> Decisions<'a> {
    /// The points' decisions, no flips.
    pub(crate) fn new(cells: &'a Cells) -> Self {
        Self { cells, coarse: &[], coarse_flips: &[], flips: BTreeSet::new() }
    }

    /// Decisions of a level with filled voxels: `coarse` are the levels above (`0..level`),
    /// `coarse_flips` their flips (by level; missing levels have none).
    pub(crate) fn with_parents(
        cells: &'a Cells,
        coarse: &'a [Cells],
        coarse_flips: &'a [BTreeSet<(u64, u64)>],
    ) -> Self {
        Self { cells, coarse, coarse_flips, flips: BTreeSet::new() }
    }

    /// Whether the surface passes from voxel `v` to its edge-neighbour `w`.
    pub(crate) fn pass(&self, v: u64, w: u64) -> bool {
        let base = joint_pass(self.cells, self.coarse, self.coarse_flips, v, w);
        if self.flips.is_empty() { base } else { base ^ self.flips.contains(&pair_key(v, w)) }
    }
    /// The case and the partner slot of face `key` across its edge `k`.
    #[inline]
    pub(crate) fn partner(&self, key: u64, k: usize) -> (EdgeCase, u64) {
        let (code, d) = unslot(key);
        let t = edge_side(d, k);
        let case = edge_case(code, d, t, self.cells.level, |c| self.cells.occupied(c));
        (case, partner(code, d, t, case, |a, b| self.pass(a, b)))
    }
}

/// The points' decision for the voxel pair `(v, w)` of `cells`: one plane through both voxels'
/// points, broken when both hold at least 4 points and its RMS residual exceeds 0.2 voxel. Two
/// filled voxels of different parents take their parents' decision (with the flips of that
/// level), from `coarse` (the levels above, by level).
fn joint_pass(cells: &Cells, coarse: &[Cells], coarse_flips: &[BTreeSet<(u64, u64)>], v: u64, w: u64) -> bool {
    let (Some(i), Some(j)) = (cells.find(v), cells.find(w)) else { return true };
    if cells.is_filled(i) && cells.is_filled(j) && v >> 3 != w >> 3 {
        if let Some((parents, above)) = coarse.split_last() {
            let (pv, pw) = (v >> 3, w >> 3);
            let base = joint_pass(parents, above, coarse_flips, pv, pw);
            let flipped = coarse_flips.get(parents.level as usize).is_some_and(|f| f.contains(&pair_key(pv, pw)));
            return base ^ flipped;
        }
    }
    let (a, b) = (cells.moments[i], cells.moments[j]);
    if a.count < 4.0 || b.count < 4.0 {
        return true;
    }
    let mut m = a;
    m.merge(&b);
    crate::plane_fit::plane(&m).is_none_or(|p| p.rms_residual() <= 0.2 * cells.voxel())
}

/// Whether the mask allows slot `key` (whose voxel must be occupied).
#[inline]
pub(crate) fn allowed(cells: &Cells, mask: &Mask, key: u64) -> bool {
    let (code, d) = unslot(key);
    cells.find(code).is_some_and(|i| mask.allows(i, morton::decode(code), d))
}

/// Closes `initial` (sorted by slot): returns all slots, sorted, with their origins
/// (`Created` for the added ones), and the number of created faces.
pub(crate) fn close(
    initial: Vec<(u64, FaceOrigin)>,
    cells: &Cells,
    mask: &Mask,
    dec: &Decisions<'_>,
) -> (Vec<u64>, Vec<FaceOrigin>, usize) {
    // The faces so far: the initial ones (sorted: a fixed index, built in parallel) and the
    // created ones (a set that grows, far smaller).
    let keys: Vec<u64> = initial.iter().map(|e| e.0).collect();
    let start = RankMap::from_sorted(&keys);
    let mut set = KeyMap::with_capacity(initial.len() / 4);
    let missing = |faces: &[u64], set: &KeyMap| -> Vec<u64> {
        let mut m: Vec<u64> = faces
            .par_iter()
            .flat_map_iter(|&f| (0..4).map(move |k| dec.partner(f, k).1))
            .filter(|&g| !start.contains(g) && !set.contains(g) && allowed(cells, mask, g))
            .collect();
        m.par_sort_unstable();
        m.dedup();
        m
    };
    let mut created: Vec<u64> = Vec::new();
    let mut frontier = missing(&keys, &set);
    while !frontier.is_empty() {
        for &g in &frontier {
            set.insert(g, 0);
        }
        created.extend_from_slice(&frontier);
        frontier = missing(&frontier, &set);
    }
    let n_created = created.len();
    let mut all: Vec<(u64, FaceOrigin)> = initial;
    all.extend(created.into_iter().map(|k| (k, FaceOrigin::Created)));
    all.par_sort_unstable_by_key(|e| e.0);
    let (slots, origins) = all.into_iter().unzip();
    (slots, origins, n_created)
}
