//! The six sides of a lattice cell (an octree voxel) and the order of their corners: the one rule
//! that reconstruction (which builds quads on cell sides) and the MRQ format (which names them,
//! spec/FORMAT.md §5.3) share.
//!
//! Sides `0..6` are `+X, -X, +Y, -Y, +Z, -Z`: side `s` lies across axis `s / 2` and faces its
//! positive direction when `s` is even. On each side two in-plane axes `(u, w)` are chosen so that
//! `u × w` is the side's outward normal, and its four corners are the in-plane offsets
//! [`SIDE_CORNER_UW`] `(0,0), (1,0), (1,1), (0,1)`: counter-clockwise seen from outside the cell.

/// The axis (`0..3`) a side lies across.
#[inline]
pub const fn side_axis(side: u8) -> usize {
    (side / 2) as usize
}

/// Whether a side faces the positive direction of its axis.
#[inline]
pub const fn side_is_positive(side: u8) -> bool {
    side % 2 == 0
}

/// The in-plane axes `(u, w)` of a side, with `u × w` along its outward normal: the cyclic pair
/// after the side's axis on positive sides, that pair swapped on negative sides.
#[inline]
pub const fn side_plane_axes(side: u8) -> (usize, usize) {
    let a = side_axis(side);
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    if side_is_positive(side) { (b, c) } else { (c, b) }
}

/// In-plane offsets `(u, w)` of a side's four corners, counter-clockwise seen from outside.
pub const SIDE_CORNER_UW: [(u32, u32); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// The corners of every side of the cell at the origin, in order: [`side_corners`]`([0; 3], s)`.
pub const SIDE_CORNERS: [[[u32; 3]; 4]; 6] = {
    let mut t = [[[0u32; 3]; 4]; 6];
    let mut s = 0;
    while s < 6 {
        let (u, w) = side_plane_axes(s as u8);
        let mut k = 0;
        while k < 4 {
            if side_is_positive(s as u8) {
                t[s][k][side_axis(s as u8)] = 1;
            }
            t[s][k][u] = SIDE_CORNER_UW[k].0;
            t[s][k][w] = SIDE_CORNER_UW[k].1;
            k += 1;
        }
        s += 1;
    }
    t
};

/// The four lattice corners of side `side` of the cell whose smallest corner is `voxel`, in order
/// (counter-clockwise seen from outside).
#[inline]
pub fn side_corners(voxel: [u32; 3], side: u8) -> [[u32; 3]; 4] {
    SIDE_CORNERS[usize::from(side)].map(|o| [voxel[0] + o[0], voxel[1] + o[1], voxel[2] + o[2]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_turn_counter_clockwise_around_the_outward_normal() {
        for side in 0..6u8 {
            let c = SIDE_CORNERS[usize::from(side)].map(|p| p.map(i64::from));
            let e1: [i64; 3] = std::array::from_fn(|i| c[1][i] - c[0][i]);
            let e2: [i64; 3] = std::array::from_fn(|i| c[3][i] - c[0][i]);
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let mut want = [0i64; 3];
            want[side_axis(side)] = if side_is_positive(side) { 1 } else { -1 };
            assert_eq!(n, want, "side {side}");
            assert_eq!(side_corners([2, 3, 4], side)[2], [2 + c[2][0] as u32, 3 + c[2][1] as u32, 4 + c[2][2] as u32]);
        }
    }
}
