//! Mode 1, generic refinement (spec §5.4 Mode 1: generic refinement): the canonical subdivision of the
//! parent (a quad per parent face corner, named by parent vertex, edge and face), children kept by
//! child masks, created faces explicit.

use crate::block::s;
use crate::bytes::Reader;
use crate::error::DecodeError;
use crate::level_decode::PlainLevel;
use crate::topology::number_edges;
use crate::topology::{NO_PARENT, rotated};

/// A rotation byte (§5.2), reserved bits zero.
fn rotation(st: &mut [Reader<'_>]) -> Result<u8, DecodeError> {
    let r = st[s::ROTATIONS].u8()?;
    if r & !7 != 0 {
        return Err(st[s::ROTATIONS].invalid(format!("rotation byte {r:#x} has reserved bits set")));
    }
    Ok(r)
}

/// Decodes the faces of a mode 1 level below parent `p` (§5.4): into `out` their offsets,
/// parents and quadrants; per subface corner its predicted name into `pred` and its canonical
/// position into `pos` (created faces' corners keep `u64::MAX`: explicit).
pub fn decode_faces(
    st: &mut [Reader<'_>],
    p: &PlainLevel,
    [nf, nc]: [usize; 2],
    (out, pred, pos): (&mut PlainLevel, &mut [u64], &mut [u8]),
) -> Result<(), DecodeError> {
    let pp = p.as_parent();
    let mut corner = 0usize;
    let (edge_of_corner, ne) = number_edges(pp.offsets, pp.indices);
    let pv = p.q.len().max(p.exact.len()) as u64;
    let (pv, ne, pnf) = (pv, u64::from(ne), pp.face_count() as u64);
    for pf in 0..pp.face_count() {
        let face = pp.face(pf);
        let n = face.len();
        let mask = st[s::CHILD_MASKS].bytes(n.div_ceil(8))?;
        if n % 8 != 0 && mask[n / 8] >> (n % 8) != 0 {
            return Err(st[s::CHILD_MASKS].invalid("child mask has bits beyond the face's corners"));
        }
        for qd in 0..n {
            let m = mask[qd / 8];
            if m >> (qd % 8) & 1 == 0 {
                continue;
            }
            if out.parents.len() == nf || corner + 4 > nc {
                return Err(st[s::CHILD_MASKS].invalid("more subfaces than face_count or corner_count allow"));
            }
            let qd8 =
                u8::try_from(qd).map_err(|_| st[s::CHILD_MASKS].invalid("quadrants above 255 cannot be stored"))?;
            let r = rotation(st)?;
            let base = pp.offsets[pf] as usize;
            let layout = [
                u64::from(face[qd]),
                pv + u64::from(edge_of_corner[base + qd]),
                pv + ne + pf as u64,
                pv + u64::from(edge_of_corner[base + (qd + n - 1) % n]),
            ];
            for i in 0..4 {
                let cp = rotated(r, i);
                pred[corner] = layout[cp];
                pos[corner] = cp as u8;
                corner += 1;
            }
            out.offsets.push(corner as u32);
            out.parents.push(pf as u32);
            out.quadrants.push(qd8);
        }
    }
    let _ = pnf;
    for _ in out.parents.len()..nf {
        let n = st[s::FACE_SIZES].varint_max(u64::from(u32::MAX) - 3, "face size")? + 3;
        if (corner as u64) + n > nc as u64 {
            return Err(st[s::FACE_SIZES].invalid("face sizes add up to more than corner_count"));
        }
        corner += n as usize;
        out.offsets.push(corner as u32);
        out.parents.push(NO_PARENT);
        out.quadrants.push(0);
    }
    if corner != nc {
        return Err(st[s::FACE_SIZES].invalid(format!("faces hold {corner} corners, corner_count is {nc}")));
    }
    Ok(())
}
