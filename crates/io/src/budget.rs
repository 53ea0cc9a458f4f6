//! The memory ceiling ([`Limits::max_memory`]) as a reader spends it.
//!
//! A reader opens a [`Budget`] over its input (whose bytes are already held and count against the
//! ceiling) and charges it before each allocation: the exact size before an allocation sized
//! from a declared count, and the next capacity before a vector grows by itself (one point more
//! than it holds). The charge is what the reader keeps, so the ceiling bounds the reader's peak
//! heap up to the transient copy a vector makes when it grows.

use octowrap_mesh::FaceList;

use crate::{Error, Limits, Location, Result};

/// What one read may still allocate.
#[derive(Clone, Debug)]
pub(crate) struct Budget {
    /// The ceiling, `None` when unlimited.
    ceiling: Option<u64>,
    /// Bytes charged so far, the input included.
    spent: u64,
}

impl Budget {
    /// A budget under `limits`' ceiling with the `input_len` bytes of the input already held.
    pub(crate) fn new(limits: &Limits, input_len: usize) -> Self {
        Self { ceiling: limits.max_memory, spent: input_len as u64 }
    }

    /// Bytes charged so far, the input included.
    pub(crate) fn spent(&self) -> u64 {
        self.spent
    }

    /// Charges `bytes` for `what` (e.g. "3000000 vertices"), refusing when the total would pass
    /// the ceiling.
    pub(crate) fn charge(&mut self, bytes: u64, what: &dyn Fn() -> String, at: Location) -> Result<()> {
        let total = self.spent.saturating_add(bytes);
        if let Some(ceiling) = self.ceiling.filter(|&c| total > c) {
            return Err(exceeded(ceiling, total, &what(), at));
        }
        self.spent = total;
        Ok(())
    }

    /// Charges `count` elements of `bytes_each`.
    pub(crate) fn charge_n(&mut self, count: usize, bytes_each: usize, what: &str, at: Location) -> Result<()> {
        let bytes = (count as u64).saturating_mul(bytes_each as u64);
        self.charge(bytes, &|| format!("{count} {what}"), at)
    }

    /// Before pushing onto `v` (whose elements come with others in parallel vectors, `bytes_each`
    /// in all): when `v` is full, charges the room for as many elements again (at least 64) and
    /// reserves it.
    #[inline]
    pub(crate) fn grow<T>(&mut self, v: &mut Vec<T>, bytes_each: usize, what: &str, at: Location) -> Result<()> {
        if v.len() < v.capacity() {
            return Ok(());
        }
        let more = v.capacity().max(64);
        let total = v.len() + more;
        self.charge((more as u64).saturating_mul(bytes_each as u64), &|| format!("{total} {what}"), at)?;
        v.reserve_exact(more);
        Ok(())
    }
}

/// Bytes one point takes with the attributes it has: `f64` position, `f32` normal, 8-bit colour,
/// `f32` intensity.
pub(crate) fn point_bytes(normals: bool, colors: bool, intensities: bool) -> usize {
    24 + if normals { 12 } else { 0 } + if colors { 3 } else { 0 } + if intensities { 4 } else { 0 }
}

/// Charges a [`FaceList`]'s memory (4 bytes per corner and per face) as it grows, doubling like
/// a vector, and keeps its corners within 32-bit offsets.
#[derive(Debug, Default)]
pub(crate) struct Corners {
    /// Units of 4 bytes charged so far.
    pub(crate) charged: u64,
}

impl Corners {
    /// Before pushing a face of `corners` corners onto `faces`.
    #[inline]
    pub(crate) fn room(&mut self, budget: &mut Budget, faces: &FaceList, corners: usize, at: Location) -> Result<()> {
        let after = faces.corner_count() as u64 + corners as u64;
        if after > u64::from(u32::MAX) {
            return Err(Error::limit(at, "more than 2^32 face corners in all".to_owned()));
        }
        let units = after + faces.len() as u64 + 1;
        if units > self.charged {
            let add = (units - self.charged).max(self.charged).max(1024);
            budget.charge(add * 4, &|| format!("{} faces with {after} corners", faces.len() + 1), at)?;
            self.charged += add;
        }
        Ok(())
    }
}

/// The error for passing the ceiling: it names the ceiling and how to raise it.
pub(crate) fn exceeded(ceiling: u64, total: u64, what: &str, at: Location) -> Error {
    Error::limit(
        at,
        format!(
            "{what} would take the read to {} in memory, past the memory ceiling of {} \
             (raise it with --max-memory, or Limits::max_memory)",
            bytes(total),
            bytes(ceiling)
        ),
    )
}

/// A byte count for people: `1.5 GiB (1610612736 bytes)`.
pub(crate) fn bytes(n: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if n < 1024 {
        return format!("{n} bytes");
    }
    let mut v = n as f64 / 1024.0;
    let mut unit = UNITS[0];
    for u in &UNITS[1..] {
        if v < 1024.0 {
            break;
        }
        v /= 1024.0;
        unit = u;
    }
    format!("{v:.1} {unit} ({n} bytes)")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;

    #[test]
    fn charges_until_the_ceiling() {
        let limits = Limits { max_memory: Some(1000), ..Limits::default() };
        let mut b = Budget::new(&limits, 400);
        b.charge_n(50, 12, "vertices", Location::Byte(7)).unwrap();
        assert_eq!(b.spent(), 1000);
        let e = b.charge_n(1, 1, "faces", Location::Byte(9)).unwrap_err();
        assert_eq!((e.kind, e.location), (ErrorKind::LimitExceeded, Location::Byte(9)));
        assert!(e.message.contains("memory ceiling of 1000 bytes") && e.message.contains("--max-memory"), "{e}");
        let mut b = Budget::new(&Limits::unlimited(), usize::MAX);
        b.charge_n(usize::MAX, 24, "points", Location::Unknown).unwrap();
    }

    #[test]
    fn growth_is_charged_when_full() {
        let limits = Limits { max_memory: Some(64 * 24 + 10), ..Limits::default() };
        let mut b = Budget::new(&limits, 0);
        let mut v: Vec<[f64; 3]> = Vec::new();
        for _ in 0..64 {
            b.grow(&mut v, 24, "points", Location::Unknown).unwrap();
            v.push([0.0; 3]);
        }
        assert!(b.grow(&mut v, 24, "points", Location::Line(65)).is_err());
        assert_eq!(bytes(1536), "1.5 KiB (1536 bytes)");
    }
}
