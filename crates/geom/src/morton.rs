//! 3D Morton (Z-order) codes: 21 bits per axis interleaved into a `u64`, bit `3i` from x,
//! `3i+1` from y, `3i+2` from z. Sorting cells by code groups the 8 children of every parent
//! together, which is what octree construction level by level needs.

/// Highest supported octree depth (21 bits per axis).
pub const MAX_DEPTH: u32 = 21;

/// [`spread_bits`] of every byte: bit `i` of the index on bit `3i` of the entry.
const SPREAD_BYTE: [u32; 256] = {
    let mut out = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        out[i] = spread_bits(i as u32) as u32;
        i += 1;
    }
    out
};

/// Spreads the low 21 bits of `v` so that bit `i` lands on bit `3i`, a byte at a time from a
/// table (three look-ups instead of five shift-and-mask rounds: the encoding is one of the most
/// frequent operations of the reconstruction).
#[inline]
pub fn spread(v: u32) -> u64 {
    u64::from(SPREAD_BYTE[(v & 0xff) as usize])
        | u64::from(SPREAD_BYTE[((v >> 8) & 0xff) as usize]) << 24
        | u64::from(SPREAD_BYTE[((v >> 16) & 0x1f) as usize]) << 48
}

/// [`spread`] by shifts and masks (builds the table).
const fn spread_bits(v: u32) -> u64 {
    let mut x = v as u64 & 0x1f_ffff;
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

    /// The table gives the shift-and-mask spreading on every input bit.
    #[test]
    fn spread_by_table_is_spread_by_bits() {
        for b in 0..21 {
            assert_eq!(spread(1 << b), spread_bits(1 << b));
        }
        for v in (0..1u32 << 21).step_by(997).chain([0x1f_ffff, 0x15_5555, 0x0a_aaaa]) {
            assert_eq!(spread(v), spread_bits(v), "{v:#x}");
        }
    }

    proptest! {
        #[test]
        fn round_trip(x in 0u32..(1 << 21), y in 0u32..(1 << 21), z in 0u32..(1 << 21)) {
            prop_assert_eq!(decode(encode(x, y, z)), [x, y, z]);
        }
    }
}
