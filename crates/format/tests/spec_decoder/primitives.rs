//! Spec §1 (conventions) and §7.3 (error classes): varints, zigzag, plane blocks, gap lists, the
//! arithmetic helpers, and the reader of one stream.

use std::fmt;

/// The error classes of spec §7.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    NotMrq,
    UnsupportedVersion,
    Truncated,
    Checksum,
    Limit,
    Invalid,
}

impl Class {
    /// The class's name in spec §7.3 (and in `fixtures/format/invalid/README.md`).
    pub fn name(self) -> &'static str {
        match self {
            Class::NotMrq => "not-mrq",
            Class::UnsupportedVersion => "unsupported-version",
            Class::Truncated => "truncated",
            Class::Checksum => "checksum",
            Class::Limit => "limit",
            Class::Invalid => "invalid",
        }
    }
}

/// A rejected file: the class of spec §7.3 and what was wrong.
#[derive(Debug)]
pub struct SpecError {
    pub class: Class,
    pub what: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.class.name(), self.what)
    }
}

pub type Result<T> = std::result::Result<T, SpecError>;

/// An error of class `class`.
pub fn fail<T>(class: Class, what: impl Into<String>) -> Result<T> {
    Err(SpecError { class, what: what.into() })
}

/// An `invalid` error (spec §7.3: any other violation).
pub fn invalid<T>(what: impl Into<String>) -> Result<T> {
    fail(Class::Invalid, what)
}

/// Fails with `invalid` unless `ok`.
pub fn require(ok: bool, what: impl FnOnce() -> String) -> Result<()> {
    if ok { Ok(()) } else { invalid(what()) }
}

/// One stream of a level block (spec §4.2), or any byte range read front to back. Reading past
/// its end is `invalid` (spec §4.1: stream sizes are declared).
pub struct Stream<'a> {
    pub name: &'static str,
    data: &'a [u8],
    pos: usize,
}

impl<'a> Stream<'a> {
    pub fn new(name: &'static str, data: &'a [u8]) -> Self {
        Self { name, data, pos: 0 }
    }

    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    pub fn u8(&mut self) -> Result<u8> {
        let Some(&b) = self.data.get(self.pos) else {
            return invalid(format!("{}: read past its end", self.name));
        };
        self.pos += 1;
        Ok(b)
    }

    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8]> {
        if self.remaining() < n {
            return invalid(format!("{}: {n} bytes needed, {} left", self.name, self.remaining()));
        }
        let out = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    /// §1.3: an unsigned LEB128 varint of at most 10 bytes, below 2^64.
    pub fn varint(&mut self) -> Result<u64> {
        let mut value = 0u64;
        for i in 0..10 {
            let b = self.u8()?;
            if i == 9 && b > 1 {
                return invalid(format!("{}: varint beyond 2^64", self.name));
            }
            value |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                return Ok(value);
            }
        }
        invalid(format!("{}: varint longer than 10 bytes", self.name))
    }

    /// A varint that must be at most `max`.
    pub fn varint_at_most(&mut self, max: u64, what: &str) -> Result<u64> {
        let v = self.varint()?;
        require(v <= max, || format!("{}: {what} {v} exceeds {max}", self.name))?;
        Ok(v)
    }

    /// A varint read as `unzigzag` (§1.4).
    pub fn signed(&mut self) -> Result<i64> {
        Ok(unzigzag(self.varint()?))
    }

    /// §1.5: a plane block of `n` values with at most `max_planes` planes.
    pub fn plane_block(&mut self, n: usize, max_planes: u8) -> Result<Vec<u64>> {
        let planes = self.u8()?;
        require(planes <= max_planes, || format!("{}: plane_count {planes} exceeds {max_planes}", self.name))?;
        let mut values = vec![0u64; n];
        for p in 0..u32::from(planes) {
            let plane = self.bytes(n)?;
            for (v, &b) in values.iter_mut().zip(plane) {
                *v |= u64::from(b) << (8 * p);
            }
        }
        Ok(values)
    }

    /// Spec §4.1: every stream the mode uses is read to its last byte.
    pub fn finish(&self) -> Result<()> {
        require(self.remaining() == 0, || format!("{}: {} bytes left over", self.name, self.remaining()))
    }
}

/// §1.4.
pub fn unzigzag(z: u64) -> i64 {
    ((z >> 1) as i64) ^ -((z & 1) as i64)
}

/// §1.6: the next element of a gap list, given the previous element (`None` for the first); `None`
/// when the exact value does not fit in 64 bits.
pub fn gap_next(previous: Option<u64>, value: u64) -> Option<u64> {
    match previous {
        None => Some(value),
        Some(p) => p.checked_add(1)?.checked_add(value),
    }
}

/// §1.7: `floor_div(2a + b, 2b)`, `b > 0`, in 128 bits.
pub fn round_div(a: i128, b: i128) -> i64 {
    assert!(b > 0);
    let q = (2 * a + b).div_euclid(2 * b);
    i64::try_from(q).expect("round_div of values in range")
}

/// §1.7: `3 * sum`, saturated to the `i64` range.
pub fn three_times_saturated(sum: i128) -> i128 {
    (3 * sum).clamp(i128::from(i64::MIN), i128::from(i64::MAX))
}

/// §1.7: nearest integer, halves away from zero, saturated to `i64`.
pub fn round_away(x: f64) -> i64 {
    let r = x.round(); // Rust's `round` rounds halves away from zero
    if r >= 9_223_372_036_854_775_807.0 {
        i64::MAX
    } else if r <= -9_223_372_036_854_775_808.0 {
        i64::MIN
    } else {
        r as i64
    }
}

/// §1.7: the grid range `[-2^28, 2^28]`.
pub const GRID: i64 = 1 << 28;

/// §1.7: `clamp` of a point to the grid range.
pub fn clamp3(p: [i64; 3]) -> [i64; 3] {
    p.map(|x| x.clamp(-GRID, GRID))
}

/// §1.7: the bit length of `x > 0`.
pub fn bit_len(x: u64) -> u32 {
    64 - x.leading_zeros()
}

/// §1.7: `to_f64` (nearest, ties to even: Rust's `as` conversion).
pub fn to_f64(x: i128) -> f64 {
    x as f64
}

pub fn sub3(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The cross product, exact in 128 bits.
pub fn cross128(a: [i128; 3], b: [i128; 3]) -> [i128; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub fn wide(a: [i64; 3]) -> [i128; 3] {
    a.map(i128::from)
}
