//! Chunks (spec §11): each level's faces split by octree cell, so that a reader can fetch and
//! decode one part of a level from its own bytes and its parent chunk's.
//!
//! Level `k`'s chunks are the cells of depth `max(0, k - CHUNK_SHIFT)` that hold one of its faces
//! (a face lies in the cell holding its slot's voxel, `voxel >> CHUNK_SHIFT`). A subface's voxel
//! is its parent's doubled plus 0 or 1 on each axis (spec §5.3), so all four subfaces of a parent
//! face lie in one cell, and that cell's parent is the parent face's cell: every chunk refines
//! exactly one chunk of the level above (its *parent chunk*).

use octowrap_mesh::{FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, PointCloud};

use crate::encoder::{Grid, level_input};
use crate::error::EncodeError;
use crate::level_decode::PlainLevel;
use crate::level_encode::encode_level;

/// A cell of depth `d` holds `2^CHUNK_SHIFT` voxels of its level along each axis: some
/// `4^CHUNK_SHIFT` faces of a surface crossing it.
pub const CHUNK_SHIFT: u32 = 7;

/// One chunk of a level, as the encoder plans it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChunkPlan {
    /// The level.
    pub level: u32,
    /// The cell's depth, `max(0, level - shift)`.
    pub depth: u32,
    /// The cell at that depth.
    pub cell: [u32; 3],
    /// The parent chunk (its index in the plan), `None` at level 0 or when the level above has no
    /// face in the parent cell.
    pub parent: Option<u32>,
    /// The level's faces in the chunk, in the level's order.
    pub faces: Vec<u32>,
    /// The level's vertices in the chunk: those its faces use, by first use, then the vertices no
    /// face of the level uses whose lattice corner lies in the cell (the last cell on each axis
    /// takes the corners on the cube's far faces).
    pub vertices: Vec<u32>,
}

/// The depth of level `k`'s chunk cells.
pub fn cell_depth(k: u32, shift: u32) -> u32 {
    k.saturating_sub(shift)
}

/// Interleaves the bits of a cell (x lowest): the chunks' order within a level.
pub fn cell_morton(c: [u32; 3]) -> u64 {
    let mut m = 0u64;
    for b in 0..21 {
        for (a, &x) in c.iter().enumerate() {
            m |= u64::from((x >> b) & 1) << (3 * b + a as u32);
        }
    }
    m
}

/// Plans the chunks of `h`, level by level (each level's chunks by the Morton order of their
/// cells). `None` when a level has no lattice coordinates, or a subface does not lie in its
/// parent's cell's child (the hierarchy is then stored unchunked).
pub fn plan(h: &Hierarchy, shift: u32) -> Option<Vec<ChunkPlan>> {
    let mut out: Vec<ChunkPlan> = Vec::new();
    // Per face of the level above: its chunk (index into `out`).
    let mut parent_chunk_of: Vec<u32> = Vec::new();
    for (k, level) in h.levels.iter().enumerate() {
        let k = k as u32;
        let lattice = level.lattice.as_ref()?;
        let depth = cell_depth(k, shift);
        let sh = k - depth;
        let cell_of = |v: [u32; 3]| [v[0] >> sh, v[1] >> sh, v[2] >> sh];
        let mut by_cell: Vec<(u64, u32)> =
            lattice.face_slots.iter().enumerate().map(|(f, &(v, _))| (cell_morton(cell_of(v)), f as u32)).collect();
        by_cell.sort_unstable();
        let first = out.len() as u32;
        let mut chunk_of = vec![0u32; level.origins.len()];
        let mut i = 0;
        while i < by_cell.len() {
            let key = by_cell[i].0;
            let mut j = i;
            while j < by_cell.len() && by_cell[j].0 == key {
                j += 1;
            }
            let faces: Vec<u32> = by_cell[i..j].iter().map(|&(_, f)| f).collect();
            let cell = cell_of(lattice.face_slots[faces[0] as usize].0);
            let index = out.len() as u32;
            let mut parent = None;
            for &f in &faces {
                chunk_of[f as usize] = index;
                if let FaceOrigin::Subface { parent: p, .. } = level.origins[f as usize] {
                    let pc = *parent_chunk_of.get(p as usize)?;
                    let pcell = &out[pc as usize];
                    let expect = if depth == 0 { [0, 0, 0] } else { [cell[0] >> 1, cell[1] >> 1, cell[2] >> 1] };
                    if pcell.cell != expect || parent.is_some_and(|q| q != pc) {
                        return None;
                    }
                    parent = Some(pc);
                }
            }
            if parent.is_none() && k > 0 {
                // Only created faces: the parent chunk is the one of the parent cell, if any.
                let expect = if depth == 0 { [0, 0, 0] } else { [cell[0] >> 1, cell[1] >> 1, cell[2] >> 1] };
                parent =
                    out[..first as usize].iter().rposition(|c| c.level + 1 == k && c.cell == expect).map(|i| i as u32);
            }
            out.push(ChunkPlan { level: k, depth, cell, parent, faces, vertices: Vec::new() });
            i = j;
        }
        // Vertices: first use by the chunk's faces, then unused ones by their corner's cell.
        let nv = level.mesh.vertices.len();
        let mut used = vec![false; nv];
        for c in &mut out[first as usize..] {
            let mut seen = std::collections::HashSet::new();
            for &f in &c.faces {
                for &v in level.mesh.faces.face(f as usize) {
                    used[v as usize] = true;
                    if seen.insert(v) {
                        c.vertices.push(v);
                    }
                }
            }
        }
        let last_cell = (1u32 << depth) - 1;
        for v in (0..nv).filter(|&v| !used[v]) {
            let corner = lattice.vertex_corners[v];
            let cell = cell_of(corner).map(|x| x.min(last_cell));
            let target = if let Some(t) = out[first as usize..].iter().position(|c| c.cell == cell) {
                t
            } else {
                out.push(ChunkPlan { level: k, depth, cell, parent: None, faces: Vec::new(), vertices: Vec::new() });
                out.len() - 1 - first as usize
            };
            out[first as usize + target].vertices.push(v as u32);
        }
        out[first as usize..].sort_by_key(|c| cell_morton(c.cell));
        for (i, c) in out[first as usize..].iter().enumerate() {
            for &f in &c.faces {
                chunk_of[f as usize] = first + i as u32;
            }
        }
        parent_chunk_of = chunk_of;
    }
    Some(out)
}

/// One chunk per level, every face and vertex of the level in its order: the plan of a hierarchy
/// without lattice coordinates, or whose seams cannot be told apart (see [`seams_distinct`]).
pub fn whole_levels(h: &Hierarchy) -> Vec<ChunkPlan> {
    h.levels
        .iter()
        .enumerate()
        .map(|(k, l)| ChunkPlan {
            level: k as u32,
            depth: 0,
            cell: [0; 3],
            parent: k.checked_sub(1).map(|p| p as u32),
            faces: (0..l.origins.len() as u32).collect(),
            vertices: (0..l.mesh.vertices.len() as u32).collect(),
        })
        .collect()
}

/// Whether every vertex of a chunked level that may lie on a seam (its lattice corner on a cell
/// boundary) differs from every other such vertex in lattice corner or grid point, so that the
/// decoder's merge (spec §11.4) finds exactly the level's vertices.
pub fn seams_distinct(h: &Hierarchy, plan: &[ChunkPlan], grid: &Grid) -> bool {
    for (k, level) in h.levels.iter().enumerate() {
        let Some(depth) = plan.iter().find(|c| c.level as usize == k).map(|c| c.depth) else { continue };
        if depth == 0 {
            continue;
        }
        let Some(lattice) = &level.lattice else { return false };
        let mask = (1u32 << (k as u32 - depth)) - 1;
        // A vertex in two chunks must lie on a cell boundary, or the merge would not find it.
        let mut chunks_of = vec![0u8; level.mesh.vertices.len()];
        for c in plan.iter().filter(|c| c.level as usize == k) {
            for &v in &c.vertices {
                chunks_of[v as usize] = chunks_of[v as usize].saturating_add(1);
            }
        }
        let off = chunks_of
            .iter()
            .zip(&lattice.vertex_corners)
            .filter(|&(&n, c)| n > 1 && c.iter().all(|&x| x & mask != 0))
            .count();
        if off > 0 {
            return false;
        }
        let mut seen = std::collections::HashSet::new();
        for (v, c) in lattice.vertex_corners.iter().enumerate() {
            if c.iter().any(|&x| x & mask == 0) {
                let p = level.mesh.vertices.positions[v];
                let key = if grid.exact {
                    p.to_array().map(f64::to_bits)
                } else {
                    grid.quantize(p).to_array().map(f64::to_bits)
                };
                if !seen.insert((*c, key)) {
                    return false;
                }
            }
        }
    }
    true
}

/// One encoded chunk: its decompressed block and its decoded level (what its children are coded
/// against).
pub struct EncodedChunk {
    /// The decompressed level block (spec §4) of the chunk.
    pub payload: Vec<u8>,
    /// The chunk's decoded level, in its decoded order.
    pub level: PlainLevel,
    /// Per face of the plan (`plan.faces[i]`): its index in the decoded chunk.
    pub face_new: Vec<u32>,
    /// Bytes of the topology streams and of the geometry stream (before zstd).
    pub split_bytes: (usize, usize),
    /// The block's `predictor` byte and `line_shift`.
    pub predictor: (u8, u32),
    /// Per vertex of the decoded chunk: the level's vertex it is (`plan.vertices[..]`).
    pub vertex_level: Vec<u32>,
}

/// Encodes every chunk of `plan` on `grid`, coarse to fine, each against its parent chunk's
/// decoded level (an empty lattice level when it has none), calling `each` in plan order.
pub fn encode_chunks(
    h: &Hierarchy,
    grid: &Grid,
    version: u16,
    plan: &[ChunkPlan],
    mut each: impl FnMut(usize, &EncodedChunk) -> Result<(), EncodeError>,
) -> Result<(), EncodeError> {
    let empty =
        PlainLevel { offsets: vec![0], slots: Some(Vec::new()), corners: Some(Vec::new()), ..PlainLevel::default() };
    // The encoded chunks of the level above, and per face of that level: (chunk, index in it).
    let mut above: Vec<Option<EncodedChunk>> = (0..plan.len()).map(|_| None).collect();
    let mut face_at: Vec<(u32, u32)> = Vec::new();
    let mut start = 0;
    let mut k = 0u32;
    while start < plan.len() {
        let end = start + plan[start..].iter().take_while(|c| c.level == k).count();
        let level = h.levels.get(k as usize).ok_or(EncodeError::Empty)?;
        let mut next_face_at = vec![(0u32, 0u32); level.origins.len()];
        let mut local = vec![u32::MAX; level.mesh.vertices.len()];
        for ci in start..end {
            let c = &plan[ci];
            let sub = sub_level(level, c, &mut local, &face_at);
            let parent_chunk = c.parent.and_then(|p| above[p as usize].as_ref());
            let parent_face_new = parent_chunk.map_or(&[][..], |p| &p.face_new[..]);
            let input = level_input(&sub, k as usize, grid, parent_face_new)?;
            let parent = if k == 0 { None } else { Some(parent_chunk.map_or(&empty, |e| &e.level)) };
            let enc = encode_level(k, &input, parent, grid.exact, grid.tied, grid.bits, version)?;
            let chunk = EncodedChunk {
                payload: enc.payload,
                level: enc.level,
                face_new: enc.face_new,
                split_bytes: enc.split_bytes,
                predictor: (enc.predictor, enc.line_shift),
                vertex_level: enc.vertex_old.iter().map(|&v| c.vertices[v as usize]).collect(),
            };
            for (i, &f) in c.faces.iter().enumerate() {
                next_face_at[f as usize] = (ci as u32, i as u32);
            }
            each(ci, &chunk)?;
            above[ci] = Some(chunk);
        }
        for a in &mut above[..start] {
            *a = None;
        }
        face_at = next_face_at;
        start = end;
        k += 1;
    }
    Ok(())
}

/// Chunk `c` of `level` as a level of its own: its faces and vertices renumbered in plan order,
/// its subfaces' parents numbered in their parent chunk's plan order (`face_at`).
fn sub_level(level: &Level, c: &ChunkPlan, local: &mut [u32], face_at: &[(u32, u32)]) -> Level {
    for (i, &v) in c.vertices.iter().enumerate() {
        local[v as usize] = i as u32;
    }
    let mut faces = FaceList::with_capacity(c.faces.len(), 4 * c.faces.len());
    let mut corners = Vec::new();
    for &f in &c.faces {
        corners.clear();
        corners.extend(level.mesh.faces.face(f as usize).iter().map(|&v| local[v as usize]));
        faces.push(&corners);
    }
    let positions = c.vertices.iter().map(|&v| level.mesh.vertices.positions[v as usize]).collect();
    let origins = c
        .faces
        .iter()
        .map(|&f| match level.origins[f as usize] {
            FaceOrigin::Subface { parent, quadrant } => {
                FaceOrigin::Subface { parent: face_at[parent as usize].1, quadrant }
            }
            FaceOrigin::Created => FaceOrigin::Created,
        })
        .collect();
    let lattice = level.lattice.as_ref().map(|l| LevelLattice {
        face_slots: c.faces.iter().map(|&f| l.face_slots[f as usize]).collect(),
        vertex_corners: c.vertices.iter().map(|&v| l.vertex_corners[v as usize]).collect(),
    });
    Level { mesh: Mesh { vertices: PointCloud::from_positions(positions), faces }, origins, lattice }
}
