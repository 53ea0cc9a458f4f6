//! The level decoder: one level block through spec §4 (block header, streams), §5 (the topology
//! of its mode, in `crate::topology`) and §6 (its geometry, in `crate::geometry`), in the spec's
//! order. Works on plain arrays; every count is checked against the streams and the level-table
//! entry (itself checked against [`crate::Limits`]) before allocating.

use crate::block::{BlockHeader, GridInfo, LINE_PARAM_LIMIT, Mode, STREAM_COUNT, s};
use crate::bytes::{Reader, unzigzag};
use crate::container::LevelEntry;
use crate::error::{DecodeError, Where};
use crate::geometry::fixed as fast;
use crate::geometry::predict::{GRID_LIMIT, GeometryScratch, Topo, geometry_pass};
use crate::geometry::residuals::{GridStreams, exact_positions, grid_streams, grid_values};
use crate::topology::lattice::LatticeFaces;
use crate::topology::names::NameScratch;
use crate::topology::{NO_POS, Parent, slots};
use crate::topology::{base, first_use, generic, lattice, names};

/// One decoded level on plain arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlainLevel {
    /// Face offsets (CSR, `face_count + 1` entries).
    pub offsets: Vec<u32>,
    /// Face corners.
    pub indices: Vec<u32>,
    /// Per face: parent face in the level above, or `u32::MAX` for a created face.
    pub parents: Vec<u32>,
    /// Per face: the parent quadrant (0 for created faces).
    pub quadrants: Vec<u8>,
    /// Per face: lattice slot, when the level carries lattice coordinates.
    pub slots: Option<Vec<([u32; 3], u8)>>,
    /// Per vertex: lattice corner, when the level carries lattice coordinates.
    pub corners: Option<Vec<[u32; 3]>>,
    /// Grid coordinates of the vertices (quantized files).
    pub q: Vec<[i64; 3]>,
    /// Positions of the vertices (exact files).
    pub exact: Vec<[f64; 3]>,
    /// Mode 3 levels: per face its rotation byte when none of its corners is an exception (then
    /// it is the face's orientation as a parent, spec §5.3), else `u8::MAX`; empty otherwise.
    pub rotation_hints: Vec<u8>,
    /// The level's canonical quads as a parent ([`Parent::canonical_quads`]), computed once when
    /// first asked for (a chunk's children decode against the same parent chunk).
    pub quad_cache: QuadCache,
}

/// A level's canonical quads, computed on first use. Cloning or comparing ignores it (it is
/// derived from the level); a level changed after use as a parent takes a new one.
#[derive(Default)]
pub struct QuadCache(std::sync::OnceLock<CanonicalQuads>);

/// Per parent face its canonical quad and orientation, or the first face that is not a quad.
pub type CanonicalQuads = Result<Vec<crate::topology::Quad>, usize>;

impl QuadCache {
    /// The cached value, computed by `f` on first use.
    pub fn get(&self, f: impl FnOnce() -> CanonicalQuads) -> &CanonicalQuads {
        self.0.get_or_init(f)
    }
}

impl Clone for QuadCache {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl PartialEq for QuadCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for QuadCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.get().is_some() { "QuadCache(computed)" } else { "QuadCache(empty)" })
    }
}

impl PlainLevel {
    /// The level as a parent of the next.
    pub fn as_parent(&self) -> Parent<'_> {
        Parent {
            offsets: &self.offsets,
            indices: &self.indices,
            q: &self.q,
            slots: self.slots.as_deref(),
            corners: self.corners.as_deref(),
            rotation_hints: &self.rotation_hints,
            quad_cache: Some(&self.quad_cache),
        }
    }
}

/// Buffers reused from level to level (and file to file) by [`decode_level`].
#[derive(Default)]
pub struct Scratch {
    /// The geometry pass's buffers.
    geometry: GeometryScratch,
    /// Per corner: its predicted name, or `u64::MAX`.
    pred: Vec<u64>,
    /// Per corner: its canonical position, or [`NO_POS`].
    pos: Vec<u8>,
    /// The name set's buffers (modes 1 and 2).
    names: NameScratch,
    /// Mode 3's key table.
    fast_resolve: first_use::ResolveScratch,
    /// Mode 3's geometry buffers.
    fast_geometry: FastGeometryScratch,
}

/// Buffers of [`finish_fast`].
#[derive(Default)]
pub struct FastGeometryScratch {
    pub(crate) contexts: fast::Contexts,
    dirs: Vec<fast::FaceLine>,
    /// Line parameters and x, y, z residuals, zigzagged.
    values: [Vec<u32>; 4],
}

impl Scratch {
    /// Bytes held by the buffers.
    pub fn capacity_bytes(&self) -> usize {
        self.geometry.capacity_bytes()
            + self.pred.capacity() * 8
            + self.pos.capacity()
            + self.names.capacity_bytes()
            + self.fast_resolve.capacity_bytes()
            + self.fast_geometry.contexts.capacity_bytes()
            + self.fast_geometry.dirs.capacity() * size_of::<fast::FaceLine>()
            + self.fast_geometry.values.iter().map(|v| v.capacity() * 4).sum::<usize>()
    }
}

/// Decodes level `k`'s decompressed payload (spec §4-§6, in the spec's order): the block header
/// and streams (§4), the topology of the level's mode (§5), its geometry (§6).
pub fn decode_level(
    k: u32,
    payload: &[u8],
    entry: &LevelEntry,
    parent: Option<&PlainLevel>,
    grid: GridInfo,
    scratch: &mut Scratch,
) -> Result<PlainLevel, DecodeError> {
    let header = BlockHeader::parse(k, payload, entry, grid)?;
    let mut st = header.streams(k, payload)?;
    let [nv, nf, nc] = header.counts;
    let mut out = PlainLevel { offsets: Vec::with_capacity(nf + 1), ..PlainLevel::default() };
    out.offsets.push(0);
    out.indices = vec![0u32; nc];
    match parent {
        Some(p) if header.mode != Mode::Base => decode_refinement(k, &header, grid, &mut st, out, p, scratch),
        _ => {
            base::decode(&mut st, header.counts, &mut out)?;
            let pos = &mut scratch.pos;
            pos.clear();
            pos.resize(nc, NO_POS);
            let variant = (header.mode, header.predictor, header.lines, header.line_shift);
            finish(k, variant, header.has_lattice, grid, &mut st, out, None, pos, &[], nv, &mut scratch.geometry)
        }
    }
}

/// The topology of a refinement level (modes 1-3, §5.2-§5.9), then its geometry.
fn decode_refinement(
    k: u32,
    header: &BlockHeader,
    grid: GridInfo,
    st: &mut [Reader<'_>; STREAM_COUNT],
    mut out: PlainLevel,
    p: &PlainLevel,
    scratch: &mut Scratch,
) -> Result<PlainLevel, DecodeError> {
    let BlockHeader { mode, has_lattice, predictor, lines, line_shift, counts: [nv, nf, nc], .. } = *header;
    let Scratch { geometry, pred, pos, names, fast_resolve, fast_geometry } = scratch;
    pred.clear();
    pred.resize(nc, u64::MAX);
    pos.clear();
    pos.resize(nc, NO_POS);
    // §5.3 / §5.4: subfaces, then created faces; predicted names per corner.
    let faces = if mode.is_lattice() {
        lattice::decode_faces(k, mode, st, &p.as_parent(), [nf, nc], (&mut out, pred, pos))?
    } else {
        generic::decode_faces(st, p, [nf, nc], (&mut out, pred, pos))?;
        LatticeFaces { slots: Vec::new(), parent_quads: std::borrow::Cow::Borrowed(&[]), name_bounds: None }
    };
    let LatticeFaces { slots, parent_quads, name_bounds } = faces;
    if mode == Mode::FastLattice {
        // §5.9: first-use numbering through a table of keys.
        let [_, _, _, _, _, _, extras, splits, exceptions, choices, _, _] = &mut st[..] else {
            unreachable!("twelve streams")
        };
        let streams = first_use::ResolveStreams { splits, exceptions, choices, extras };
        let faces = (&out.parents[..], &out.quadrants[..], &parent_quads[..]);
        let level = (&mut out.indices[..], &mut out.rotation_hints[..]);
        let corners =
            first_use::resolve(k, nv, (pred, pos), level, streams, faces, (fast_resolve, &mut fast_geometry.contexts))?;
        out.corners = Some(corners);
        out.slots = Some(slots);
        out.parents.shrink_to_fit();
        let variant = (predictor, lines, line_shift);
        return finish_fast(k, variant, grid, st, out, p, &parent_quads, fast_geometry);
    }
    // §5.5 and §5.6: names, splits, corners.
    let set = names::decode_names((k, mode, nv), st, pred, name_bounds, names)?;
    names::decode_corners([nv, nc], st, (pred, name_bounds), &set, (&mut out.indices, pos))?;
    if mode == Mode::Lattice {
        out.corners = Some(lattice::vertex_corners(k, nv, &set));
        out.slots = Some(slots);
    }
    out.parents.shrink_to_fit();
    let variant = (mode, predictor, lines, line_shift);
    finish(k, variant, has_lattice, grid, st, out, Some(p), pos, &parent_quads, nv, geometry)
}

#[allow(clippy::too_many_arguments)] // the level as the topology leaves it: §5.8, then §6
fn finish(
    k: u32,
    (mode, predictor, lines, line_shift): (Mode, u8, bool, u32),
    has_lattice: bool,
    grid: GridInfo,
    st: &mut [Reader<'_>],
    mut out: PlainLevel,
    parent: Option<&PlainLevel>,
    pos: &[u8],
    parent_quads: &[([u32; 4], u8)],
    nv: usize,
    geometry: &mut GeometryScratch,
) -> Result<PlainLevel, DecodeError> {
    if mode != Mode::Lattice && has_lattice {
        let (slots, corners) = slots::decode_raw_lattice(&mut st[s::RAW_LATTICE], k, out.parents.len(), nv)?;
        out.slots = Some(slots);
        out.corners = Some(corners);
    }
    let g = &mut st[s::GEOMETRY];
    if grid.exact {
        out.exact = exact_positions(g, nv)?;
    } else {
        let topo = Topo {
            mode,
            level: k,
            bits: grid.bits,
            offsets: &out.offsets,
            indices: &out.indices,
            parents: &out.parents,
            quadrants: &out.quadrants,
            corner_pos: pos,
            vertex_corners: out.corners.as_deref(),
            parent_quads: (mode == Mode::Lattice).then_some(parent_quads),
            predictor,
            lines,
            line_shift,
        };
        let q = grid_positions(&topo, g, nv, parent, geometry)?;
        out.q = q;
    }
    for r in st.iter() {
        r.finish()?;
    }
    Ok(out)
}

/// The grid positions of a mode 0-2 level (§6.1-§6.6): with lines, a bitmap of line vertices,
/// their parameters, and the other vertices' residuals, each list in coding order (pass A, then
/// pass B); each vertex its prediction plus its residual, or the point of its line parameter.
fn grid_positions(
    topo: &Topo<'_>,
    g: &mut Reader<'_>,
    nv: usize,
    parent: Option<&PlainLevel>,
    geometry: &mut GeometryScratch,
) -> Result<Vec<[i64; 3]>, DecodeError> {
    let (k, lines) = (topo.level, topo.lines);
    let GridStreams { flags, params, planes } = grid_streams(g, nv, lines)?;
    let mut q = vec![[0i64; 3]; nv];
    let pp = parent.map(PlainLevel::as_parent);
    let geo_off = g.offset();
    let invalid =
        |reason: String| DecodeError::Invalid { place: Where::Payload(k), offset: geo_off, what: "geometry", reason };
    let (mut next_line, mut next_other) = (0usize, 0usize);
    geometry_pass(
        topo,
        pp.as_ref(),
        &mut q,
        geometry,
        #[inline(always)]
        |v, pr| {
            if lines && flags[v / 8] >> (v % 8) & 1 == 1 {
                let Some(line) = pr.line else {
                    return Err(invalid(format!("vertex {v} is flagged as a line vertex but has no line")));
                };
                let j = pr.param + unzigzag(params.as_ref().expect("lines").get(next_line));
                next_line += 1;
                if j.abs() > LINE_PARAM_LIMIT {
                    return Err(invalid(format!("vertex {v} has line parameter {j}, beyond 2^30")));
                }
                let out = line.point(j);
                if out.iter().any(|x| x.abs() > GRID_LIMIT) {
                    return Err(invalid(format!("vertex {v} decodes outside the grid range (|q| > 2^28)")));
                }
                return Ok((out, Some(j)));
            }
            let i = if lines { next_other } else { v };
            next_other += 1;
            let mut out = [0i64; 3];
            let point = pr.point();
            for a in 0..3 {
                out[a] = point[a] + unzigzag(planes[a].get(i));
                if out[a].abs() > GRID_LIMIT {
                    return Err(invalid(format!("vertex {v} decodes outside the grid range (|q| > 2^28)")));
                }
            }
            Ok((out, None))
        },
    )?;
    Ok(q)
}

/// Geometry of a mode 3 level (spec §6.8) and the end-of-block checks.
#[allow(clippy::too_many_arguments)]
fn finish_fast(
    k: u32,
    (predictor, lines, line_shift): (u8, bool, u32),
    grid: GridInfo,
    st: &mut [Reader<'_>],
    mut out: PlainLevel,
    parent: &PlainLevel,
    parent_quads: &[([u32; 4], u8)],
    scratch: &mut FastGeometryScratch,
) -> Result<PlainLevel, DecodeError> {
    let nv = out.corners.as_ref().map_or(0, Vec::len);
    let g = &mut st[s::GEOMETRY];
    if grid.exact {
        out.exact = exact_positions(g, nv)?;
    } else {
        let FastGeometryScratch { contexts, dirs, values } = scratch;
        // (`contexts` were found by `fast::resolve`.)
        // The stream's values, decoded once (in bulk, not per vertex): value blocks (§6.9) from
        // version 4, byte planes before.
        let flags = if grid.version >= 4 {
            grid_values(g, nv, lines, values)?
        } else {
            let GridStreams { flags, params, planes } = grid_streams(g, nv, lines)?;
            let [jv, rx, ry, rz] = &mut *values;
            match &params {
                Some(p) => p.decode_into(jv),
                None => jv.clear(),
            }
            planes[0].decode_into(rx);
            planes[1].decode_into(ry);
            planes[2].decode_into(rz);
            flags
        };
        let [jv, rx, ry, rz] = values;
        let topo = fast::FastTopo {
            level: k,
            bits: grid.bits,
            indices: &out.indices,
            slots: out.slots.as_deref().unwrap_or_default(),
            vertex_corners: out.corners.as_deref().unwrap_or_default(),
            contexts,
            parent_quads,
            lines,
            line_shift,
            predictor,
        };
        let mut q = vec![[0i64; 3]; nv];
        let decoded = fast::decode_pass(&topo, &parent.q, &mut q, dirs, flags, jv, [rx, ry, rz]);
        if let Err(v) = decoded {
            return Err(g.invalid(format!(
                "vertex {v} decodes outside the grid range (|q| > 2^28) or has a line parameter beyond 2^30"
            )));
        }
        out.q = q;
    }
    for r in st.iter() {
        r.finish()?;
    }
    Ok(out)
}
