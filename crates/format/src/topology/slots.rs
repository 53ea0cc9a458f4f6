//! Octree lattice keys of spec §5.3 (Lattice faces) and §5.8 (Raw lattice): slot keys, corner
//! keys, the child slot under a parent quadrant, and the raw lattice stream in both directions. A
//! slot's canonical corner order is `octowrap_geom::cell`'s.

use octowrap_geom::cell::{SIDE_CORNER_UW, side_axis as normal_axis, side_is_positive as positive};
pub use octowrap_geom::cell::{side_corners as slot_corners, side_plane_axes as plane_axes};

use crate::block::s;
use crate::bytes::{Reader, put_varint, unzigzag, zigzag};
use crate::error::DecodeError;
use crate::level_decode::PlainLevel;
use crate::level_encode::Streams;

/// The deepest level whose lattice a file may name (keys then fit in 64 bits with room to spare).
pub const MAX_LATTICE_DEPTH: u32 = 20;

/// The corner keys (depth `depth`) of the four canonical corners of slot `(voxel, side)`, in
/// canonical order: [`corner_key`] of [`slot_corners`], with two multiplications instead of eight.
#[allow(clippy::inline_always)] // once per face in the level decoder's face loop
#[inline(always)]
pub fn slot_corner_keys(voxel: [u32; 3], side: u8, depth: u32) -> [u64; 4] {
    let n = normal_axis(side);
    let (u, w) = plane_axes(side);
    let mut base = voxel;
    if positive(side) {
        base[n] += 1;
    }
    let m = (1u64 << depth) + 1;
    let stride = [1, m, m * m];
    let k0 = corner_key(base, depth);
    let (du, dw) = (stride[u], stride[w]);
    [k0, k0 + du, k0 + du + dw, k0 + dw]
}

/// [`child_slot`] under the slot's canonical corner `cp` (`0..4`), which always exists.
#[allow(clippy::inline_always)] // once per subface in the level decoder's face loop
#[inline(always)]
pub fn child_slot_at(voxel: [u32; 3], side: u8, cp: usize, inner: bool) -> ([u32; 3], u8) {
    let n = normal_axis(side);
    let (u, w) = plane_axes(side);
    let (du, dw) = SIDE_CORNER_UW[cp & 3];
    let mut child = [0u32; 3];
    child[u] = 2 * voxel[u] + du;
    child[w] = 2 * voxel[w] + dw;
    let outer = if positive(side) { 2 * voxel[n] + 1 } else { 2 * voxel[n] };
    child[n] = if inner { outer ^ 1 } else { outer };
    (child, side)
}

/// Slot key at depth `k`: `((z * N + y) * N + x) * 6 + side`, `N = 2^k`.
pub fn slot_key(voxel: [u32; 3], side: u8, depth: u32) -> u64 {
    let n = 1u64 << depth;
    ((u64::from(voxel[2]) * n + u64::from(voxel[1])) * n + u64::from(voxel[0])) * 6 + u64::from(side)
}

/// Inverse of [`slot_key`]; `None` when the key lies outside the depth's range.
pub fn slot_from_key(key: u64, depth: u32) -> Option<([u32; 3], u8)> {
    let n = 1u64 << depth;
    if key >= 6 * n * n * n {
        return None;
    }
    let side = (key % 6) as u8;
    let v = key / 6;
    Some(([(v % n) as u32, ((v / n) % n) as u32, (v / (n * n)) as u32], side))
}

/// Morton slot key (spec §5.3): `morton(v) * 6 + side`, where `morton` interleaves the voxel's
/// bits as `... z1 y1 x1 z0 y0 x0`. Orders created faces along a space-filling curve.
pub fn morton_slot_key(voxel: [u32; 3], side: u8) -> u64 {
    let m = spread3(voxel[0]) | spread3(voxel[1]) << 1 | spread3(voxel[2]) << 2;
    m * 6 + u64::from(side)
}

/// Bits 0-20 of `x` moved to bits 0, 3, 6, ... 60.
fn spread3(x: u32) -> u64 {
    let mut v = u64::from(x) & 0x1f_ffff;
    v = (v | v << 32) & 0x001f_0000_0000_ffff;
    v = (v | v << 16) & 0x001f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    v = (v | v << 2) & 0x1249_2492_4924_9249;
    v
}

/// The inverse of [`spread3`]: bits 0, 3, 6, ... 60 of `v` packed into bits 0-20.
fn compact3(v: u64) -> u32 {
    let mut v = v & 0x1249_2492_4924_9249;
    v = (v | v >> 2) & 0x10c3_0c30_c30c_30c3;
    v = (v | v >> 4) & 0x100f_00f0_0f00_f00f;
    v = (v | v >> 8) & 0x001f_0000_ff00_00ff;
    v = (v | v >> 16) & 0x001f_0000_0000_ffff;
    v = (v | v >> 32) & 0x1f_ffff;
    v as u32
}

/// Inverse of [`morton_slot_key`]; `None` when the slot lies outside depth `k`.
pub fn slot_from_morton_key(key: u64, depth: u32) -> Option<([u32; 3], u8)> {
    let side = (key % 6) as u8;
    let m = key / 6;
    // 21 bits per axis hold 63 bits; bit 63 of `m` would be lost (and cannot be a valid voxel).
    if m >> 63 != 0 {
        return None;
    }
    let v = [compact3(m), compact3(m >> 1), compact3(m >> 2)];
    slot_in_range(v, side, depth).then_some((v, side))
}

/// Corner key at depth `k`: `(z * (N + 1) + y) * (N + 1) + x`, `N = 2^k`.
pub fn corner_key(c: [u32; 3], depth: u32) -> u64 {
    let m = (1u64 << depth) + 1;
    (u64::from(c[2]) * m + u64::from(c[1])) * m + u64::from(c[0])
}

/// Inverse of [`corner_key`]; `None` outside the depth's range.
pub fn corner_from_key(key: u64, depth: u32) -> Option<[u32; 3]> {
    let m = (1u64 << depth) + 1;
    if key >= m * m * m {
        return None;
    }
    Some([(key % m) as u32, ((key / m) % m) as u32, (key / (m * m)) as u32])
}

/// [`corner_from_key`] for many valid keys of one depth: below 2^32, divisions by `2^k + 1` as
/// multiplications by a 64-bit reciprocal (exact for 32-bit operands, Lemire et al. 2019).
pub struct CornerKeys {
    m: u64,
    recip: Option<u64>,
}

impl CornerKeys {
    /// Corner keys of depth `depth`.
    pub fn new(depth: u32) -> Self {
        let m = (1u64 << depth) + 1;
        Self { m, recip: (m * m * m <= 1 << 32).then(|| u64::MAX / m + 1) }
    }

    /// The lattice corner of a key that is valid at this depth.
    #[inline]
    pub fn corner(&self, key: u64) -> [u32; 3] {
        let m = self.m;
        match self.recip {
            Some(r) if key < 1 << 32 => {
                let div = |n: u64| ((u128::from(r) * u128::from(n)) >> 64) as u64;
                let q1 = div(key);
                let z = div(q1);
                [(key - q1 * m) as u32, (q1 - z * m) as u32, z as u32]
            }
            _ => [(key % m) as u32, ((key / m) % m) as u32, (key / (m * m)) as u32],
        }
    }
}

/// Whether a voxel lies in `[0, 2^k)^3` and a side in `0..6`.
pub fn slot_in_range(voxel: [u32; 3], side: u8, depth: u32) -> bool {
    side < 6 && voxel.iter().all(|&c| u64::from(c) < (1u64 << depth))
}

/// Whether a corner lies in `[0, 2^k]^3`.
pub fn corner_in_range(c: [u32; 3], depth: u32) -> bool {
    c.iter().all(|&x| u64::from(x) <= (1u64 << depth))
}

/// The child slot (depth `k + 1`) under quadrant corner `corner` of the parent slot `(voxel, side)`
/// (depth `k`): `inner == false` is the child voxel touching the parent's face (`c_out`),
/// `inner == true` the one behind it (`c_in`). `None` when `corner` is not a corner of the slot.
pub fn child_slot(voxel: [u32; 3], side: u8, corner: [u32; 3], inner: bool) -> Option<([u32; 3], u8)> {
    let n = normal_axis(side);
    let (u, w) = plane_axes(side);
    let plane = voxel[n] + u32::from(positive(side));
    if corner[n] != plane {
        return None;
    }
    let mut child = [0u32; 3];
    for a in [u, w] {
        let d = corner[a].wrapping_sub(voxel[a]);
        if d > 1 {
            return None;
        }
        child[a] = 2 * voxel[a] + d;
    }
    let outer = if positive(side) { 2 * voxel[n] + 1 } else { 2 * voxel[n] };
    // c_out is the child touching the face; c_in the other child along the normal.
    child[n] = if inner { outer ^ 1 } else { outer };
    Some((child, side))
}

/// Grid coordinates of lattice corner `c` at depth `k` when the grid has `2^bits` steps across the
/// cube: `floor(c * 2^bits / 2^k)` per axis.
pub fn lattice_point(c: [u32; 3], depth: u32, bits: u32) -> [i64; 3] {
    let at = |x: u32| ((u64::from(x) << bits) >> depth) as i64;
    [at(c[0]), at(c[1]), at(c[2])]
}

/// A face's slot: its voxel and side (spec §5.3).
pub type Slot = ([u32; 3], u8);

/// Reads the raw lattice coordinates of a mode 0 or 1 level of depth `k` (spec §5.8 Raw
/// lattice): `nf` slot keys, then `nv` corner keys, each list as zigzag deltas.
pub fn decode_raw_lattice(
    r: &mut Reader<'_>,
    k: u32,
    nf: usize,
    nv: usize,
) -> Result<(Vec<Slot>, Vec<[u32; 3]>), DecodeError> {
    let mut slots = Vec::with_capacity(nf);
    let mut key = 0i64;
    for _ in 0..nf {
        key = key.wrapping_add(unzigzag(r.varint()?));
        let slot = u64::try_from(key)
            .ok()
            .and_then(|x| slot_from_key(x, k))
            .ok_or_else(|| r.invalid(format!("slot key {key} outside level {k}")))?;
        slots.push(slot);
    }
    let mut corners = Vec::with_capacity(nv);
    key = 0;
    for _ in 0..nv {
        key = key.wrapping_add(unzigzag(r.varint()?));
        let c = u64::try_from(key)
            .ok()
            .and_then(|x| corner_from_key(x, k))
            .ok_or_else(|| r.invalid(format!("corner key {key} outside level {k}")))?;
        corners.push(c);
    }
    Ok((slots, corners))
}

/// Writes a mode 0 or 1 level's lattice coordinates (§5.8): its slot keys, then its corner
/// keys, each list as zigzag deltas.
pub fn encode_raw_lattice(st: &mut Streams, level: &PlainLevel, k: u32) {
    let r = &mut st.0[s::RAW_LATTICE];
    let mut prev = 0i64;
    for &(v, d) in level.slots.as_deref().unwrap_or_default() {
        let key = slot_key(v, d, k) as i64;
        put_varint(r, zigzag(key - prev));
        prev = key;
    }
    prev = 0;
    for &c in level.corners.as_deref().unwrap_or_default() {
        let key = corner_key(c, k) as i64;
        put_varint(r, zigzag(key - prev));
        prev = key;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_round_trip_and_corners_turn_outward() {
        for side in 0..6u8 {
            let k = slot_key([3, 1, 2], side, 2);
            assert_eq!(slot_from_key(k, 2), Some(([3, 1, 2], side)));
            let c = slot_corners([0, 0, 0], side);
            let p = |i: usize| glam_like(c[i]);
            let e1 = sub(p(1), p(0));
            let e2 = sub(p(3), p(0));
            let nrm = cross(e1, e2);
            let mut want = [0i64; 3];
            want[normal_axis(side)] = if positive(side) { 1 } else { -1 };
            assert_eq!(nrm, want, "side {side}");
        }
        assert_eq!(corner_from_key(corner_key([4, 0, 3], 2), 2), Some([4, 0, 3]));
        assert_eq!(morton_slot_key([1, 0, 0], 0), 6);
        assert_eq!(morton_slot_key([0, 1, 1], 5), 6 * 6 + 5);
        for (v, d) in [([3u32, 1, 2], 4u8), ([0, 0, 0], 0), ([7, 7, 7], 5)] {
            assert_eq!(slot_from_morton_key(morton_slot_key(v, d), 3), Some((v, d)));
        }
        assert_eq!(slot_from_morton_key(morton_slot_key([8, 0, 0], 0), 3), None);
        for x in [0u32, 1, 5, 0x1f_ffff, 0x12_3456] {
            let naive: u64 = (0..21).map(|b| u64::from((x >> b) & 1) << (3 * b)).sum();
            assert_eq!(spread3(x), naive);
            assert_eq!(compact3(naive), x);
        }
        assert_eq!(slot_from_morton_key(u64::MAX, 20), None);
        assert_eq!(corner_from_key(125, 2), None);
        for depth in 0..=6u32 {
            let ck = CornerKeys::new(depth);
            let m = (1u64 << depth) + 1;
            assert!((0..m * m * m).all(|key| Some(ck.corner(key)) == corner_from_key(key, depth)));
        }
        let ck = CornerKeys::new(10);
        assert!((0..1025u64 * 1025 * 1025).step_by(9973).all(|key| Some(ck.corner(key)) == corner_from_key(key, 10)));
        for depth in [0u32, 1, 3, 7, 10, 11, 20] {
            let ck = CornerKeys::new(depth);
            let m = (1u64 << depth) + 1;
            for key in [0, 1, m - 1, m, m * m - 1, m * m, (m * m * m / 2 + 7).min(m * m * m - 1), m * m * m - 1] {
                assert_eq!(Some(ck.corner(key)), corner_from_key(key, depth), "depth {depth} key {key}");
            }
        }
    }

    #[test]
    fn fast_slot_helpers_agree_with_the_definitions() {
        for side in 0..6u8 {
            for voxel in [[0u32, 0, 0], [3, 1, 2], [7, 0, 5]] {
                let sc = slot_corners(voxel, side);
                assert_eq!(slot_corner_keys(voxel, side, 3), sc.map(|c| corner_key(c, 3)));
                for (cp, &c) in sc.iter().enumerate() {
                    for inner in [false, true] {
                        assert_eq!(Some(child_slot_at(voxel, side, cp, inner)), child_slot(voxel, side, c, inner));
                    }
                }
            }
        }
    }

    #[test]
    fn child_slots() {
        // +Z face of voxel (1,1,1) at depth 1; corner (2,1,2) -> in-plane child (3,2), outer z = 3.
        assert_eq!(child_slot([1, 1, 1], 4, [2, 1, 2], false), Some(([3, 2, 3], 4)));
        assert_eq!(child_slot([1, 1, 1], 4, [2, 1, 2], true), Some(([3, 2, 2], 4)));
        assert_eq!(child_slot([1, 1, 1], 5, [1, 1, 1], false), Some(([2, 2, 2], 5)));
        assert_eq!(child_slot([1, 1, 1], 5, [1, 1, 1], true), Some(([2, 2, 3], 5)));
        assert_eq!(child_slot([1, 1, 1], 4, [2, 1, 1], false), None);
    }

    fn glam_like(c: [u32; 3]) -> [i64; 3] {
        c.map(i64::from)
    }
    fn sub(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn cross(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }
}
