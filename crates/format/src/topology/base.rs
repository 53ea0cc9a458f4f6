//! Mode 0, the base level (spec §5.1 Mode 0: base level): face sizes and explicit corner indices, every
//! face created, faces and vertices in the encoder's order.

use crate::block::{Mode, s};
use crate::bytes::{Reader, put_varint, unzigzag, zigzag};
use crate::error::DecodeError;
use crate::geometry::residuals::geometry;
use crate::level_decode::PlainLevel;
use crate::level_encode::{Encoded, InputLevel, Streams, finish};
use crate::topology::slots;
use crate::topology::{NO_PARENT, NO_POS};

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

/// Encodes a mode 0 level: faces and vertices in the input's order, face sizes and corner
/// indices as given, the raw lattice when the level has one, then its geometry.
pub fn encode(k: u32, input: &InputLevel<'_>, has_lattice: bool, (bits, exact): (u32, bool)) -> Encoded {
    let nf = input.parents.len();
    let nv = input.q.len().max(input.exact.len());
    let mut st = Streams::new();
    // Base mode: order kept as given.
    let mut level = PlainLevel {
        offsets: input.offsets.to_vec(),
        indices: input.indices.to_vec(),
        parents: vec![NO_PARENT; nf],
        quadrants: vec![0; nf],
        ..PlainLevel::default()
    };
    for w in input.offsets.windows(2) {
        put_varint(&mut st.0[s::FACE_SIZES], u64::from(w[1] - w[0] - 3));
    }
    let mut prev = 0i64;
    for &i in input.indices {
        put_varint(&mut st.0[s::CORNERS], zigzag(i64::from(i) - prev));
        prev = i64::from(i);
    }
    if has_lattice {
        level.slots = input.slots.map(<[_]>::to_vec);
        level.corners = input.corners.map(<[_]>::to_vec);
        slots::encode_raw_lattice(&mut st, &level, k);
    }
    level.q.clone_from(&input.q);
    level.exact.clone_from(&input.exact);
    let pos = vec![NO_POS; input.indices.len()];
    st.0[s::GEOMETRY] = geometry(&level, Mode::Base, k, bits, exact, None, &pos, &[], (0, 0)).0;
    let mut e = finish(st, (Mode::Base, 0, 0), has_lattice, level, (0..nf as u32).collect(), (0..nv as u32).collect());
    e.pos = pos;
    e
}
