//! The encoder's file assembly (spec §3 File structure, §8 Encoder requirements): the
//! quantization grid, the levels coded coarse to fine against their decoded parents, and the
//! container around them.

use std::io::Write;

use octowrap_mesh::{Aabb, DVec3, FaceOrigin, Hierarchy, Level};
use xxhash_rust::xxh3::xxh3_64;

use crate::container::{
    self, ENTRY_SIZE, FLAG_CUBE, FLAG_EXACT, FLAG_TIED, FileHeader, HEADER_SIZE, LevelEntry, MAGIC, Preamble,
};
use crate::decoder;
use crate::error::EncodeError;
use crate::level_decode::PlainLevel;
use crate::level_encode::{self, InputLevel};
use crate::topology::NO_PARENT;
use crate::{EncodeOptions, FORMAT_VERSION, LevelStats, MAX_GRID_BITS, Quantization, geometry};

/// The quantization grid of a file (spec §3.1: `EXACT`, `TIED`, `grid_bits`, `origin`, `step`).
pub struct Grid {
    /// Positions stored exactly (no grid).
    pub exact: bool,
    /// The grid is tied to the cube.
    pub tied: bool,
    /// `grid_bits`.
    pub bits: u32,
    /// World position of grid point (0, 0, 0).
    pub origin: DVec3,
    /// Grid step in world units.
    pub step: f64,
}

impl Grid {
    /// Grid coordinates of `p`, rounded to the nearest grid point (not range-checked).
    pub fn quantize(&self, p: DVec3) -> DVec3 {
        ((p - self.origin) / self.step).round()
    }

    /// The grid tied to `cube` (spec §3.1 `TIED`): origin at its smallest corner, `2^bits` steps
    /// across its largest edge; `None` for an empty or flat cube. `bits` in `1..=MAX_GRID_BITS`.
    pub fn tied(cube: Aabb, bits: u32) -> Option<Self> {
        let edge = cube.size().max_element();
        (!cube.is_empty() && edge > 0.0).then(|| Self {
            exact: false,
            tied: true,
            bits,
            origin: cube.min,
            step: edge / f64::from(1u32 << bits),
        })
    }

    /// The world position of grid point `q` (spec §6.7), as the decoder computes it.
    pub fn position(&self, q: [i64; 3]) -> DVec3 {
        self.origin + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * self.step
    }
}

pub fn choose_grid(h: &Hierarchy, q: Quantization) -> Result<Grid, EncodeError> {
    let exact = Grid { exact: true, tied: false, bits: 0, origin: DVec3::ZERO, step: 0.0 };
    let bounds = || {
        let mut b = Aabb::EMPTY;
        for l in &h.levels {
            for p in &l.mesh.vertices.positions {
                b.grow(*p);
            }
        }
        if b.is_empty() { Aabb { min: DVec3::ZERO, max: DVec3::ZERO } } else { b }
    };
    match q {
        Quantization::Exact => Ok(exact),
        Quantization::Bits(bits) => {
            if !(1..=MAX_GRID_BITS).contains(&bits) {
                return Err(EncodeError::Options(format!("quantization bits must be 1..={MAX_GRID_BITS}, got {bits}")));
            }
            if let Some(g) = h.cube.and_then(|c| Grid::tied(c, bits)) {
                Ok(g)
            } else {
                let b = bounds();
                let ext = b.size().max_element();
                let step = if ext > 0.0 { ext / f64::from((1u32 << bits) - 1).max(1.0) } else { 1.0 };
                Ok(Grid { exact: false, tied: false, bits, origin: b.min, step })
            }
        }
        Quantization::Step(step) => {
            if !(step.is_finite() && step > 0.0) {
                return Err(EncodeError::Options(format!("the step must be positive and finite, got {step}")));
            }
            let origin = h.cube.filter(|c| !c.is_empty()).map_or_else(|| bounds().min, |c| c.min);
            Ok(Grid { exact: false, tied: false, bits: 0, origin, step })
        }
    }
}

/// The grid of `h` under `opts`, after the checks every encoding starts with: some levels, at
/// most 32, sound parent links, a version this crate writes.
fn checked_grid(h: &Hierarchy, opts: &EncodeOptions) -> Result<Grid, EncodeError> {
    if h.levels.is_empty() {
        return Err(EncodeError::Empty);
    }
    if h.levels.len() > 32 {
        return Err(EncodeError::Unsupported { level: 32, reason: "more than 32 levels".into() });
    }
    h.check_links()?;
    check_version(opts)?;
    let grid = choose_grid(h, opts.quantization)?;
    Ok(grid)
}

/// Fails unless `opts.version` is a version this crate writes (2 or 3).
fn check_version(opts: &EncodeOptions) -> Result<(), EncodeError> {
    if !(2..=FORMAT_VERSION).contains(&opts.version) {
        return Err(EncodeError::Options(format!(
            "format version {} cannot be written (2..={FORMAT_VERSION})",
            opts.version
        )));
    }
    Ok(())
}

/// Encodes `h` into a byte vector. See [`encode_to`].
pub fn encode(h: &Hierarchy, opts: &EncodeOptions) -> Result<Vec<u8>, EncodeError> {
    Ok(encode_inner(h, opts, false)?.0)
}

/// Encodes `h` and reports per-level sizes (for benchmarks).
pub fn encode_with_stats(h: &Hierarchy, opts: &EncodeOptions) -> Result<(Vec<u8>, Vec<LevelStats>), EncodeError> {
    encode_inner(h, opts, true)
}

/// Encodes `h` to any writer. The hierarchy's links are checked first; positions must be finite.
/// Level `k + 1` is stored in the order of its decoded level (spec §5.4, §5.7, §5.9).
pub fn encode_to(w: &mut impl Write, h: &Hierarchy, opts: &EncodeOptions) -> Result<(), EncodeError> {
    w.write_all(&encode(h, opts)?)?;
    Ok(())
}

pub fn encode_levels(
    h: &Hierarchy,
    opts: &EncodeOptions,
    mut each: impl FnMut(&level_encode::Encoded) -> Result<(), EncodeError>,
) -> Result<Grid, EncodeError> {
    let grid = checked_grid(h, opts)?;
    let mut parent: Option<PlainLevel> = None;
    let mut parent_face_new: Vec<u32> = Vec::new();
    for k in 0..h.levels.len() {
        let input = input_level(h, k, &grid, &parent_face_new)?;
        let enc = level_encode::encode_level(
            k as u32,
            &input,
            parent.as_ref(),
            grid.exact,
            grid.tied,
            grid.bits,
            opts.version,
        )?;
        each(&enc)?;
        parent_face_new = enc.face_new;
        parent = Some(enc.level);
    }
    Ok(grid)
}

/// Level `k` of `h` on plain arrays: positions quantized on `grid`, parents renumbered through
/// `parent_face_new` (the parent level's canonical face order).
pub fn input_level<'a>(
    h: &'a Hierarchy,
    k: usize,
    grid: &Grid,
    parent_face_new: &[u32],
) -> Result<InputLevel<'a>, EncodeError> {
    level_input(&h.levels[k], k, grid, parent_face_new)
}

/// [`input_level`] of a level `l` standing at index `k` of its hierarchy.
pub fn level_input<'a>(
    l: &'a Level,
    k: usize,
    grid: &Grid,
    parent_face_new: &[u32],
) -> Result<InputLevel<'a>, EncodeError> {
    let mesh = &l.mesh;
    mesh.check_indices().map_err(|source| EncodeError::Faces { level: k, source })?;
    if mesh.vertices.len() > u32::MAX as usize / 2 || mesh.faces.corner_count() > u32::MAX as usize / 2 {
        return Err(EncodeError::Unsupported { level: k, reason: "too many vertices or corners".into() });
    }
    let mut q = Vec::new();
    let mut exact = Vec::new();
    for (v, p) in mesh.vertices.positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(EncodeError::NonFinite { level: k, vertex: v });
        }
        if grid.exact {
            exact.push(p.to_array());
        } else {
            let g = grid.quantize(*p);
            if g.abs().max_element() > geometry::predict::GRID_LIMIT as f64 {
                return Err(EncodeError::OutOfGrid { level: k, vertex: v });
            }
            q.push([g.x as i64, g.y as i64, g.z as i64]);
        }
    }
    let (parents, quadrants) = l
        .origins
        .iter()
        .map(|o| match *o {
            FaceOrigin::Subface { parent, quadrant } => (parent_face_new[parent as usize], quadrant.0),
            FaceOrigin::Created => (NO_PARENT, 0),
        })
        .unzip();
    Ok(InputLevel {
        offsets: mesh.faces.offsets(),
        indices: mesh.faces.indices(),
        parents,
        quadrants,
        slots: l.lattice.as_ref().map(|x| &x.face_slots[..]),
        corners: l.lattice.as_ref().map(|x| &x.vertex_corners[..]),
        q,
        exact,
        topology_only: false,
    })
}

/// `with_stats`: also compress each level's topology and geometry apart, for the per-level sizes
/// (two more zstd runs per level; [`encode`] skips them).
fn encode_inner(
    h: &Hierarchy,
    opts: &EncodeOptions,
    with_stats: bool,
) -> Result<(Vec<u8>, Vec<LevelStats>), EncodeError> {
    if opts.version >= container::CHUNKED_VERSION {
        return encode_chunked(h, opts, with_stats);
    }
    let mut blocks = Vec::with_capacity(h.levels.len());
    let mut stats = Vec::with_capacity(h.levels.len());
    let grid = encode_levels(h, opts, |enc| {
        let stored = zstd::bulk::compress(&enc.payload, opts.zstd_level)?;
        let geo_start = enc.payload.len() - enc.split_bytes.1;
        let size = |bytes: &[u8]| -> Result<usize, EncodeError> {
            Ok(if with_stats { zstd::bulk::compress(bytes, opts.zstd_level)?.len() } else { 0 })
        };
        let (topology, geometry) = (size(&enc.payload[..geo_start])?, size(&enc.payload[geo_start..])?);
        stats.push(LevelStats {
            mode: enc.payload[0],
            predictor: enc.predictor,
            line_shift: enc.line_shift,
            stored: stored.len(),
            topology,
            geometry,
        });
        let lv = &enc.level;
        let counts = (lv.q.len().max(lv.exact.len()) as u32, lv.parents.len() as u32, lv.indices.len() as u32);
        blocks.push((enc.payload.len() as u64, stored, counts));
        Ok(())
    })?;
    let header = file_header(h, opts, &grid, blocks.len())?;
    let mut offset = (HEADER_SIZE + ENTRY_SIZE * blocks.len() + header.metadata_size as usize + 8) as u64;
    let mut levels = Vec::with_capacity(blocks.len());
    for (raw, stored, (nv, nf, nc)) in &blocks {
        levels.push(LevelEntry {
            offset,
            stored_size: stored.len() as u64,
            raw_size: *raw,
            checksum: xxh3_64(stored),
            vertex_count: *nv,
            face_count: *nf,
            corner_count: *nc,
            cell_depth: 0,
        });
        offset += stored.len() as u64;
    }
    let pre = Preamble { header, levels, chunks: Vec::new(), metadata: opts.metadata.clone() };
    let mut out = pre.to_bytes();
    for (_, stored, _) in blocks {
        out.extend(stored);
    }
    Ok((out, stats))
}

/// The file header of `h` written with `opts` on `grid` (spec §3.1); `chunk_count` 0.
fn file_header(
    h: &Hierarchy,
    opts: &EncodeOptions,
    grid: &Grid,
    level_count: usize,
) -> Result<FileHeader, EncodeError> {
    let metadata_bytes = container::to_bytes(&opts.metadata);
    let mut flags = 0;
    if h.cube.is_some() {
        flags |= FLAG_CUBE;
    }
    if grid.exact {
        flags |= FLAG_EXACT;
    }
    if grid.tied {
        flags |= FLAG_TIED;
    }
    let (cube_min, cube_max) = h.cube.map_or(([0.0; 3], [0.0; 3]), |c| (c.min.to_array(), c.max.to_array()));
    let header = FileHeader {
        magic: MAGIC,
        version: opts.version,
        header_size: HEADER_SIZE as u16,
        flags,
        level_count: level_count as u32,
        grid_bits: grid.bits,
        origin: grid.origin.to_array(),
        step: grid.step,
        cube_min,
        cube_max,
        metadata_size: u32::try_from(metadata_bytes.len())
            .map_err(|_| EncodeError::Options("metadata larger than 4 GiB".into()))?,
        chunk_count: 0,
    };
    Ok(header)
}

/// The version 5 form of [`crate::canonical`]: the decoded level of each level's chunks (spec
/// §11.4), with the input positions.
pub fn canonical_chunked(h: &Hierarchy, opts: &EncodeOptions) -> Result<Hierarchy, EncodeError> {
    let (grid, plan) = chunk_plan(h, opts)?;
    // Per level: its decoded chunks with their vertices' input indices and parents' face offsets.
    let mut levels: Vec<Vec<(PlainLevel, Vec<u32>, u32)>> = (0..h.levels.len()).map(|_| Vec::new()).collect();
    let mut face_at: Vec<u32> = vec![0; plan.len()];
    let mut next_face = vec![0u32; h.levels.len()];
    crate::chunks::encode_chunks(h, &grid, opts.version, &plan, |ci, enc| {
        let k = plan[ci].level as usize;
        face_at[ci] = next_face[k];
        next_face[k] += enc.level.parents.len() as u32;
        let parent_offset = plan[ci].parent.map_or(0, |p| face_at[p as usize]);
        levels[k].push((enc.level.clone(), enc.vertex_level.clone(), parent_offset));
        Ok(())
    })?;
    let levels = levels.into_iter().enumerate().map(|(k, parts)| merged_input_level(&h.levels[k], parts)).collect();
    Ok(Hierarchy { levels, cube: h.cube })
}

/// A level's decoded chunks merged (spec §11.4), each vertex at its input position `level`'s:
/// vertices are one when they are the same input vertex.
fn merged_input_level(level: &Level, parts: Vec<(PlainLevel, Vec<u32>, u32)>) -> Level {
    let mut seen = std::collections::HashMap::new();
    let mut merged = PlainLevel { offsets: vec![0], ..PlainLevel::default() };
    if parts.iter().all(|(p, ..)| p.corners.is_some()) {
        merged.slots = Some(Vec::new());
        merged.corners = Some(Vec::new());
    }
    let mut positions = Vec::new();
    for (p, vertex_level, parent_offset) in parts {
        let mut remap = Vec::with_capacity(vertex_level.len());
        for (local, &v) in vertex_level.iter().enumerate() {
            let next = positions.len() as u32;
            let index = *seen.entry(v).or_insert(next);
            if index == next {
                positions.push(level.mesh.vertices.positions[v as usize]);
                if let (Some(mc), Some(pc)) = (&mut merged.corners, &p.corners) {
                    mc.push(pc[local]);
                }
            }
            remap.push(index);
        }
        let base = *merged.offsets.last().expect("offsets");
        merged.offsets.extend(p.offsets[1..].iter().map(|&o| base + o));
        merged.indices.extend(p.indices.iter().map(|&v| remap[v as usize]));
        merged.parents.extend(p.parents.iter().map(|&f| if f == NO_PARENT { f } else { f + parent_offset }));
        merged.quadrants.extend(&p.quadrants);
        if let (Some(ms), Some(ps)) = (&mut merged.slots, &p.slots) {
            ms.extend(ps);
        }
    }
    let mut out = decoder::to_level(&merged, DVec3::ZERO, 1.0);
    out.mesh.vertices.positions = positions;
    out
}

/// The grid and chunk plan of a version 5 file of `h` (spec §11): cells of depth
/// `k - opts.chunk_shift`, or one chunk per level when the hierarchy has no lattice, the grid is
/// not tied, or two seam vertices could not be told apart.
fn chunk_plan(h: &Hierarchy, opts: &EncodeOptions) -> Result<(Grid, Vec<crate::chunks::ChunkPlan>), EncodeError> {
    use crate::chunks;
    let grid = checked_grid(h, opts)?;
    // A coarser split where vertices off the cell boundaries are shared by chunks (spec §11.4).
    let levels = h.levels.len() as u32;
    let plan = (opts.chunk_shift..levels)
        .filter(|_| grid.exact || grid.tied)
        .find_map(|shift| chunks::plan(h, shift).filter(|p| chunks::seams_distinct(h, p, &grid)))
        .unwrap_or_else(|| chunks::whole_levels(h));
    Ok((grid, plan))
}

/// A version 5 file (spec §11): every level in chunks, each chunk coded against its parent chunk.
fn encode_chunked(
    h: &Hierarchy,
    opts: &EncodeOptions,
    with_stats: bool,
) -> Result<(Vec<u8>, Vec<LevelStats>), EncodeError> {
    let (grid, plan) = chunk_plan(h, opts)?;
    let mut stored: Vec<Vec<u8>> = Vec::with_capacity(plan.len());
    let mut entries: Vec<container::ChunkEntry> = Vec::with_capacity(plan.len());
    let mut stats = vec![LevelStats::default(); h.levels.len()];
    crate::chunks::encode_chunks(h, &grid, opts.version, &plan, |ci, enc| {
        let c = &plan[ci];
        let frame = zstd::bulk::compress(&enc.payload, opts.zstd_level)?;
        let st = &mut stats[c.level as usize];
        st.mode = enc.payload[0];
        (st.predictor, st.line_shift) = enc.predictor;
        st.stored += frame.len();
        if with_stats {
            let geo = enc.payload.len() - enc.split_bytes.1;
            st.topology += zstd::bulk::compress(&enc.payload[..geo], opts.zstd_level)?.len();
            st.geometry += zstd::bulk::compress(&enc.payload[geo..], opts.zstd_level)?.len();
        }
        let lv = &enc.level;
        let (lo, hi) = chunk_box(lv, &grid);
        let too_big =
            || EncodeError::Unsupported { level: c.level as usize, reason: "a chunk larger than 4 GiB".into() };
        entries.push(container::ChunkEntry {
            offset: 0,
            checksum: xxh3_64(&frame),
            stored_size: u32::try_from(frame.len()).map_err(|_| too_big())?,
            raw_size: u32::try_from(enc.payload.len()).map_err(|_| too_big())?,
            parent: c.parent.unwrap_or(container::NO_CHUNK),
            level: c.level as u16,
            reserved: 0,
            cell: c.cell,
            vertex_count: lv.q.len().max(lv.exact.len()) as u32,
            face_count: lv.parents.len() as u32,
            corner_count: lv.indices.len() as u32,
            bbox_min: lo,
            bbox_max: hi,
            geometric_error: -1.0,
            reserved2: 0,
        });
        stored.push(frame);
        Ok(())
    })?;
    let mut header = file_header(h, opts, &grid, h.levels.len())?;
    header.chunk_count = u32::try_from(entries.len()).map_err(|_| EncodeError::Options("too many chunks".into()))?;
    let preamble_size = (HEADER_SIZE
        + ENTRY_SIZE * h.levels.len()
        + container::CHUNK_ENTRY_SIZE * entries.len()
        + header.metadata_size as usize
        + 8) as u64;
    let mut offset = preamble_size;
    for (e, s) in entries.iter_mut().zip(&stored) {
        e.offset = offset;
        offset += s.len() as u64;
    }
    let mut levels = Vec::with_capacity(h.levels.len());
    for (k, l) in h.levels.iter().enumerate() {
        let ids: Vec<usize> = (0..plan.len()).filter(|&i| plan[i].level as usize == k).collect();
        let mut sum = xxhash_rust::xxh3::Xxh3::new();
        for &i in &ids {
            sum.update(&stored[i]);
        }
        let first = ids.first().map_or(offset, |&i| entries[i].offset);
        levels.push(LevelEntry {
            offset: first,
            stored_size: ids.iter().map(|&i| u64::from(entries[i].stored_size)).sum(),
            raw_size: ids.iter().map(|&i| u64::from(entries[i].raw_size)).sum(),
            checksum: sum.digest(),
            vertex_count: l.mesh.vertices.len() as u32,
            face_count: ids.iter().map(|&i| entries[i].face_count).sum(),
            corner_count: ids.iter().map(|&i| entries[i].corner_count).sum(),
            cell_depth: ids.first().map_or(0, |&i| plan[i].depth),
        });
    }
    let pre = Preamble { header, levels, chunks: entries, metadata: opts.metadata.clone() };
    let mut out = pre.to_bytes();
    debug_assert_eq!(out.len() as u64, preamble_size);
    for s in stored {
        out.extend(s);
    }
    Ok((out, stats))
}

/// The box around a chunk's decoded vertices in world units, rounded outwards to binary32.
fn chunk_box(lv: &PlainLevel, grid: &Grid) -> ([f32; 3], [f32; 3]) {
    let mut b = Aabb::EMPTY;
    if grid.exact {
        for p in &lv.exact {
            b.grow(DVec3::from_array(*p));
        }
    } else {
        for q in &lv.q {
            b.grow(grid.position(*q));
        }
    }
    if b.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    // The neighbouring binary32 value towards minus (plus) infinity, for finite nonzero `f`.
    let step = |f: f32, down: bool| {
        let b = f.to_bits();
        let away = (f > 0.0) != down;
        if f == 0.0 {
            let tiny = f32::from_bits(1);
            if down { -tiny } else { tiny }
        } else if away {
            f32::from_bits(b + 1)
        } else {
            f32::from_bits(b - 1)
        }
    };
    let down = |x: f64| {
        let f = x as f32;
        if f64::from(f) > x { step(f, true) } else { f }
    };
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x { step(f, false) } else { f }
    };
    (b.min.to_array().map(down), b.max.to_array().map(up))
}
