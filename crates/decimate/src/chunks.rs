//! Geometric errors of MRQ chunks (spec §11.2 `geometric_error`): per chunk of a version 5 file,
//! the certified Hausdorff distance between the chunk's surface and the finest level's surface
//! over the chunk's cell, raised to its children's largest so that it never grows from a chunk to
//! the chunks refining it. A view-dependent client turns it into a screen-space error.

use octowrap_format::{ChunkInfo, ChunkedMrq, DecodeOptions, EncodeError, EncodeOptions, Limits};
use octowrap_mesh::Hierarchy;
use rayon::prelude::*;

/// Writes [`encode_measured`]'s bytes to `path` atomically ([`octowrap_fsutil::write_file`]: a
/// replaced file keeps its mode and owner, and is replaced only once the new one is complete).
pub fn write_measured(path: &std::path::Path, h: &Hierarchy, opts: &EncodeOptions) -> Result<(), EncodeError> {
    let bytes = encode_measured(h, opts)?;
    octowrap_fsutil::write_file(path, &octowrap_fsutil::WriteOptions::default(), |w| w.write_all(&bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| EncodeError::Io(e))
}

/// `h` encoded as MRQ with `opts`; in a chunked file (version 5) every chunk's geometric error is
/// measured ([`chunk_errors`]) and stored in the chunk index. Deterministic, whatever the thread
/// count.
pub fn encode_measured(h: &Hierarchy, opts: &EncodeOptions) -> Result<Vec<u8>, EncodeError> {
    let mut bytes = octowrap_format::encode(h, opts)?;
    if opts.version < 5 {
        return Ok(bytes);
    }
    // The file was just written: reading it back cannot fail but on a bug, said as such.
    let fail = |e: octowrap_format::DecodeError| {
        EncodeError::Io(std::io::Error::other(format!("reading back the file just encoded: {e}")))
    };
    let chunks = ChunkedMrq::open(&bytes[..], &Limits::default()).map_err(fail)?.chunks();
    let decoded = octowrap_format::decode(&bytes[..], &DecodeOptions::default()).map_err(fail)?.hierarchy;
    let errors = chunk_errors(&decoded, &chunks);
    octowrap_format::set_chunk_errors(&mut bytes, &errors).map_err(fail)?;
    Ok(bytes)
}

/// The geometric error of every chunk of a version 5 file, `chunks` as its index lists them and
/// `h` as the file decodes (each level's faces chunk after chunk, spec §11.4): the certified
/// Hausdorff distance's upper bound between the chunk's faces and the finest level's faces whose
/// voxels lie in the chunk's cell (all of the finest level without lattice coordinates), then the
/// largest of its own and of every chunk refining it. Chunks of the finest level have 0.
pub fn chunk_errors(h: &Hierarchy, chunks: &[ChunkInfo]) -> Vec<f32> {
    let Some(finest) = h.levels.last() else { return vec![0.0; chunks.len()] };
    let fk = h.levels.len() - 1;
    // Each chunk's first face in its level.
    let mut first = vec![0u32; chunks.len()];
    let mut next = vec![0u32; h.levels.len()];
    for (i, c) in chunks.iter().enumerate() {
        let k = c.level as usize;
        if k < next.len() {
            first[i] = next[k];
            next[k] += c.face_count;
        }
    }
    let measure = |i: usize| -> f64 {
        let c = &chunks[i];
        let k = c.level as usize;
        if k >= fk || c.face_count == 0 {
            return 0.0;
        }
        let Some(level) = h.levels.get(k) else { return 0.0 };
        let faces: Vec<u32> =
            (first[i]..first[i] + c.face_count).filter(|&f| (f as usize) < level.origins.len()).collect();
        let depth = c.cell_depth;
        let region: Vec<u32> = match &finest.lattice {
            Some(l) if depth > 0 => {
                let shift = fk as u32 - depth;
                (0..l.face_slots.len() as u32)
                    .filter(|&f| l.face_slots[f as usize].0.map(|x| x >> shift) == c.cell)
                    .collect()
            }
            _ => (0..finest.origins.len() as u32).collect(),
        };
        let d = crate::metrics::certified_hausdorff(&level.mesh.subset(&faces), &finest.mesh.subset(&region));
        if d.upper.is_finite() { d.upper } else { 0.0 }
    };
    let mut errors: Vec<f32> = (0..chunks.len()).into_par_iter().map(|i| measure(i) as f32).collect();
    // Children after parents in the index: walking backwards raises every parent after its children.
    for i in (0..chunks.len()).rev() {
        if let Some(p) = chunks[i].parent {
            let p = p as usize;
            if p < i {
                errors[p] = errors[p].max(errors[i]);
            }
        }
    }
    errors
}

/// Which chunks of a version 5 file to fetch and draw: refinement by replacement from the root
/// chunks down, the way 3D Tiles clients refine (`REPLACE`). The drawn chunks are a cut (no one
/// refines another) for [`octowrap_format::ChunkedMrq::cut`], which makes their mesh crack-free.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ViewSelection {
    /// The chunks drawn (index order).
    pub drawn: Vec<u32>,
    /// Every chunk to fetch: the drawn ones and their ancestors (index order).
    pub fetched: Vec<u32>,
}

/// The chunks a view shows: a chunk that the view frustum meets and whose geometric error exceeds
/// the camera's tolerance at its distance is replaced by the chunks refining it that the frustum
/// meets; the others are culled (neither fetched nor drawn: the view shows the surface in front of
/// the camera, not a closed one). `aspect` is the viewport's width over its height.
pub fn select_for_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> ViewSelection {
    let frustum = Frustum::new(camera, aspect);
    let seen = |c: &ChunkInfo| frustum.meets(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from));
    refine_while(chunks, |c| seen(c) && exceeds(c, camera.tolerance_at(frustum.distance_to(c))), seen)
}

/// Per chunk: whether the view frustum meets its bounding box (for
/// [`octowrap_format::ChunkedMrq::cut_where`] with a [`select_for_view`] selection).
pub fn in_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> Vec<bool> {
    let frustum = Frustum::new(camera, aspect);
    chunks.iter().map(|c| frustum.meets(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from))).collect()
}

/// The chunks for a view of the whole surface: as [`select_for_view`], but no chunk is culled: a
/// chunk outside the view frustum stays at the level where it leaves the view, so the drawn
/// chunks cover the surface (and their crack-free mesh is closed wherever the finest level is).
pub fn select_cover_for_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> ViewSelection {
    let frustum = Frustum::new(camera, aspect);
    let seen = |c: &ChunkInfo| frustum.meets(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from));
    refine_while(chunks, |c| seen(c) && exceeds(c, camera.tolerance_at(frustum.distance_to(c))), |_| true)
}

/// The coarsest cover whose chunks are each within `max_error` (model units) of the finest level:
/// a chunk whose geometric error exceeds it is replaced by the chunks refining it.
pub fn select_for_error(chunks: &[ChunkInfo], max_error: f64) -> ViewSelection {
    refine_while(chunks, |c| exceeds(c, max_error), |_| true)
}

/// Whether chunk `c`'s geometric error (unmeasured: infinite) exceeds `tolerance`.
fn exceeds(c: &ChunkInfo, tolerance: f64) -> bool {
    f64::from(c.geometric_error.unwrap_or(f32::INFINITY)) > tolerance
}

/// From every root chunk down: a chunk for which `refine` holds and that has children is replaced
/// by those of its children for which `keep` holds (drawn itself when none does); others are drawn.
fn refine_while(
    chunks: &[ChunkInfo],
    refine: impl Fn(&ChunkInfo) -> bool,
    keep: impl Fn(&ChunkInfo) -> bool,
) -> ViewSelection {
    let mut children: Vec<Vec<u32>> = vec![Vec::new(); chunks.len()];
    let mut roots = Vec::new();
    for (i, c) in chunks.iter().enumerate() {
        match c.parent {
            Some(p) if (p as usize) < i => children[p as usize].push(i as u32),
            _ => roots.push(i as u32),
        }
    }
    let mut out = ViewSelection::default();
    let mut stack: Vec<u32> = roots.into_iter().rev().collect();
    while let Some(i) = stack.pop() {
        let c = &chunks[i as usize];
        out.fetched.push(i);
        if !children[i as usize].is_empty() && refine(c) {
            let kept: Vec<u32> =
                children[i as usize].iter().rev().copied().filter(|&j| keep(&chunks[j as usize])).collect();
            if kept.is_empty() {
                out.drawn.push(i);
            }
            stack.extend(kept);
        } else {
            out.drawn.push(i);
        }
    }
    out.drawn.sort_unstable();
    out.fetched.sort_unstable();
    out
}

/// A camera's view frustum (no far plane).
struct Frustum {
    eye: [f64; 3],
    forward: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    tan_x: f64,
    tan_y: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Frustum {
    fn new(c: &crate::Camera, aspect: f64) -> Self {
        use octowrap_geom::DVec3;
        let eye = DVec3::from(c.position);
        let forward = (DVec3::from(c.target) - eye).normalize();
        let right = forward.cross(DVec3::from(c.up)).normalize();
        let up = right.cross(forward);
        let tan_y = (c.fov_y_degrees.to_radians() * 0.5).tan();
        Self {
            eye: c.position,
            forward: forward.to_array(),
            right: right.to_array(),
            up: up.to_array(),
            tan_x: tan_y * aspect.max(1e-6),
            tan_y,
        }
    }

    /// Whether the box `lo..hi` meets the frustum: no side plane has all eight corners outside.
    fn meets(&self, lo: [f64; 3], hi: [f64; 3]) -> bool {
        let corners = (0..8).map(|m| {
            let p = [0, 1, 2].map(|a| if m >> a & 1 == 1 { hi[a] } else { lo[a] });
            [0, 1, 2].map(|a| p[a] - self.eye[a])
        });
        let corners: Vec<[f64; 3]> = corners.collect();
        let outside = |side: &dyn Fn([f64; 3]) -> f64| corners.iter().all(|&x| side(x) > 0.0);
        let (f, r, u) = (self.forward, self.right, self.up);
        !(outside(&|x| -dot(x, f))
            || outside(&|x| dot(x, r) - self.tan_x * dot(x, f))
            || outside(&|x| -dot(x, r) - self.tan_x * dot(x, f))
            || outside(&|x| dot(x, u) - self.tan_y * dot(x, f))
            || outside(&|x| -dot(x, u) - self.tan_y * dot(x, f)))
    }

    /// Distance from the eye to chunk `c`'s bounding box (0 inside it).
    fn distance_to(&self, c: &ChunkInfo) -> f64 {
        self.distance(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from))
    }

    /// Distance from the eye to the box (0 inside it).
    fn distance(&self, lo: [f64; 3], hi: [f64; 3]) -> f64 {
        let d: Vec<f64> = (0..3).map(|a| (lo[a] - self.eye[a]).max(0.0).max(self.eye[a] - hi[a])).collect();
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    }
}
