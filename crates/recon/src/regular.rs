//! Regular mesh refinement `R` (Keller et al., §3.4): every face of `M_j` splits into four
//! subfaces, each projected onto a child voxel.
//!
//! Reading: for face `(p, d)` and its quadrant `q` (the quarter touching corner `q`), the two
//! children of `p` under that quarter are `c_out` (touching side `d`) and `c_in` (behind it). The
//! subface goes to `c_out` when `c_out` is occupied, else to `c_in` when `c_in` is occupied, else
//! it is removed; a slot the mask ([`crate::sheet`]) refuses is removed too (it is never pushed
//! further in: behind an occupied `c_out` the slot `(c_in, d)` is not a boundary face at all). The
//! paper's rule against capturing the interior, "not assigned to a subvoxel already associated
//! with a face on the opposite", is read order-independently: a child can only receive `d` as
//! `c_in` of `(p, d)` and `-d` as `c_out` of `(p, -d)`, and then `c_out` wins. (The closure may
//! still give that child both sides when its sheet is two-sided.) Every subface remembers its
//! parent face and quadrant: the subdivision connectivity the hierarchy records.

use octowrap_geom::morton;
use octowrap_mesh::{FaceOrigin, Quadrant};
use rayon::prelude::*;

use crate::lattice::{Side, axis, corner_offset, opposite, plane_axes, sign, slot, unslot};
use crate::octree::Cells;
use crate::rankmap::RankMap;
use crate::sheet::Mask;

/// The subfaces of `coarse_slots` (level `j`, sorted, face `i` = slot `i`) on level `fine.level`,
/// sorted by slot key, with their origins.
pub(crate) fn refine(
    coarse_slots: &[u64],
    coarse_index: &RankMap,
    fine: &Cells,
    mask: &Mask,
) -> Vec<(u64, FaceOrigin)> {
    let allowed =
        |code: u64, side: Side| -> bool { fine.find(code).is_some_and(|i| mask.allows(i, morton::decode(code), side)) };
    let mut out: Vec<(u64, FaceOrigin)> = coarse_slots
        .par_iter()
        .enumerate()
        .flat_map_iter(|(fi, &s)| {
            let (p, d) = unslot(s);
            let pc = morton::decode(p);
            let a = axis(d);
            let (b, c) = plane_axes(a);
            let out_bit = u32::from(sign(d) > 0);
            let has_opposite = coarse_index.contains(slot(p, opposite(d)));
            (0..4u8).filter_map(move |q| {
                let o = corner_offset(d, usize::from(q));
                let mut child = [2 * pc[0], 2 * pc[1], 2 * pc[2]];
                child[b] += o[0];
                child[c] += o[1];
                let mut cout = child;
                cout[a] += out_bit;
                let mut cin = child;
                cin[a] += 1 - out_bit;
                let kout = morton::encode(cout[0], cout[1], cout[2]);
                let kin = morton::encode(cin[0], cin[1], cin[2]);
                let origin = FaceOrigin::Subface { parent: fi as u32, quadrant: Quadrant(q) };
                if fine.occupied(kout) {
                    return allowed(kout, d).then_some((slot(kout, d), origin));
                }
                if !allowed(kin, d) {
                    return None;
                }
                // c_out wins: `c_in` also receives -d as `c_out` of the opposite face.
                if has_opposite && allowed(kin, opposite(d)) {
                    return None;
                }
                Some((slot(kin, d), origin))
            })
        })
        .collect();
    out.par_sort_unstable_by_key(|e| e.0);
    out
}
