//! The lattice vocabulary shared by every stage: voxels named by Morton code, faces named by
//! slots `(voxel, side)`, their corners, and the partner rule across each edge (Keller et al.,
//! §3.3 and §3.5, in the reading of `lattice` docs in the crate root).
//!
//! A slot key packs a voxel's Morton code and a side: `code << 3 | side`, sides numbered
//! `0..6 = +X, -X, +Y, -Y, +Z, -Z` (the numbering of [`octowrap_mesh::LevelLattice`]).

/// Deepest supported level: slot keys need `3 * level + 3` bits.
pub(crate) const MAX_LEVEL: u32 = 20;

/// A side `0..6`.
pub(crate) type Side = u8;

/// Axis `0..3` of a side.
#[inline]
pub(crate) fn axis(side: Side) -> usize {
    usize::from(side >> 1)
}

/// `+1` or `-1`.
#[inline]
pub(crate) fn sign(side: Side) -> i32 {
    if side & 1 == 0 { 1 } else { -1 }
}

/// The opposite side.
#[inline]
pub(crate) fn opposite(side: Side) -> Side {
    side ^ 1
}

/// The side along `axis` with the given sign.
#[inline]
pub(crate) fn side_of(axis: usize, positive: bool) -> Side {
    (axis as u8) * 2 + u8::from(!positive)
}

/// The unit step of a side.
#[inline]
pub(crate) fn step(side: Side) -> [i32; 3] {
    let mut s = [0; 3];
    s[axis(side)] = sign(side);
    s
}

/// Packs a slot key.
#[inline]
pub(crate) fn slot(code: u64, side: Side) -> u64 {
    code << 3 | u64::from(side)
}

/// Unpacks a slot key.
#[inline]
pub(crate) fn unslot(key: u64) -> (u64, Side) {
    (key >> 3, (key & 7) as u8)
}

/// The bits of axis 0 in a Morton code (every third bit from bit 0).
const AXIS_BITS: u64 = 0x1249_2492_4924_9249;

/// Voxel coordinates of `code` moved by `delta` (each component in `-1..=1`), if still inside
/// `[0, 2^level)^3`. Steps are taken on the interleaved bits directly: adding one to an axis
/// fills the other axes' bits with ones so the carry runs through them; subtracting one borrows
/// through zeros in the same way. No decoding, so the neighbour look-ups of every stage stay
/// cheap.
#[inline]
pub(crate) fn offset(code: u64, delta: [i32; 3], level: u32) -> Option<u64> {
    debug_assert!(delta.iter().all(|d| (-1..=1).contains(d)));
    let all = if level >= 21 { u64::MAX >> 1 } else { (1u64 << (3 * level)) - 1 };
    let mut out = code;
    for (a, &d) in delta.iter().enumerate() {
        let mask = (AXIS_BITS << a) & all;
        let bits = out & mask;
        let moved = match d {
            0 => continue,
            1 if bits == mask => return None,
            1 => ((bits | !mask).wrapping_add(1 << a)) & mask,
            _ if bits == 0 => return None,
            _ => bits.wrapping_sub(1 << a) & mask,
        };
        out = (out & !mask) | moved;
    }
    Some(out)
}

/// The codes of the 3x3x3 block around voxel `code` at `level`, in [`crate::octree::BLOCK`]'s
/// order: [`offset`] of every offset of the block (`None` outside `[0, 2^level)^3`), with each
/// axis stepped once (the axes' bits are disjoint, so a neighbour is the other bits with one
/// moved value per axis): a few instructions per neighbour instead of three steps each.
#[inline]
pub(crate) fn block(code: u64, level: u32) -> [Option<u64>; 27] {
    let all = if level >= 21 { u64::MAX >> 1 } else { (1u64 << (3 * level)) - 1 };
    let mut moved = [[None; 3]; 3];
    let mut rest = code;
    for (a, axis) in moved.iter_mut().enumerate() {
        let mask = (AXIS_BITS << a) & all;
        let bits = code & mask;
        rest &= !mask;
        *axis = [
            (bits != 0).then(|| bits.wrapping_sub(1 << a) & mask),
            Some(bits),
            (bits != mask).then(|| ((bits | !mask).wrapping_add(1 << a)) & mask),
        ];
    }
    std::array::from_fn(|i| match (moved[0][i % 3], moved[1][(i / 3) % 3], moved[2][i / 9]) {
        (Some(x), Some(y), Some(z)) => Some(rest | x | y | z),
        _ => None,
    })
}

/// The two in-plane axes `(b, c)` of a face on `axis` (cyclic, so `b x c = axis`).
#[inline]
pub(crate) fn plane_axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// In-plane offsets `(b, c)` of corner `k` of a face on `side`, in the corner order of
/// [`octowrap_geom::cell`] (counter-clockwise seen from outside).
#[inline]
pub(crate) fn corner_offset(side: Side, k: usize) -> [u32; 2] {
    let (b, c) = plane_axes(axis(side));
    let p = octowrap_geom::cell::SIDE_CORNERS[usize::from(side)][k & 3];
    [p[b], p[c]]
}

/// The four lattice corners (in `[0, 2^level]^3`) of the face `(voxel, side)`, in order.
#[inline]
pub(crate) fn corners(voxel: [u32; 3], side: Side) -> [[u32; 3]; 4] {
    let a = axis(side);
    let (b, c) = plane_axes(a);
    let mut base = voxel;
    if sign(side) > 0 {
        base[a] += 1;
    }
    std::array::from_fn(|k| {
        let o = corner_offset(side, k);
        let mut p = base;
        p[b] += o[0];
        p[c] += o[1];
        p
    })
}

/// The in-plane side pointing from the face centre towards edge `k` (corner `k` to `k + 1`).
#[inline]
pub(crate) fn edge_side(side: Side, k: usize) -> Side {
    let a = axis(side);
    let (b, c) = plane_axes(a);
    let o0 = corner_offset(side, k);
    let o1 = corner_offset(side, k + 1);
    // Midpoint offsets relative to the centre, doubled: each is -1, 0 or 1.
    let mb = o0[0] + o1[0];
    let mc = o0[1] + o1[1];
    if mb == 1 {
        debug_assert_ne!(mc, 1);
        side_of(c, mc == 2)
    } else {
        side_of(b, mb == 2)
    }
}

/// Adds two steps.
#[inline]
pub(crate) fn add(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Which of the four voxels around an edge are occupied, as seen from face `(v, d)` across its
/// edge towards `t`: `a = v + t`, `b = v + t + d`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EdgeCase {
    /// `a`, `b` empty: turn the corner onto `(v, t)`.
    Convex,
    /// `a` occupied, `b` empty: `(a, d)`.
    Flat(u64),
    /// `a` and `b` occupied: `(b, -t)`.
    Concave(u64),
    /// Only `b` occupied: the surface passes (`(b, -t)`) or breaks (`(v, t)`): decided per voxel pair.
    Diagonal(u64),
}

/// The configuration around the edge of face `(code, d)` towards `t`, `occupied` telling which
/// voxel codes of the level exist.
#[inline]
pub(crate) fn edge_case(code: u64, d: Side, t: Side, level: u32, occupied: impl Fn(u64) -> bool) -> EdgeCase {
    let a = offset(code, step(t), level).filter(|&k| occupied(k));
    let b = offset(code, add(step(t), step(d)), level).filter(|&k| occupied(k));
    match (a, b) {
        (None, None) => EdgeCase::Convex,
        (Some(a), None) => EdgeCase::Flat(a),
        (Some(_), Some(b)) => EdgeCase::Concave(b),
        (None, Some(b)) => EdgeCase::Diagonal(b),
    }
}

/// The partner slot of face `(code, d)` across its edge towards `t`, given the case and, for the
/// diagonal case, whether the surface passes.
#[inline]
pub(crate) fn partner(code: u64, d: Side, t: Side, case: EdgeCase, pass: impl Fn(u64, u64) -> bool) -> u64 {
    match case {
        EdgeCase::Convex => slot(code, t),
        EdgeCase::Flat(a) => slot(a, d),
        EdgeCase::Concave(b) => slot(b, opposite(t)),
        EdgeCase::Diagonal(b) => {
            if pass(code, b) {
                slot(b, opposite(t))
            } else {
                slot(code, t)
            }
        }
    }
}

/// The unordered key of a voxel pair (for decisions that both voxels must agree on).
#[inline]
pub(crate) fn pair_key(a: u64, b: u64) -> (u64, u64) {
    if a <= b { (a, b) } else { (b, a) }
}

#[cfg(test)]
mod tests {
    use octowrap_geom::morton;

    use super::*;

    #[test]
    fn offsets_match_decoded_arithmetic() {
        let mut seed = 7u64;
        for level in [1u32, 2, 3, 7, 10, 20] {
            let n = 1i64 << level;
            for _ in 0..2000 {
                seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                let c: [u32; 3] = std::array::from_fn(|a| {
                    let r = (seed >> (8 + 16 * a)) as i64 & 0xffff;
                    // Edges of the range are the interesting cases.
                    [0, n - 1, r % n][(seed >> (60 - a)) as usize % 3] as u32
                });
                let code = morton::encode(c[0], c[1], c[2]);
                for delta in crate::octree::BLOCK {
                    let want = (0..3).map(|a| i64::from(c[a]) + i64::from(delta[a])).collect::<Vec<_>>();
                    let want = want
                        .iter()
                        .all(|v| (0..n).contains(v))
                        .then(|| morton::encode(want[0] as u32, want[1] as u32, want[2] as u32));
                    assert_eq!(offset(code, delta, level), want, "level {level} {c:?} {delta:?}");
                }
                let each: Vec<Option<u64>> = crate::octree::BLOCK.iter().map(|&d| offset(code, d, level)).collect();
                assert_eq!(block(code, level).to_vec(), each, "level {level} {c:?}");
            }
        }
    }

    #[test]
    fn corners_are_counter_clockwise_seen_from_outside() {
        for side in 0..6u8 {
            let c = corners([3, 4, 5], side);
            let p: Vec<[f64; 3]> = c.iter().map(|p| p.map(f64::from)).collect();
            let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let e2 = [p[2][0] - p[1][0], p[2][1] - p[1][1], p[2][2] - p[1][2]];
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let s = step(side);
            assert!(n.iter().zip(s).all(|(a, b)| (a - f64::from(b)).abs() < 1e-12), "side {side}");
            // The face lies on the voxel's side.
            let a = axis(side);
            let want = if sign(side) > 0 { [3, 4, 5][a] + 1 } else { [3, 4, 5][a] };
            assert!(c.iter().all(|q| q[a] == want), "side {side}");
        }
    }

    #[test]
    fn edge_sides_point_at_their_edges() {
        for side in 0..6u8 {
            let c = corners([0, 0, 0], side);
            for k in 0..4 {
                let t = edge_side(side, k);
                assert_ne!(axis(t), axis(side));
                let at = axis(t);
                let want = u32::from(sign(t) > 0);
                assert_eq!(c[k][at], want);
                assert_eq!(c[(k + 1) % 4][at], want);
            }
        }
    }

    #[test]
    fn partners_are_symmetric() {
        // Every configuration of the 4 voxels around an edge, every face, both diagonal decisions.
        let level = 3;
        let v = morton::encode(3, 3, 3);
        for mask in 0u8..8 {
            for pass_all in [false, true] {
                for d in 0..6u8 {
                    for k in 0..4 {
                        let t = edge_side(d, k);
                        let a = offset(v, step(t), level).unwrap();
                        let b = offset(v, add(step(t), step(d)), level).unwrap();
                        let vd = offset(v, step(d), level).unwrap();
                        let occ = |c: u64| {
                            c == v
                                || (c == a && mask & 1 != 0)
                                || (c == b && mask & 2 != 0)
                                || (c == vd && mask & 4 != 0)
                        };
                        if occ(vd) {
                            continue;
                        }
                        let pass = |_: u64, _: u64| pass_all;
                        let g = partner(v, d, t, edge_case(v, d, t, level, occ), pass);
                        let (gc, gd) = unslot(g);
                        // Find g's edge that sits on the same lattice edge, and come back.
                        let fc = corners(morton::decode(v), d);
                        let gcs = corners(morton::decode(gc), gd);
                        let k2 = (0..4).find(|&j| gcs[j] == fc[(k + 1) % 4] && gcs[(j + 1) % 4] == fc[k]);
                        let k2 = k2.unwrap_or_else(|| panic!("no matching edge d={d} k={k} mask={mask}"));
                        let t2 = edge_side(gd, k2);
                        let back = partner(gc, gd, t2, edge_case(gc, gd, t2, level, occ), pass);
                        assert_eq!(back, slot(v, d), "d={d} k={k} mask={mask} pass={pass_all}");
                    }
                }
            }
        }
    }
}
