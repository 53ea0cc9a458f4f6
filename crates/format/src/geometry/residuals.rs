//! The geometry stream's layout (spec §6.1 Stream, §6.6 Line geometry): exact positions as byte
//! planes of binary64 bit patterns; grid residuals as three byte-plane blocks, preceded with
//! `LINES` by the bitmap of line vertices and their parameters. Both directions.

use crate::bytes::{Planes, Reader, put_planes};
use crate::error::DecodeError;

/// The exact geometry of a level (spec §6.1): three planes of `f64` bit patterns, every
/// coordinate finite.
pub fn exact_positions(g: &mut Reader<'_>, nv: usize) -> Result<Vec<[f64; 3]>, DecodeError> {
    let planes = [g.planes(nv, 8)?, g.planes(nv, 8)?, g.planes(nv, 8)?];
    let exact: Vec<[f64; 3]> = (0..nv).map(|v| planes.each_ref().map(|p| f64::from_bits(p[v]))).collect();
    if let Some(v) = exact.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(g.invalid(format!("vertex {v} has a non-finite coordinate")));
    }
    Ok(exact)
}

/// The parts of a grid level's geometry stream (spec §6.1, §6.6, §6.8), in stream order.
pub struct GridStreams<'a> {
    /// With `LINES`: one bit per vertex, set for line vertices (empty without).
    pub flags: &'a [u8],
    /// With `LINES`: the line vertices' parameters.
    pub params: Option<Planes<'a>>,
    /// The other vertices' three residuals.
    pub planes: [Planes<'a>; 3],
}

/// Reads the layout of a grid level's geometry stream: with lines, the bitmap of line vertices
/// (unused bits zero) and their parameters, then the residual planes of the others.
pub fn grid_streams<'a>(g: &mut Reader<'a>, nv: usize, lines: bool) -> Result<GridStreams<'a>, DecodeError> {
    let mut flags: &[u8] = &[];
    let mut line_count = 0usize;
    if lines {
        flags = g.bytes(nv.div_ceil(8))?;
        if nv % 8 != 0 && flags[nv / 8] >> (nv % 8) != 0 {
            return Err(g.invalid("unused line flag bits are not zero"));
        }
        line_count = flags.iter().map(|b| b.count_ones() as usize).sum();
    }
    let params = if lines { Some(g.plane_view(line_count, 4)?) } else { None };
    let rest = nv - line_count;
    let planes = [g.plane_view(rest, 4)?, g.plane_view(rest, 4)?, g.plane_view(rest, 4)?];
    Ok(GridStreams { flags, params, planes })
}

/// Writes the layout of a grid level's geometry stream (spec §6.1, §6.6, §6.8): with lines, the
/// bitmap of line vertices and their parameters, then the other vertices' residuals in coding
/// order; without, the residuals of every vertex, put back in vertex order (`order` lists the
/// vertices in coding order).
pub fn put_grid_streams(
    g: &mut Vec<u8>,
    lines: Option<(&[u8], &[u64])>,
    mut res: [Vec<u64>; 3],
    order: &[u32],
    nv: usize,
) {
    if let Some((flags, params)) = lines {
        g.extend(flags);
        put_planes(g, params);
    } else {
        for r in &mut res {
            let mut by_vertex = vec![0u64; nv];
            for (i, &v) in order.iter().enumerate() {
                by_vertex[v as usize] = r[i];
            }
            *r = by_vertex;
        }
    }
    for r in &res {
        put_planes(g, r);
    }
}
