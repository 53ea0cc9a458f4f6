//! Spec §6.9: value blocks, byte planes or range coded, written from the spec's text.

use super::primitives::{Result, Stream, invalid, require};

/// §6.9 "Range decoder": the state and its two operations.
struct RangeDecoder<'a> {
    bytes: &'a [u8],
    next: usize,
    range: u64,
    code: u64,
}

impl RangeDecoder<'_> {
    /// The next byte of the block; bytes past its end read as 0 (the block is rejected afterwards).
    fn byte(&mut self) -> u64 {
        let b = self.bytes.get(self.next).map_or(0, |&b| u64::from(b));
        self.next += 1;
        b
    }

    fn normalize(&mut self) {
        while self.range < 1 << 24 {
            self.range <<= 8;
            self.code = ((self.code << 8) | self.byte()) & 0xFFFF_FFFF;
        }
    }

    /// `decode_bit(p)`: a bit under probability `p` (of a 0, out of 2^12), and `p`'s update.
    fn bit(&mut self, p: &mut u64) -> u64 {
        let bound = (self.range >> 12) * *p;
        let bit = if self.code < bound {
            self.range = bound;
            *p += (4096 - *p) >> 4;
            0
        } else {
            self.code -= bound;
            self.range -= bound;
            *p -= *p >> 4;
            1
        };
        self.normalize();
        bit
    }

    /// `decode_direct()`: a bit of probability one half.
    fn direct(&mut self) -> u64 {
        self.range >>= 1;
        let bit = if self.code >= self.range {
            self.code -= self.range;
            1
        } else {
            0
        };
        self.normalize();
        bit
    }
}

/// §6.9: `count` values of a value block.
pub fn read(g: &mut Stream<'_>, count: usize) -> Result<Vec<u64>> {
    match g.u8()? {
        0 => g.plane_block(count, 4),
        1 => {
            let len = g.varint()?;
            require(len <= g.remaining() as u64, || format!("{}: range coded block of {len} bytes", g.name))?;
            let bytes = g.bytes(len as usize)?;
            require(bytes.first() == Some(&0), || format!("{}: range coded block's first byte", g.name))?;
            let mut d = RangeDecoder { bytes, next: 1, range: 0xFFFF_FFFF, code: 0 };
            for _ in 0..4 {
                d.code = (d.code << 8) | d.byte();
            }
            // Probabilities: unary[class][i], top[n], last[n], all 2048.
            let mut unary = vec![[2048u64; 32]; 16];
            let mut top = [2048u64; 33];
            let mut last = [2048u64; 33];
            let (mut n1, mut n2) = (0usize, 0usize);
            let mut values = Vec::new();
            for _ in 0..count {
                let class = (n1 + n2).min(15);
                let mut n = 0;
                while n < 32 && d.bit(&mut unary[class][n]) == 1 {
                    n += 1;
                }
                let x = if n == 0 {
                    0
                } else if n == 1 {
                    1
                } else {
                    let mut x = 1u64 << (n - 1);
                    x |= d.bit(&mut top[n]) << (n - 2);
                    if n >= 3 {
                        for i in (1..n - 2).rev() {
                            x |= d.direct() << i;
                        }
                        x |= d.bit(&mut last[n]);
                    }
                    x
                };
                values.push(x);
                (n2, n1) = (n1, n);
                require(d.next <= bytes.len() + 8, || format!("{}: range coded block too short", g.name))?;
            }
            require(d.next == bytes.len(), || {
                format!("{}: range coded block of {} bytes, {} read", g.name, bytes.len(), d.next)
            })?;
            Ok(values)
        }
        c => invalid(format!("{}: value block coding {c}", g.name)),
    }
}
