//! Mode 0, the base level (spec §5.1 Base mode): face sizes and explicit corner indices, every
//! face created, faces and vertices in the encoder's order.

use crate::block::s;
use crate::bytes::{Reader, unzigzag};
use crate::error::DecodeError;
use crate::level_decode::PlainLevel;
use crate::topology::NO_PARENT;

/// Decodes the faces and corners of a mode 0 level into `out` (whose `offsets` hold `[0]` and
/// `indices` `corner_count` zeros).
pub fn decode(st: &mut [Reader<'_>], [nv, nf, nc]: [usize; 3], out: &mut PlainLevel) -> Result<(), DecodeError> {
    out.parents = vec![NO_PARENT; nf];
    out.quadrants = vec![0; nf];
    let mut sum = 0u64;
    for _ in 0..nf {
        let n = st[s::FACE_SIZES].varint_max(u64::from(u32::MAX) - 3, "face size")? + 3;
        sum += n;
        if sum > nc as u64 {
            return Err(st[s::FACE_SIZES].invalid("face sizes add up to more than corner_count"));
        }
        out.offsets.push(sum as u32);
    }
    if sum != nc as u64 {
        return Err(st[s::FACE_SIZES].invalid(format!("face sizes add up to {sum}, corner_count is {nc}")));
    }
    let mut prev = 0i64;
    for c in 0..nc {
        prev = prev.wrapping_add(unzigzag(st[s::CORNERS].varint()?));
        if prev < 0 || prev >= nv as i64 {
            return Err(st[s::CORNERS].invalid(format!("vertex index {prev} out of range 0..{nv}")));
        }
        out.indices[c] = prev as u32;
    }
    Ok(())
}
