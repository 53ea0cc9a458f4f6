//! The binary range coder of spec §6.9 (after the LZMA range coder: Igor Pavlov, *LZMA
//! specification*, "The range decoder"; G. N. N. Martin, *Range encoding: an algorithm for removing
//! redundancy from a digitised message*, 1979): a 32-bit range, byte-wise renormalization with
//! carry propagation in the encoder, adaptive bit probabilities of [`PROB_BITS`] bits moved by
//! `1 / 2^`[`MOVE_BITS`] of the distance to the coded bit, and direct bits of probability one half.
//!
//! The encoder's output is exactly as long as the decoder reads: four bytes after a first byte that
//! is always zero, then one byte per renormalization. The decoder reads bytes past the end of its
//! input as zero and reports afterwards how far it read, so that hostile input costs no more work
//! than its value count allows and fails cleanly.

/// Bits of an adaptive probability (spec §6.9): probabilities are integers in `(0, 2^12)`.
pub const PROB_BITS: u32 = 12;
/// Adaptation speed: a probability moves by `1 / 2^4` of its distance to the coded bit.
pub const MOVE_BITS: u32 = 4;
/// The initial probability of a zero bit: one half.
pub const PROB_INIT: u16 = 1 << (PROB_BITS - 1);
const TOP: u32 = 1 << 24;

/// The range encoder.
pub struct Encoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
}

impl Encoder {
    /// An encoder with an empty output.
    pub fn new() -> Self {
        Self { low: 0, range: u32::MAX, cache: 0, cache_size: 1, out: Vec::new() }
    }

    fn shift_low(&mut self) {
        if self.low < 0xFF00_0000 || self.low > 0xFFFF_FFFF {
            let carry = (self.low >> 32) as u8;
            let mut c = self.cache;
            loop {
                self.out.push(c.wrapping_add(carry));
                c = 0xFF;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = (self.low >> 24) as u8;
        }
        self.cache_size += 1;
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    /// Codes `bit` with the adaptive probability `p` (of a zero), and adapts `p`.
    #[inline]
    pub fn bit(&mut self, p: &mut u16, bit: bool) {
        let bound = (self.range >> PROB_BITS) * u32::from(*p);
        if bit {
            self.low += u64::from(bound);
            self.range -= bound;
            *p -= *p >> MOVE_BITS;
        } else {
            self.range = bound;
            *p += ((1 << PROB_BITS) - *p) >> MOVE_BITS;
        }
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// Codes the `count` low bits of `value`, most significant first, each with probability one half.
    #[inline]
    pub fn direct(&mut self, value: u32, count: u32) {
        for i in (0..count).rev() {
            self.range >>= 1;
            if value >> i & 1 == 1 {
                self.low += u64::from(self.range);
            }
            while self.range < TOP {
                self.range <<= 8;
                self.shift_low();
            }
        }
    }

    /// Flushes the coder and returns its bytes.
    pub fn finish(mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        self.out
    }
}

/// The range decoder over one coded block's bytes.
pub struct Decoder<'a> {
    data: &'a [u8],
    pos: usize,
    range: u32,
    code: u32,
}

impl<'a> Decoder<'a> {
    /// A decoder over `data`: its first byte (which must be zero, see [`Self::first_byte_ok`])
    /// and the next four start the code value.
    pub fn new(data: &'a [u8]) -> Self {
        let mut d = Self { data, pos: 1, range: u32::MAX, code: 0 };
        for _ in 0..4 {
            d.code = d.code << 8 | u32::from(d.next());
        }
        d
    }

    /// Whether the block's first byte is zero (spec §6.9).
    pub fn first_byte_ok(&self) -> bool {
        self.data.first() == Some(&0)
    }

    /// Bytes read so far, those past the end of the input included (read as zero).
    pub fn consumed(&self) -> usize {
        self.pos
    }

    #[inline]
    fn next(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }

    #[inline]
    fn normalize(&mut self) {
        while self.range < TOP {
            self.range <<= 8;
            self.code = self.code << 8 | u32::from(self.next());
        }
    }

    /// Decodes one bit with the adaptive probability `p`, and adapts `p`.
    #[inline]
    pub fn bit(&mut self, p: &mut u16) -> bool {
        let bound = (self.range >> PROB_BITS) * u32::from(*p);
        let bit = if self.code < bound {
            self.range = bound;
            *p += ((1 << PROB_BITS) - *p) >> MOVE_BITS;
            false
        } else {
            self.code -= bound;
            self.range -= bound;
            *p -= *p >> MOVE_BITS;
            true
        };
        self.normalize();
        bit
    }

    /// Decodes `count` (at most 32) direct bits, most significant first.
    #[inline]
    pub fn direct(&mut self, count: u32) -> u32 {
        let mut v = 0u32;
        for _ in 0..count {
            self.range >>= 1;
            let bit = u32::from(self.code >= self.range);
            self.code -= self.range & 0u32.wrapping_sub(bit);
            v = v << 1 | bit;
            self.normalize();
        }
        v
    }
}
