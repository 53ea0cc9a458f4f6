//! Which chunks of a version 5 file a view needs (spec §11.5's cuts): refinement by replacement
//! from the root chunks down, by each chunk's geometric error against a camera's screen-space
//! tolerance or a fixed error, with or without frustum culling. The drawn chunks are a cut for
//! [`crate::ChunkedMrq::cut`], which makes their mesh crack-free.

use octowrap_geom::DVec3;

use crate::ChunkInfo;

/// A camera, as the selection sees it: where it is, where it looks, and the screen-space error it
/// allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewCamera {
    /// Eye position, world units.
    pub position: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction.
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_y_degrees: f64,
    /// Viewport height, pixels.
    pub viewport_height_px: f64,
    /// Largest screen-space error, pixels.
    pub pixel_error: f64,
}

impl ViewCamera {
    /// The largest geometric error that shows as at most `pixel_error` pixels at distance `d`:
    /// `pixel_error · 2 d tan(fov_y / 2) / viewport_height_px`.
    pub fn tolerance_at(&self, d: f64) -> f64 {
        self.pixel_error * 2.0 * d * (self.fov_y_degrees.to_radians() * 0.5).tan() / self.viewport_height_px
    }
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
pub fn select_for_view(chunks: &[ChunkInfo], camera: &ViewCamera, aspect: f64) -> ViewSelection {
    let frustum = Frustum::new(camera, aspect);
    let seen = |c: &ChunkInfo| frustum.meets(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from));
    refine_while(chunks, |c| seen(c) && exceeds(c, camera.tolerance_at(frustum.distance_to(c))), seen)
}

/// Per chunk: whether the view frustum meets its bounding box (for
/// [`crate::ChunkedMrq::cut_where`] with a [`select_for_view`] selection).
pub fn in_view(chunks: &[ChunkInfo], camera: &ViewCamera, aspect: f64) -> Vec<bool> {
    let frustum = Frustum::new(camera, aspect);
    chunks.iter().map(|c| frustum.meets(c.bbox_min.map(f64::from), c.bbox_max.map(f64::from))).collect()
}

/// The chunks for a view of the whole surface: as [`select_for_view`], but no chunk is culled: a
/// chunk outside the view frustum stays at the level where it leaves the view, so the drawn
/// chunks cover the surface (and their crack-free mesh is closed wherever the finest level is).
pub fn select_cover_for_view(chunks: &[ChunkInfo], camera: &ViewCamera, aspect: f64) -> ViewSelection {
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
    fn new(c: &ViewCamera, aspect: f64) -> Self {
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
