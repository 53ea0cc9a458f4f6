//! 3D Morton (Z-order) codes: 21 bits per axis interleaved into a `u64`, bit `3i` from x,
//! `3i+1` from y, `3i+2` from z. Sorting cells by code groups the 8 children of every parent
//! together, which is what octree construction level by level needs.

/// Highest supported octree depth (21 bits per axis).
pub const MAX_DEPTH: u32 = 21;

/// Spreads the low 21 bits of `v` so that bit `i` lands on bit `3i`.
#[inline]
pub fn spread(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// Inverse of [`spread`]: gathers bits `3i` into bit `i`.
#[inline]
pub fn compact(v: u64) -> u32 {
    let mut x = v & 0x1249_2492_4924_9249;
    x = (x | (x >> 2)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x >> 4)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x >> 8)) & 0x001f_0000_ff00_00ff;
    x = (x | (x >> 16)) & 0x001f_0000_0000_ffff;
    x = (x | (x >> 32)) & 0x1f_ffff;
    x as u32
}

/// Morton code of cell `(x, y, z)`; each coordinate must be below `2^21`.
#[inline]
pub fn encode(x: u32, y: u32, z: u32) -> u64 {
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

/// Cell coordinates of a Morton code.
#[inline]
pub fn decode(code: u64) -> [u32; 3] {
    [compact(code), compact(code >> 1), compact(code >> 2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn small_codes() {
        assert_eq!(encode(1, 0, 0), 1);
        assert_eq!(encode(0, 1, 0), 2);
        assert_eq!(encode(0, 0, 1), 4);
        assert_eq!(encode(1, 1, 1), 7);
        assert_eq!(encode(2, 0, 0), 8);
        // Parent code is the child code shifted by 3.
        assert_eq!(encode(5, 6, 7) >> 3, encode(2, 3, 3));
    }

    proptest! {
        #[test]
        fn round_trip(x in 0u32..(1 << 21), y in 0u32..(1 << 21), z in 0u32..(1 << 21)) {
            prop_assert_eq!(decode(encode(x, y, z)), [x, y, z]);
        }
    }
}
