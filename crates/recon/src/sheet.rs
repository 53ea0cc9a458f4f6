//! Which faces may exist: the oriented-sheet mask that keeps open surfaces one-sided
//! (Keller et al., §3.4 "rules preventing faces of `M_j` to capture parts of the interior hull", and
//! the stop rules 1 and 2 of §3.5).
//!
//! Reading: the paper's stop rules (no face "on the opposite of v"; the cavity rule) are stated
//! per visit, so read literally they depend on the order in which faces are processed; they
//! both let holes close and refuse to wrap one-voxel protrusions. They are replaced by one
//! order-independent predicate on slots,
//! applied both to the regular refinement (§3.4) and to the closure (§3.5):
//!
//! 1. Every occupied voxel `c` of level `j + 1` gets a sheet: the plane fitted to the points of its
//!    3x3x3 block (centre `m`, normal `n`). It is *reliable* when the block holds at least 8 points
//!    and `sqrt(l0) < 0.5 sqrt(l1)` (a flat neighbourhood). It is *two-sided* when the voxel's own
//!    points lie in two layers along `n` (a thin closed part: both sides are real surface).
//! 2. The normal is oriented outwards by the level-`j` mesh, which encloses the object: the faces
//!    `(p, d)` of `M_j` on `c`'s parent `p` vote with the sign of `d . n` (when `|d . n| > 0.3`). Mixed
//!    votes (a part thinner than `p`, or the root) are settled by where `c`'s points lie in `p`
//!    along `n` (the upper child of a thin plate faces up); no faces on `p`: the votes of the faces
//!    on `p`'s 26 neighbours. Two neighbours on the same plane (own point means within a tenth of
//!    a voxel along the normal) that disagree are one sheet lying across a voxel boundary, not
//!    the two sides of a plate: both become unsettled. Unsettled voxels take the orientation of
//!    their settled neighbours
//!    (three synchronous sweeps); what remains (an isolated flat sheet seen equally from both
//!    sides) faces the positive direction of its dominant axis, a deterministic tie-break.
//! 3. Slot `(c, d)` is refused when `c`'s sheet is reliable, oriented and not two-sided, and either
//!    `d . n <= -0.3` (the face looks into the object) or the face centre lies more than a quarter
//!    voxel behind the plane (the underside of a tilted sheet).
//!
//! 4. An unreliable voxel that continues its oriented neighbours' sheet *leans* with them: when at
//!    least 3 oriented voxels of its block agree on a normal (their sum at least 0.8 of their
//!    count long), its points' mean lies within half a voxel of their planes on average and its
//!    points are one thin layer along that normal (standard deviation under a tenth of a voxel),
//!    slot `(c, d)` is refused when `d . n <= -0.5`. This is the rim of a hole where the surface
//!    curls (no flat plane fits there): without it the wrapping enters the hole and takes the
//!    rim cells' inner sides too, a lip that the vertex mapping lays onto the outer wall (the
//!    bunny's open bottom: 116 and 254 intersecting face pairs at levels 5 and 6 without leaning,
//!    12 and 13 with it; `docs/decisions.md`, "Leaning rim voxels"). A thin part with two sides
//!    near the surface (a strut beside the dragon's hind leg) has thicker cells and keeps every
//!    slot.
//!
//! A closed surface keeps every outer face (no outward face looks inwards), an open sheet keeps
//! one side only, so holes stay holes, and a one-voxel protrusion (no reliable plane) is wrapped.
//! Tested on a sphere, a torus, a bowl, a disc with a hole, two parallel sheets, a thin closed
//! plate and a plate with a one-voxel pillar (`tests/promises.rs`).
//!
//! Filled voxels ([`crate::regions`]) take no sheet of their own: they allow their parent's
//! subfaces (on the parent face's side of the parent), and the steps of the transition to a dense
//! region, slots looking into an empty child of a dense voxel. Such a step is refused only when
//! it is inwards of every parent face the child lies on (or it lies on none) and its face centre
//! is more than a quarter voxel behind each oriented sheet around: its parent's (from the level
//! above), the dense voxel's, and those of the dense voxels around the empty child. A filled
//! region is up to a voxel thicker than its points, so steps can look sideways or against the
//! normal; a step behind all these planes is on the inner side of a sheet.
//!
//! A hole of one or two voxels in a thinly sampled sheet is a sampling gap, not a hole in the
//! surface; such gaps are filled with point-less voxels before the mask is built
//! ([`crate::octree::Cells::fill_gaps`]), so the mask only ever sees holes the data supports.
//!
//! Known limits: a closed part thinner than a tenth of a voxel whose two sides fall in two voxel
//! layers is read as one sheet and kept one-sided at that level; at level 1 the foot of a thin
//! protrusion and the plate it stands on can share a voxel and leave a small hole there.

use octowrap_geom::{DVec3, Moments, morton};
use rayon::prelude::*;

use crate::lattice::{Side, axis, block, offset, opposite, sign, slot, step};
use crate::octree::{Cells, Octree};
use crate::rankmap::RankMap;

/// Minimum `|d . n|` for a face to vote, and the refusal threshold.
const VOTE: f64 = 0.3;

/// A leaning voxel refuses slots with `d . n <= -LEAN`.
const LEAN: f64 = 0.5;
/// Oriented neighbours needed for an unreliable voxel to lean.
const LEAN_VOTES: u32 = 3;
/// How well they must agree: the length of their normals' sum over their count.
const LEAN_AGREEMENT: f64 = 0.8;
/// How far (voxels, on average) a leaning voxel's points' mean may lie from its neighbours' planes.
const LEAN_OFFSET: f64 = 0.5;
/// How thin (voxels, standard deviation along the common normal) a leaning voxel's points must be.
/// Measured on the dragon: its level-7 strut beside the hind leg has cells between 0.15 and 0.25,
/// and at 0.25 the strut is lost (RMS .00086 -> .00199); the bunny's rim cells lean at 0.07.
const LEAN_SPREAD: f64 = 0.1;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// No reliable plane: every slot allowed.
    Unreliable,
    /// Two layers of points: every slot allowed.
    TwoSided,
    /// Reliable, orientation not yet known.
    Unsigned,
    /// Reliable and oriented: the mask applies.
    Signed,
    /// Unreliable, but its oriented neighbours agree on a side (`n`, outwards): slots looking
    /// clearly against it are refused (the inside of a shell entered through a hole).
    Leaning,
}

/// A voxel's sheet.
#[derive(Clone, Copy, Debug)]
struct Sheet {
    m: DVec3,
    n: DVec3,
    state: State,
}

/// Region bits of a filled voxel ([`crate::regions`]): [`FILLED`], and bit `d` when its slot on
/// side `d` is allowed.
const FILLED: u8 = 1 << 6;

/// The per-voxel sheets of one level.
#[derive(Debug, Default)]
pub(crate) struct Mask {
    sheets: Vec<Sheet>,
    voxel: f64,
    /// Per voxel, its region bits (empty when no voxel is filled).
    region: Vec<u8>,
}

impl Mask {
    /// Whether slot `(cell, side)` of voxel `coords` may carry a face.
    #[inline]
    pub(crate) fn allows(&self, cell: usize, coords: [u32; 3], side: Side) -> bool {
        if let Some(&r) = self.region.get(cell) {
            if r & FILLED != 0 {
                return r & (1 << side) != 0;
            }
        }
        let s = &self.sheets[cell];
        let d = step(side);
        let dn = f64::from(d[0]) * s.n.x + f64::from(d[1]) * s.n.y + f64::from(d[2]) * s.n.z;
        if s.state == State::Leaning {
            return dn > -LEAN;
        }
        if s.state != State::Signed {
            return true;
        }
        if dn <= -VOTE {
            return false;
        }
        self.in_front(s, coords, side)
    }

    /// Whether the centre of face `(coords, side)` lies at most a quarter voxel behind the sheet.
    #[inline]
    fn in_front(&self, s: &Sheet, coords: [u32; 3], side: Side) -> bool {
        in_front(s, coords, side, self.voxel)
    }

    /// Number of voxels whose sheet is oriented (and so constrains faces).
    pub(crate) fn signed_count(&self) -> usize {
        self.sheets.iter().filter(|s| s.state == State::Signed).count()
    }
}

/// Whether the centre of face `(coords, side)` (voxel edge `h`) lies at most a quarter voxel
/// behind the oriented sheet `s`.
#[inline]
fn in_front(s: &Sheet, coords: [u32; 3], side: Side, h: f64) -> bool {
    let mut centre = DVec3::new(f64::from(coords[0]) + 0.5, f64::from(coords[1]) + 0.5, f64::from(coords[2]) + 0.5);
    centre[axis(side)] += 0.5 * f64::from(sign(side));
    (centre * h - s.m).dot(s.n) >= -0.25 * h
}

/// The allowed sides of filled voxel `i` of `fine` (bits `0..6`, with [`FILLED`]): the subfaces
/// of its parent's faces on their side of the parent (the parent's topology), and, where the
/// slot looks into an empty child of a voxel that is not filled (the transition's steps), any
/// side not inwards of a parent face the child lies on, or whose face is not behind the
/// oriented sheet of its own parent or of the voxel it looks into.
fn filled_sides(
    fine: &Cells,
    coarse: &Cells,
    coarse_slots: &RankMap,
    parent_mask: Option<&Mask>,
    sheets: &[Sheet],
    i: usize,
) -> u8 {
    let (key, level, h) = (fine.keys[i], fine.level, fine.voxel());
    let coords = morton::decode(key);
    let parent = key >> 3;
    let sheet_of = |p: u64| {
        parent_mask.zip(coarse.find(p)).and_then(|(m, k)| m.sheets.get(k)).filter(|s| s.state == State::Signed)
    };
    let mut touched = 0u8;
    for d in 0..6u8 {
        if coarse_slots.contains(slot(parent, d)) && (coords[axis(d)] & 1) == u32::from(sign(d) > 0) {
            touched |= 1 << d;
        }
    }
    let mut allowed = touched;
    for side in 0..6u8 {
        if touched & (1 << side) != 0 {
            continue;
        }
        let Some(next) = offset(key, step(side), level) else { continue };
        // Only a step into an empty child of an occupied voxel (a dense one: a sparse voxel's
        // children are all present).
        if fine.occupied(next) || !coarse.occupied(next >> 3) {
            continue;
        }
        let sideways = touched != 0 && touched & (1 << opposite(side)) == 0;
        let front = |p: u64| sheet_of(p).is_some_and(|s| in_front(s, coords, side, h));
        // The sheets of the voxels around the empty one that are not filled.
        let around = || {
            block(next, level).into_iter().flatten().any(|k| {
                fine.find(k).is_some_and(|k| {
                    !fine.is_filled(k) && sheets[k].state == State::Signed && in_front(&sheets[k], coords, side, h)
                })
            })
        };
        if sideways || front(parent) || front(next >> 3) || around() {
            allowed |= 1 << side;
        }
    }
    FILLED | allowed
}

/// Whether `points` lie in two layers along `n`: by height over the plane `(m, n)`, fewer than a
/// fifth of the points lie within half the RMS height (a valley; the rim of a thin plate may
/// sample the space between its sides), or some empty run of a 64-bin height histogram is wider
/// than a twentieth of a voxel and than three times the largest gap expected from uniform sampling
/// (`ln k` mean gaps); either way with at least a tenth of the points (and 2) on either side. A single sheet, noisy or curved, has
/// neither; both sides of a thin plate do.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must count as "no"
fn two_layers(points: &[octowrap_geom::glam::Vec3], m: DVec3, n: DVec3, h: f64) -> bool {
    const BINS: usize = 64;
    // Coarse voxels hold up to all the points: a fixed stride keeps about 4096 of them.
    let stride = (points.len() / 4096).max(1);
    let sample = || points.iter().step_by(stride);
    let k = sample().len();
    if k < 6 {
        return false;
    }
    let (mut lo, mut hi, mut sum2) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for p in sample() {
        let d = (p.as_dvec3() - m).dot(n);
        lo = lo.min(d);
        hi = hi.max(d);
        sum2 += d * d;
    }
    let r = (sum2 / k as f64).sqrt();
    if !(r > 0.05 * h) {
        return false;
    }
    let side = (k / 10).max(2);
    // The valley: few points within half the RMS height.
    let (mut near, mut below, mut above) = (0, 0, 0);
    // The gap, on a histogram of 64 bins (no sort): an empty run wider than the threshold.
    let mut hist = [0u32; BINS];
    let width = (hi - lo) / BINS as f64;
    for p in sample() {
        let d = (p.as_dvec3() - m).dot(n);
        if d.abs() < 0.5 * r {
            near += 1;
        } else if d < 0.0 {
            below += 1;
        } else {
            above += 1;
        }
        hist[(((d - lo) / width) as usize).min(BINS - 1)] += 1;
    }
    if 5 * near < k && below >= side && above >= side {
        return true;
    }
    let need = (3.0 * (k as f64).ln() * (hi - lo) / k as f64).max(0.05 * h);
    let mut count = 0;
    let mut run = 0;
    for &c in &hist {
        if c == 0 {
            run += 1;
            if (run as f64) * width > need && count >= side && k - count >= side {
                return true;
            }
        } else {
            run = 0;
            count += c as usize;
        }
    }
    false
}

/// Builds the mask of level `fine.level` from the points and the faces of the level above.
/// Filled voxels ([`crate::regions`]) take their parent's sheet from `parent_mask` (the mask of
/// the level above) and allow only their parent's subfaces, plus the transition's steps.
pub(crate) fn build(
    tree: &Octree,
    fine: &Cells,
    coarse: &Cells,
    coarse_slots: &RankMap,
    parent_mask: Option<&Mask>,
) -> Mask {
    let h = fine.voxel();
    let mut sheets = block_sheets(tree, fine, coarse, parent_mask);
    orient_from_faces(&mut sheets, fine, coarse, coarse_slots);
    unsign_conflicts(&mut sheets, fine);
    spread_orientation(&mut sheets, fine);
    tie_break(&mut sheets);
    lean_unreliable(&mut sheets, fine);
    let region: Vec<u8> =
        if fine.filled.is_empty() {
            Vec::new()
        } else {
            (0..fine.len())
                .into_par_iter()
                .map(|i| {
                    if fine.is_filled(i) {
                        filled_sides(fine, coarse, coarse_slots, parent_mask, &sheets, i)
                    } else {
                        0
                    }
                })
                .collect()
        };
    Mask { sheets, voxel: h, region }
}

/// Step 1: every voxel's block plane, whether it is reliable, and whether its points lie in two
/// layers. A filled voxel takes its parent's sheet.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN is unreliable
fn block_sheets(tree: &Octree, fine: &Cells, coarse: &Cells, parent_mask: Option<&Mask>) -> Vec<Sheet> {
    let level = fine.level;
    let h = fine.voxel();
    let pts = &tree.points;
    (0..fine.len())
        .into_par_iter()
        .map(|i| {
            let key = fine.keys[i];
            if fine.is_filled(i) {
                // The parent's sheet (its orientation settled a level above).
                let inherited = parent_mask.zip(coarse.find(key >> 3)).and_then(|(m, p)| m.sheets.get(p).copied());
                return inherited.unwrap_or(Sheet { m: DVec3::ZERO, n: DVec3::Z, state: State::Unreliable });
            }
            let mut around = Moments::default();
            for k in block(key, level).into_iter().flatten() {
                if let Some(k) = fine.find(k) {
                    around.merge(&fine.moments[k]);
                }
            }
            let unreliable = Sheet { m: DVec3::ZERO, n: DVec3::Z, state: State::Unreliable };
            if around.count < 8.0 {
                return unreliable;
            }
            let Some(plane) = crate::plane_fit::plane(&around) else { return unreliable };
            let [l0, l1, _] = plane.eigenvalues;
            if !(l0.sqrt() < 0.5 * l1.sqrt()) {
                return unreliable;
            }
            let (m, n) = (plane.point, plane.normal);
            let mut state = State::Unsigned;
            let own = crate::plane_fit::plane(&fine.moments[i]);
            let planes = [Some((m, n)), own.map(|p| (p.point, p.normal))];
            if planes.iter().flatten().any(|&(m, n)| two_layers(&pts[fine.range(i)], m, n, h)) {
                state = State::TwoSided;
            }
            Sheet { m, n, state }
        })
        .collect()
}

/// Step 2: orients the unsigned sheets from the coarse faces on their parent (or, when the
/// parent has none that vote, on the parent's block).
fn orient_from_faces(sheets: &mut [Sheet], fine: &Cells, coarse: &Cells, coarse_slots: &RankMap) {
    let level = fine.level;
    let faces_on = |p: u64| -> [bool; 6] { std::array::from_fn(|d| coarse_slots.contains(slot(p, d as u8))) };
    let votes = |faces: [bool; 6], n: DVec3| -> (u32, u32) {
        let (mut pos, mut neg) = (0, 0);
        for (d, present) in faces.iter().enumerate() {
            if *present {
                let s = n[d / 2] * f64::from(sign(d as u8));
                if s > VOTE {
                    pos += 1;
                } else if s < -VOTE {
                    neg += 1;
                }
            }
        }
        (pos, neg)
    };
    sheets.par_iter_mut().enumerate().for_each(|(i, s)| {
        if s.state != State::Unsigned {
            return;
        }
        let key = fine.keys[i];
        let parent = key >> 3;
        let (pos, neg) = votes(faces_on(parent), s.n);
        let orient = if pos > 0 && neg == 0 {
            1.0
        } else if neg > 0 && pos == 0 {
            -1.0
        } else if pos > 0 && neg > 0 {
            // A part thinner than the parent: where do this child's points lie in it?
            let pi = coarse.find(parent).expect("the parent of an occupied voxel is occupied");
            let (pm, cm) = (coarse.moments[pi], fine.moments[i]);
            let spread = s.n.dot(pm.covariance() * s.n).max(0.0).sqrt();
            let delta = (cm.mean().unwrap_or_default() - pm.mean().unwrap_or_default()).dot(s.n);
            if spread > 0.0 && delta.abs() > 0.25 * spread { delta.signum() } else { 0.0 }
        } else {
            let (mut pos, mut neg) = (0, 0);
            for k in block(parent, level - 1).into_iter().flatten() {
                if coarse.occupied(k) {
                    let (p, q) = votes(faces_on(k), s.n);
                    pos += p;
                    neg += q;
                }
            }
            if pos > 2 * neg {
                1.0
            } else if neg > 2 * pos {
                -1.0
            } else {
                0.0
            }
        };
        if orient != 0.0 {
            s.n *= orient;
            s.state = State::Signed;
        }
    });
}

/// Step 2b: one sheet lying across two voxel layers (a flat sheet on a voxel boundary) must not
/// get two orientations: neighbours on the same plane (own point means within a tenth of a voxel
/// along the normal, normals within 25 degrees) that disagree both take the tie-break below.
fn unsign_conflicts(sheets: &mut [Sheet], fine: &Cells) {
    let (level, h) = (fine.level, fine.voxel());
    let shared: &[Sheet] = sheets;
    let conflicted: Vec<usize> = (0..fine.len())
        .into_par_iter()
        .filter(|&i| shared[i].state == State::Signed && !fine.is_filled(i))
        .filter(|&i| {
            let key = fine.keys[i];
            let mi = fine.moments[i].mean().unwrap_or_default();
            block(key, level).into_iter().flatten().any(|k| {
                fine.find(k).is_some_and(|k| {
                    let mk = fine.moments[k].mean().unwrap_or_default();
                    shared[k].state == State::Signed
                        && !fine.is_filled(k)
                        && shared[k].n.dot(shared[i].n) < -0.9
                        && (mi - mk).dot(shared[i].n).abs() < 0.1 * h
                })
            })
        })
        .collect();
    for i in conflicted {
        sheets[i].state = State::Unsigned;
    }
}

/// Step 3: spreads orientation to unsettled reliable voxels from their signed neighbours, in
/// synchronous sweeps.
fn spread_orientation(sheets: &mut [Sheet], fine: &Cells) {
    for _ in 0..3 {
        let shared: &[Sheet] = sheets;
        let updates: Vec<(usize, f64)> = (0..fine.len())
            .into_par_iter()
            .filter(|&i| shared[i].state == State::Unsigned)
            .filter_map(|i| {
                let key = fine.keys[i];
                let mut sum = 0.0;
                for k in block(key, fine.level).into_iter().flatten() {
                    if let Some(k) = fine.find(k) {
                        if shared[k].state == State::Signed {
                            sum += shared[k].n.dot(shared[i].n);
                        }
                    }
                }
                (sum != 0.0).then_some((i, sum.signum()))
            })
            .collect();
        if updates.is_empty() {
            break;
        }
        for (i, o) in updates {
            sheets[i].n *= o;
            sheets[i].state = State::Signed;
        }
    }
}

/// Step 4: the sheets still unsigned face the positive direction of their dominant axis.
fn tie_break(sheets: &mut [Sheet]) {
    for s in sheets {
        if s.state == State::Unsigned {
            let a = s.n.abs().max_position();
            if s.n[a] < 0.0 {
                s.n = -s.n;
            }
            s.state = State::Signed;
        }
    }
}

/// Step 5: unreliable voxels that continue their oriented neighbours' sheet lean with them.
fn lean_unreliable(sheets: &mut [Sheet], fine: &Cells) {
    let h = fine.voxel();
    let filled = |i: usize| fine.is_filled(i);
    let shared: &[Sheet] = sheets;
    let leaning: Vec<(usize, DVec3)> = (0..fine.len())
        .into_par_iter()
        .filter(|&i| shared[i].state == State::Unreliable && !filled(i))
        .filter_map(|i| lean(fine, shared, i, h, &filled))
        .collect();
    for (i, n) in leaning {
        sheets[i].n = n;
        sheets[i].state = State::Leaning;
    }
}

/// The side unreliable voxel `i` leans to, if it does (item 4 of the module docs): at least
/// [`LEAN_VOTES`] oriented neighbours in its 3x3x3 block whose normals agree (their sum at least
/// [`LEAN_AGREEMENT`] of their count long), its points' mean within [`LEAN_OFFSET`] voxel of their
/// planes on average, and its points spread less than [`LEAN_SPREAD`] voxel along the common
/// normal (one thin layer: the sheet's ragged or curling edge, not a thin part with two sides
/// such as a strut beside the surface, whose cells the wrapping must be free to surround).
fn lean(fine: &Cells, sheets: &[Sheet], i: usize, h: f64, filled: &dyn Fn(usize) -> bool) -> Option<(usize, DVec3)> {
    let own = fine.moments[i].mean()?;
    let (mut sum, mut count, mut off) = (DVec3::ZERO, 0u32, 0.0);
    for k in block(fine.keys[i], fine.level).into_iter().flatten() {
        if let Some(k) = fine.find(k) {
            let s = &sheets[k];
            if s.state == State::Signed && !filled(k) {
                sum += s.n;
                count += 1;
                off += (own - s.m).dot(s.n).abs();
            }
        }
    }
    let c = f64::from(count);
    if count < LEAN_VOTES || sum.length() < LEAN_AGREEMENT * c || off >= LEAN_OFFSET * h * c {
        return None;
    }
    let n = sum.normalize();
    let spread = n.dot(fine.moments[i].covariance() * n).max(0.0).sqrt();
    (spread < LEAN_SPREAD * h).then_some((i, n))
}
