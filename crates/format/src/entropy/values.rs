//! Coded value blocks (spec §6.9): a sequence of unsigned 32-bit values, stored either as byte
//! planes (§1.5) or range coded with an adaptive model whose contexts come from the two values
//! before (after the magnitude contexts of Khodakovsky and Guskov, *Compression of normal meshes*,
//! 2003, §4, and the bit-length binarization of Draco's and CABAC's Exp-Golomb codes).
//!
//! A value `x` with bit length `n` (0 for `x = 0`) is coded as `n` in unary (adaptive bits under
//! the context class of the two previous values' bit lengths and the bit's position), then below
//! its leading one: the next bit adaptive (by `n`), the bits between direct, the last bit adaptive
//! (by `n`; it is the sign of a zigzagged difference).

use crate::bytes::{Reader, put_planes, put_varint};
use crate::entropy::range::{Decoder, Encoder, PROB_INIT};
use crate::error::DecodeError;

/// A value block stored as byte planes (spec §6.9 `coding` 0).
pub const CODING_PLANES: u8 = 0;
/// A value block range coded (spec §6.9 `coding` 1).
pub const CODING_RANGE: u8 = 1;

/// Context classes of the bit length: `min(n1 + n2, 15)` of the two previous values' bit lengths.
const CLASSES: usize = 16;

/// The adaptive probabilities of one value block, all starting at one half.
struct Model {
    unary: [[u16; 32]; CLASSES],
    top: [u16; 33],
    last: [u16; 33],
}

impl Model {
    fn new() -> Self {
        Self { unary: [[PROB_INIT; 32]; CLASSES], top: [PROB_INIT; 33], last: [PROB_INIT; 33] }
    }
}

#[inline]
fn bit_length(x: u32) -> u32 {
    32 - x.leading_zeros()
}

#[inline]
fn class(n1: u32, n2: u32) -> usize {
    ((n1 + n2) as usize).min(CLASSES - 1)
}

/// Range codes `values` (spec §6.9, `coding` 1's bytes without their length).
pub fn range_code(values: &[u32]) -> Vec<u8> {
    let mut m = Model::new();
    let mut e = Encoder::new();
    let (mut n1, mut n2) = (0u32, 0u32);
    for &x in values {
        let n = bit_length(x);
        let unary = &mut m.unary[class(n1, n2)];
        for p in unary.iter_mut().take(n as usize) {
            e.bit(p, true);
        }
        if n < 32 {
            e.bit(&mut unary[n as usize], false);
        }
        if n >= 2 {
            e.bit(&mut m.top[n as usize], x >> (n - 2) & 1 == 1);
        }
        if n >= 3 {
            e.direct(x >> 1, n - 3);
            e.bit(&mut m.last[n as usize], x & 1 == 1);
        }
        (n2, n1) = (n1, n);
    }
    e.finish()
}

/// Decodes `n` range coded values (spec §6.9) into `out`. `Err(true)`: the block does not start
/// with a zero byte; `Err(false)`: the values need more bytes than `data` holds, or leave some.
pub fn range_decode(data: &[u8], count: usize, out: &mut Vec<u32>) -> Result<(), bool> {
    out.clear();
    let mut d = Decoder::new(data);
    if !d.first_byte_ok() {
        return Err(true);
    }
    out.reserve(count);
    let mut m = Model::new();
    let (mut n1, mut n2) = (0u32, 0u32);
    for _ in 0..count {
        let unary = &mut m.unary[class(n1, n2)];
        let mut n = 0u32;
        while n < 32 && d.bit(&mut unary[n as usize]) {
            n += 1;
        }
        let x = match n {
            0 => 0,
            1 => 1,
            2 => 2 | u32::from(d.bit(&mut m.top[2])),
            _ => {
                let top = u32::from(d.bit(&mut m.top[n as usize]));
                let mid = d.direct(n - 3);
                let last = u32::from(d.bit(&mut m.last[n as usize]));
                1 << (n - 1) | top << (n - 2) | mid << 1 | last
            }
        };
        out.push(x);
        (n2, n1) = (n1, n);
        // Hostile input: stop once the reads ran well past the end.
        if d.consumed() > data.len() + 8 {
            return Err(false);
        }
    }
    if d.consumed() != data.len() {
        return Err(false);
    }
    Ok(())
}

/// Writes a value block (spec §6.9): range coded when that is smaller than the byte planes.
pub fn put_values(out: &mut Vec<u8>, values: &[u32]) {
    let coded = range_code(values);
    let max = values.iter().copied().max().unwrap_or(0);
    let planes = (32 - max.leading_zeros()).div_ceil(8) as usize;
    if coded.len() + 5 < 1 + planes * values.len() {
        out.push(CODING_RANGE);
        put_varint(out, coded.len() as u64);
        out.extend(coded);
    } else {
        out.push(CODING_PLANES);
        put_planes(out, &values.iter().map(|&v| u64::from(v)).collect::<Vec<_>>());
    }
}

/// Reads a value block of `count` values (spec §6.9) into `out`; byte planes hold at most four
/// planes.
pub fn read_values(r: &mut Reader<'_>, count: usize, out: &mut Vec<u32>) -> Result<(), DecodeError> {
    let at = r.offset();
    match r.u8()? {
        CODING_PLANES => {
            r.plane_view(count, 4)?.decode_into(out);
            Ok(())
        }
        CODING_RANGE => {
            let len = r.varint()?;
            let len = usize::try_from(len).ok().filter(|&l| l <= r.remaining()).ok_or_else(|| {
                r.invalid(format!("range coded block of {len} bytes, {} left in the stream", r.remaining()))
            })?;
            let start = r.offset();
            let data = r.bytes(len)?;
            range_decode(data, count, out).map_err(|first| {
                if first {
                    r.invalid_at(start, "range coded block does not start with a zero byte")
                } else {
                    r.invalid_at(
                        start,
                        format!("range coded block of {len} bytes does not hold exactly {count} values"),
                    )
                }
            })
        }
        c => Err(r.invalid_at(at, format!("unknown value block coding {c}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::{range_code, range_decode};

    fn values(seed: u64, n: usize, spread: u32) -> Vec<u32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                let bits = (s >> 59) as u32 % (spread + 1);
                ((s >> 20) as u32) >> (32 - bits.max(1)) & if bits == 0 { 0 } else { u32::MAX }
            })
            .collect()
    }

    #[test]
    fn round_trips_and_reads_exactly_its_bytes() {
        for (seed, n, spread) in [(1, 0, 4), (2, 1, 32), (3, 1000, 3), (4, 5000, 32), (5, 300, 0), (6, 2000, 12)] {
            let v = values(seed, n, spread);
            let coded = range_code(&v);
            assert_eq!(coded[0], 0);
            let mut out = Vec::new();
            range_decode(&coded, v.len(), &mut out).unwrap();
            assert_eq!(out, v, "seed {seed}");
            // One byte fewer or more is an error, never a panic.
            assert!(range_decode(&coded[..coded.len() - 1], v.len(), &mut out).is_err());
            let mut longer = coded.clone();
            longer.push(0);
            assert!(range_decode(&longer, v.len(), &mut out).is_err());
        }
    }

    #[test]
    fn extreme_values_round_trip() {
        let v = vec![u32::MAX, 0, 1, 2, 3, u32::MAX - 1, 1 << 31, 7, 0, 0, 0, u32::MAX];
        let mut out = Vec::new();
        range_decode(&range_code(&v), v.len(), &mut out).unwrap();
        assert_eq!(out, v);
    }

    #[test]
    fn skewed_values_cost_less_than_a_bit() {
        let v: Vec<u32> = (0..10_000).map(|i| u32::from(i % 97 == 0)).collect();
        let coded = range_code(&v);
        assert!(coded.len() * 8 < v.len() / 5, "{} bytes", coded.len());
    }

    #[test]
    fn garbage_fails_cleanly() {
        let mut s = 7u64;
        for len in 0..64 {
            let data: Vec<u8> = (0..len)
                .map(|i| {
                    s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    if i == 0 { 0 } else { (s >> 33) as u8 }
                })
                .collect();
            let mut out = Vec::new();
            let _ = range_decode(&data, 1000, &mut out);
        }
    }
}
