//! Byte-level primitives of spec §1 Conventions: varints (§1.3), zigzag (§1.4), byte planes (§1.5),
//! and a bounds-checked reader that names the offset of every failure.

use crate::error::{DecodeError, Where};

/// Appends `v` as an unsigned LEB128 varint (7 bits per byte, least significant group first).
pub fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Zigzag mapping of a signed value: 0, -1, 1, -2, ... become 0, 1, 2, 3, ...
pub fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// Inverse of [`zigzag`].
pub fn unzigzag(v: u64) -> i64 {
    ((v >> 1) as i64) ^ -((v & 1) as i64)
}

/// Writes `values` as byte planes (spec §1.5): one count byte `P` (the fewest bytes that hold the
/// largest value, 0 for all zeros), then `P` planes of `values.len()` bytes, least significant first.
pub fn put_planes(out: &mut Vec<u8>, values: &[u64]) {
    let max = values.iter().copied().max().unwrap_or(0);
    let planes = (64 - max.leading_zeros()).div_ceil(8) as usize;
    out.push(planes as u8);
    for p in 0..planes {
        out.extend(values.iter().map(|&v| (v >> (8 * p)) as u8));
    }
}

/// A cursor over one stream of a level's decompressed payload (or over the preamble).
/// Every read is bounds-checked; failures name the stream and the absolute offset.
#[derive(Clone)]
pub struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    /// Offset of `data[0]` within the region that `place` names.
    base: u64,
    place: Where,
    stream: &'static str,
}

impl<'a> Reader<'a> {
    /// A reader over `data`, which starts at byte `base` of the region `place`.
    pub fn new(data: &'a [u8], base: u64, place: Where, stream: &'static str) -> Self {
        Self { data, pos: 0, base, place, stream }
    }

    /// Offset of the next byte within the region.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// The bytes not yet read.
    pub fn rest(&self) -> &'a [u8] {
        &self.data[self.pos..]
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// An `Invalid` error at the current offset.
    pub fn invalid(&self, reason: impl Into<String>) -> DecodeError {
        DecodeError::Invalid { place: self.place, offset: self.offset(), what: self.stream, reason: reason.into() }
    }

    /// An `Invalid` error at `offset` (within the region).
    pub fn invalid_at(&self, offset: u64, reason: impl Into<String>) -> DecodeError {
        DecodeError::Invalid { place: self.place, offset, what: self.stream, reason: reason.into() }
    }

    /// Fails unless every byte was consumed (streams have exact lengths).
    pub fn finish(&self) -> Result<(), DecodeError> {
        if self.remaining() != 0 {
            return Err(self.invalid(format!("{} unused bytes at the end of the stream", self.remaining())));
        }
        Ok(())
    }

    /// Reads one byte.
    #[inline]
    pub fn u8(&mut self) -> Result<u8, DecodeError> {
        let Some(&b) = self.data.get(self.pos) else {
            return Err(self.invalid("stream ends early"));
        };
        self.pos += 1;
        Ok(b)
    }

    /// Reads `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        if self.remaining() < n {
            return Err(self.invalid(format!("stream ends early: {n} bytes needed, {} left", self.remaining())));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Reads a little-endian `u32`.
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        let b = self.bytes(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Reads an unsigned LEB128 varint of at most 10 bytes whose value fits in 64 bits.
    #[inline]
    pub fn varint(&mut self) -> Result<u64, DecodeError> {
        // One byte, the common case.
        if let Some(&b) = self.data.get(self.pos) {
            if b < 0x80 {
                self.pos += 1;
                return Ok(u64::from(b));
            }
        }
        let mut v = 0u64;
        for i in 0..10 {
            let b = self.u8()?;
            let low = u64::from(b & 0x7f);
            if i == 9 && b > 1 {
                return Err(self.invalid("varint overflows 64 bits"));
            }
            v |= low << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(self.invalid("varint longer than 10 bytes"))
    }

    /// Reads a varint that must be at most `max`.
    pub fn varint_max(&mut self, max: u64, what: &str) -> Result<u64, DecodeError> {
        let at = self.offset();
        let v = self.varint()?;
        if v > max {
            return Err(DecodeError::Invalid {
                place: self.place,
                offset: at,
                what: self.stream,
                reason: format!("{what} {v} exceeds {max}"),
            });
        }
        Ok(v)
    }

    /// Reads a byte-plane block of `n` values (see [`put_planes`]) with at most `max_planes` planes,
    /// without copying: values are assembled on access.
    pub fn plane_view(&mut self, n: usize, max_planes: u8) -> Result<Planes<'a>, DecodeError> {
        let p = self.u8()?;
        if p > max_planes {
            return Err(self.invalid(format!("plane count {p} exceeds {max_planes}")));
        }
        let need = n.checked_mul(usize::from(p)).ok_or_else(|| self.invalid("plane block too large"))?;
        if need > self.remaining() {
            return Err(self.invalid(format!("plane block needs {need} bytes, {} left", self.remaining())));
        }
        Ok(Planes { bytes: self.bytes(need)?, n, count: usize::from(p) })
    }

    /// Reads a byte-plane block of `n` values (see [`put_planes`]) with at most `max_planes` planes.
    pub fn planes(&mut self, n: usize, max_planes: u8) -> Result<Vec<u64>, DecodeError> {
        let view = self.plane_view(n, max_planes)?;
        let mut out = vec![0u64; n];
        if n > 0 {
            for (plane, bytes) in view.bytes.chunks_exact(n).enumerate() {
                let shift = 8 * plane;
                for (v, &b) in out.iter_mut().zip(bytes) {
                    *v |= u64::from(b) << shift;
                }
            }
        }
        Ok(out)
    }
}

/// A byte-plane block read in place (see [`Reader::plane_view`]).
pub struct Planes<'a> {
    bytes: &'a [u8],
    n: usize,
    count: usize,
}

impl Planes<'_> {
    /// All `n` values into `out` (at most four planes: values below 2^32), plane by plane.
    pub fn decode_into(&self, out: &mut Vec<u32>) {
        out.clear();
        out.resize(self.n, 0);
        if self.n == 0 {
            return;
        }
        for (plane, bytes) in self.bytes.chunks_exact(self.n).enumerate().take(4) {
            let shift = 8 * plane as u32;
            for (v, &b) in out.iter_mut().zip(bytes) {
                *v |= u32::from(b) << shift;
            }
        }
    }

    /// Value `v` (`v < n`).
    #[inline]
    pub fn get(&self, v: usize) -> u64 {
        let mut x = 0u64;
        for p in 0..self.count {
            x |= u64::from(self.bytes[p * self.n + v]) << (8 * p);
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varints_and_planes_round_trip() {
        let vals = [0u64, 1, 127, 128, 300, u64::from(u32::MAX), u64::MAX];
        let mut b = Vec::new();
        for &v in &vals {
            put_varint(&mut b, v);
        }
        put_planes(&mut b, &[1, 700, 3]);
        let mut r = Reader::new(&b, 0, Where::Preamble, "test");
        for &v in &vals {
            assert_eq!(r.varint().unwrap(), v);
        }
        let mut r2 = r.clone();
        assert_eq!(r.planes(3, 8).unwrap(), vec![1, 700, 3]);
        let view = r2.plane_view(3, 8).unwrap();
        assert_eq!([view.get(0), view.get(1), view.get(2)], [1, 700, 3]);
        r.finish().unwrap();
        for v in [-3i64, -1, 0, 1, i64::MIN, i64::MAX] {
            assert_eq!(unzigzag(zigzag(v)), v);
        }
        assert!(Reader::new(&[0xff; 11], 0, Where::Preamble, "t").varint().is_err());
        assert!(
            Reader::new(&[0xff; 9].iter().chain(&[2]).copied().collect::<Vec<_>>(), 0, Where::Preamble, "t")
                .varint()
                .is_err()
        );
    }
}
