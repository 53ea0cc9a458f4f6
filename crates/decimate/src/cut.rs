//! Adaptive cuts through a multiresolution hierarchy: the coarsest level wherever it is accurate
//! enough, stitched crack-free.
//!
//! Sources: Keller et al. (subdivision connectivity of the levels, §3.4-3.5: every face of level
//! `j + 1` covers quadrant `q` of a parent face of level `j`, or was created); the selective
//! refinement of Hoppe, "View-Dependent Refinement of Progressive Meshes" (SIGGRAPH 1997, §4:
//! screen-space error tolerance `τ · 2 d tan(fov/2) / height`); crack-free stitching of mixed
//! levels in the spirit of restricted quadtrees (Pajarola 1998), done here by sharing the finest
//! level's vertices instead of restricting the cut.
//!
//! # Definitions
//! * **Region** of a face `f` of level `j`: the set of finest-level faces that descend from it.
//!   A finest-level face is its own region.
//! * `f` is **complete** when it is a quad, all four quadrant children exist and are complete
//!   (finest faces are complete), the corner of child `q` at the parent's corner `q` is the one
//!   child vertex shared with no sibling, and the region's boundary is one simple loop that
//!   passes through the four **corner vertices** (those corners followed down to the finest level)
//!   in the face's own order. Only complete faces can stand for their region.
//! * The **quad** of a complete face: its four corner vertices at their finest-level positions,
//!   split along the shorter diagonal.
//! * **Distance of `f` to the finest level**: the symmetric Hausdorff distance between the quad
//!   and the region's triangles (quads split along their shorter diagonal, polygons fanned),
//!   certified: the upper bound of `hausdorff.rs`, which no point of either surface exceeds,
//!   between samples included, and which is within 1 % of a distance actually found.
//!
//! # The cut
//! Top-down from every root (level-0 faces and created faces): a complete face whose distance is
//! within the tolerance is selected, otherwise its children are visited; finest faces are always
//! selectable. The selected regions partition the finest level's faces.
//!
//! # Stitching, and why the result is crack-free
//! Every output vertex is a finest-level vertex. *Kept* vertices are the corners of the selected
//! faces (all vertices of selected finest faces) and the junctions: vertices where three or more
//! selected regions meet, the finest level's boundary counting as one. A selected coarse face
//! becomes the polygon of its region's boundary loop restricted to the kept vertices, so a coarse
//! face beside finer ones gains their corners on its edges (a T-junction becomes a polygon corner).
//! Between two kept vertices, a region's boundary runs along exactly one neighbour (or the finest
//! boundary), since any change of neighbour is a junction; the neighbour restricts the same path
//! to the same kept vertices, so both produce the same polygon edge in opposite directions: no
//! gaps, no T-junctions, and boundary edges only on the finest level's own boundary. Regions are
//! disks whose boundary vertices are manifold in the finest level (checked), so replacing a
//! region by its polygon creates no non-manifold vertex or edge.
//!
//! Each selected coarse face is then checked as it will be output (its polygon with the kept
//! vertices, fan-triangulated from its first corner as [`Mesh::triangles`] does): if that polygon
//! is farther than the tolerance from its region, by the same distance, the face is refused and the
//! selection redone. So every output face is within the tolerance of the finest level.

use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::{FaceList, FaceOrigin, Hierarchy, Mesh, PointCloud};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::Error;
use crate::hausdorff::Tolerance;

/// A camera for view-dependent cuts, read from JSON (see [`Camera::from_json`]).
///
/// ```json
/// {
///   "position": [0.5, -2.0, 0.5],
///   "target": [0.0, 0.0, 0.0],
///   "up": [0.0, 0.0, 1.0],
///   "fov_y_degrees": 60.0,
///   "viewport_height_px": 1080,
///   "pixel_error": 1.0
/// }
/// ```
///
/// A region at distance `d` from `position` (the distance to its bounding box) may be drawn
/// coarsely when its distance to the finest level is at most
/// `pixel_error · 2 d tan(fov_y / 2) / viewport_height_px`: the world size of `pixel_error`
/// pixels at that depth. `target` and `up` fix the view direction and are checked, but the cut
/// keeps every region (no frustum culling), so the result stays a closed surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Eye position, world units.
    pub position: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction (default `[0, 0, 1]`).
    #[serde(default = "z_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees, in `(0, 180)`.
    pub fov_y_degrees: f64,
    /// Viewport height in pixels, positive.
    pub viewport_height_px: f64,
    /// Largest screen-space error in pixels, positive.
    pub pixel_error: f64,
}

fn z_up() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

impl Camera {
    /// Reads and checks a camera from JSON (schema in the type's docs).
    pub fn from_json(text: &str) -> Result<Self, Error> {
        let c: Self = serde_json::from_str(text).map_err(|e| Error::Camera(e.to_string()))?;
        c.check()?;
        Ok(c)
    }

    /// Checks the ranges: finite vectors, distinct position and target, an up vector not along the
    /// view direction, field of view in `(0, 180)`, positive viewport height and pixel error.
    pub fn check(&self) -> Result<(), Error> {
        let (p, t, u) = (DVec3::from(self.position), DVec3::from(self.target), DVec3::from(self.up));
        let bad = |why: &str| Err(Error::Camera(why.to_owned()));
        if !(p.is_finite() && t.is_finite() && u.is_finite()) {
            return bad("position, target and up must be finite");
        }
        if (t - p).length_squared() == 0.0 || (t - p).cross(u).length_squared() == 0.0 {
            return bad("target must differ from position, and up must not be along the view direction");
        }
        if !(self.fov_y_degrees > 0.0 && self.fov_y_degrees < 180.0) {
            return bad("fov_y_degrees must be in (0, 180)");
        }
        if !(self.viewport_height_px > 0.0 && self.viewport_height_px.is_finite()) {
            return bad("viewport_height_px must be positive");
        }
        if !(self.pixel_error > 0.0 && self.pixel_error.is_finite()) {
            return bad("pixel_error must be positive");
        }
        Ok(())
    }

    /// The world-space tolerance at distance `d` from the eye.
    pub fn tolerance_at(&self, d: f64) -> f64 {
        self.view().tolerance_at(d)
    }

    /// The camera as the chunk selection sees it ([`octowrap_format::select`]).
    pub fn view(&self) -> octowrap_format::select::ViewCamera {
        let Self { position, target, up, fov_y_degrees, viewport_height_px, pixel_error } = *self;
        octowrap_format::select::ViewCamera { position, target, up, fov_y_degrees, viewport_height_px, pixel_error }
    }
}

/// What decides where the cut is coarse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CutCriterion {
    /// A region may be coarse when its distance to the finest level is at most this, in world
    /// units.
    MaxError(f64),
    /// A screen-space error for a camera.
    View(Camera),
}

/// What [`cut`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CutReport {
    /// Faces of the finest level.
    pub finest_faces: usize,
    /// Output faces.
    pub faces: usize,
    /// Output vertices.
    pub vertices: usize,
    /// Selected faces per level, coarsest first.
    pub faces_per_level: Vec<usize>,
    /// Complete faces per level (those that could stand for their region).
    pub complete_per_level: Vec<usize>,
    /// Largest distance to the finest level of a selected face (0 when all are finest): the
    /// certified upper bound of the module docs, so the cut is within it of the finest level.
    pub max_error: f64,
}

/// The result of [`cut`].
#[derive(Clone, Debug)]
pub struct HierarchyCut {
    /// The adaptive mesh.
    pub mesh: Mesh,
    /// What was selected.
    pub report: CutReport,
}

/// A complete face.
struct Info {
    /// Finest-level vertices at the four corners.
    corners: [u32; 4],
    /// Finest-level faces of the region.
    region: Vec<u32>,
    /// The region's boundary loop (finest-level vertices), starting at `corners[0]`.
    boundary: Vec<u32>,
    /// Distance to the finest level.
    error: f64,
    /// Bounds of the region's vertices.
    bounds: Aabb,
}

/// Cuts `h` adaptively (see the module docs for the definitions and the crack-freeness argument).
///
/// Output: a polygon mesh over the finest level's vertices that the cut uses (renumbered in
/// finest order, keeping their attributes). Selected finest faces come out as they are; a selected
/// coarse face comes out as a polygon of 4 or more corners. If the finest level is manifold (and
/// closed), so is the cut; its boundary edges lie on the finest level's boundary.
pub fn cut(h: &Hierarchy, criterion: &CutCriterion) -> Result<HierarchyCut, Error> {
    check_input(h, criterion)?;
    let finest = &h.levels[h.levels.len() - 1].mesh;
    let children = quadrant_children(h);
    let finest_info = FinestInfo::new(finest);
    let info = completeness(h, &children, &finest_info);
    let tolerance = |i: &Info| match criterion {
        CutCriterion::MaxError(e) => *e,
        CutCriterion::View(c) => {
            let p = DVec3::from(c.position);
            c.tolerance_at((i.bounds.min - p).max(p - i.bounds.max).max(DVec3::ZERO).length())
        }
    };
    let selection = select_within_tolerance(h, &children, &info, &finest_info, &tolerance);
    Ok(stitch(h, &info, &selection))
}

/// Rejects an empty hierarchy, broken links or indices, a negative or NaN error bound, a bad
/// camera, and non-finite positions of the finest level's vertices.
fn check_input(h: &Hierarchy, criterion: &CutCriterion) -> Result<(), Error> {
    let Some(finest) = h.levels.last() else { return Err(Error::EmptyHierarchy) };
    h.check_links()?;
    for l in &h.levels {
        l.mesh.check_indices()?;
    }
    match criterion {
        CutCriterion::MaxError(e) if e.is_nan() || *e < 0.0 => {
            return Err(Error::option("max_error", "must be zero or positive"));
        }
        CutCriterion::View(c) => c.check()?,
        CutCriterion::MaxError(_) => {}
    }
    let fine = &finest.mesh;
    let fpos = &fine.vertices.positions;
    if let Some(&v) = fine.faces.indices().iter().find(|&&v| !fpos[v as usize].is_finite()) {
        return Err(Error::NonFinite { vertex: v });
    }
    Ok(())
}

/// `children[j][f][q]`: the face of level `j + 1` covering quadrant `q` of face `f` of level `j`
/// (`u32::MAX` for none).
fn quadrant_children(h: &Hierarchy) -> Vec<Vec<[u32; 4]>> {
    (0..h.levels.len() - 1)
        .map(|j| {
            let mut c = vec![[u32::MAX; 4]; h.levels[j].mesh.faces.len()];
            for (f, o) in h.levels[j + 1].origins.iter().enumerate() {
                if let FaceOrigin::Subface { parent, quadrant } = *o {
                    c[parent as usize][usize::from(quadrant.0)] = f as u32;
                }
            }
            c
        })
        .collect()
}

/// What the cut needs to know about the finest level's vertices.
struct FinestInfo {
    /// How many finest faces use each vertex (a region's interior vertices must be used by the
    /// region only).
    uses: Vec<u32>,
    /// Each vertex's kind (interior, border, frozen) as the edge collapse classifies it.
    kinds: Vec<crate::collapse::Kind>,
    /// Vertices where the finest level is not manifold (several fans, non-manifold or
    /// mis-oriented edges): no region may have one on its boundary, so every defect stays where
    /// it is.
    defect: Vec<bool>,
    /// The faces at each vertex.
    faces_of: crate::collapse::Csr,
    /// Tightness of the region distances.
    tol: Tolerance,
}

impl FinestInfo {
    fn new(fine: &Mesh) -> Self {
        let fpos = &fine.vertices.positions;
        let mut uses = vec![0u32; fpos.len()];
        for &v in fine.faces.indices() {
            uses[v as usize] += 1;
        }
        let tris = fine.triangles();
        let adj = crate::collapse::Csr::build(fpos.len(), &tris);
        let kinds = crate::collapse::classify(fpos.len(), &tris, &adj, false);
        let defect = kinds.iter().map(|&k| k == crate::collapse::Kind::Frozen).collect();
        let faces_of = crate::collapse::Csr::build_polygons(fpos.len(), &fine.faces);
        let tol = crate::hausdorff::tolerance(fine.vertices.bounds().diagonal());
        FinestInfo { uses, kinds, defect, faces_of, tol }
    }
}

/// The completeness data of every face of every level but the finest (`None` where a face is not
/// complete), finest-but-one level first.
fn completeness(h: &Hierarchy, children: &[Vec<[u32; 4]>], fi: &FinestInfo) -> Vec<Vec<Option<Info>>> {
    let last = h.levels.len() - 1;
    let fpos = &h.levels[last].mesh.vertices.positions;
    let mut info: Vec<Vec<Option<Info>>> = (0..=last).map(|_| Vec::new()).collect();
    for j in (0..last).rev() {
        let (below, here) = info.split_at_mut(j + 1);
        let next = &here[0];
        let ctx = Context { h, fpos, last, next, uses: &fi.uses, defect: &fi.defect, tol: fi.tol };
        below[j] =
            (0..h.levels[j].mesh.faces.len()).into_par_iter().map(|f| ctx.complete(j, f, children[j][f])).collect();
    }
    info
}

/// The faces selected, the finest vertices kept, and each selected face's distance to the finest
/// level as it is output.
struct Selection {
    selected: Vec<(usize, u32)>,
    kept: Vec<bool>,
    errors: Vec<f64>,
}

/// Selects, then checks each selected coarse face as it will be output (with the corners of finer
/// neighbours on its edges, fan-triangulated); faces over their tolerance are banned and the
/// selection redone, until none is (each round bans at least one face, so this ends).
fn select_within_tolerance(
    h: &Hierarchy,
    children: &[Vec<[u32; 4]>],
    info: &[Vec<Option<Info>>],
    fi: &FinestInfo,
    tolerance: &dyn Fn(&Info) -> f64,
) -> Selection {
    let last = h.levels.len() - 1;
    let fine = &h.levels[last].mesh;
    let fpos = &fine.vertices.positions;
    let info_of = |j: usize, f: u32| info[j].get(f as usize).and_then(Option::as_ref);
    let mut banned: Vec<Vec<bool>> = info.iter().map(|l| vec![false; l.len()]).collect();
    loop {
        let selected = select(h, children, |j, f| {
            !banned[j][f as usize] && info_of(j, f).is_some_and(|i| i.error <= tolerance(i))
        });
        let kept = kept_vertices(fine, last, &selected, info, fi);
        let errors: Vec<f64> = selected
            .par_iter()
            .map(|&(j, f)| match info_of(j, f) {
                Some(i) if j < last => {
                    let poly: Vec<u32> = i.boundary.iter().copied().filter(|&v| kept[v as usize]).collect();
                    if poly.len() == 4 {
                        return i.error;
                    }
                    let fan: Vec<[u32; 3]> = face_triangles(fpos, &poly).collect();
                    region_distance(fpos, &fine.faces, &i.region, &fan, fi.tol)
                }
                _ => 0.0,
            })
            .collect();
        let mut changed = false;
        for (&(j, f), &e) in selected.iter().zip(&errors) {
            if let Some(i) = info_of(j, f).filter(|_| j < last) {
                if e > tolerance(i) {
                    banned[j][f as usize] = true;
                    changed = true;
                }
            }
        }
        if !changed {
            return Selection { selected, kept, errors };
        }
    }
}

/// The finest vertices the selection keeps: the corners of the selected faces, and the junctions,
/// vertices where three or more selected faces meet, counting the finest level's boundary as one
/// (away from corners, a region's boundary meets another region's only along paths, and both
/// skip the same vertices).
fn kept_vertices(
    fine: &Mesh,
    last: usize,
    selected: &[(usize, u32)],
    info: &[Vec<Option<Info>>],
    fi: &FinestInfo,
) -> Vec<bool> {
    let mut kept = vec![false; fine.vertices.positions.len()];
    let mut owner = vec![u32::MAX; fine.faces.len()];
    for (k, &(j, f)) in selected.iter().enumerate() {
        match info[j].get(f as usize).and_then(Option::as_ref) {
            Some(i) if j < last => {
                i.corners.iter().for_each(|&v| kept[v as usize] = true);
                i.region.iter().for_each(|&g| owner[g as usize] = k as u32);
            }
            _ => {
                fine.faces.face(f as usize).iter().for_each(|&v| kept[v as usize] = true);
                owner[f as usize] = k as u32;
            }
        }
    }
    for (v, k) in kept.iter_mut().enumerate() {
        if *k {
            continue;
        }
        let mut seen = [u32::MAX; 3];
        let mut n = usize::from(fi.kinds[v] == crate::collapse::Kind::Border);
        for &g in fi.faces_of.of(v as u32) {
            let o = owner[g as usize];
            if n < 3 && !seen[..n].contains(&o) {
                seen[n] = o;
                n += 1;
            }
        }
        *k = n >= 3;
    }
    kept
}

/// The output: the kept vertices renumbered in finest order with their attributes, every selected
/// finest face as it is, every selected coarse face as its boundary loop restricted to the kept
/// vertices; and the report.
fn stitch(h: &Hierarchy, info: &[Vec<Option<Info>>], selection: &Selection) -> HierarchyCut {
    let last = h.levels.len() - 1;
    let fine = &h.levels[last].mesh;
    let fpos = &fine.vertices.positions;
    let Selection { selected, kept, errors } = selection;
    let mut map = vec![u32::MAX; fpos.len()];
    let mut order = Vec::new();
    for (v, &k) in kept.iter().enumerate() {
        if k {
            map[v] = order.len() as u32;
            order.push(v);
        }
    }
    let mut faces = FaceList::default();
    let mut per_level = vec![0usize; last + 1];
    let max_error = errors.iter().copied().fold(0.0, f64::max);
    for &(j, f) in selected {
        per_level[j] += 1;
        match info[j].get(f as usize).and_then(Option::as_ref) {
            Some(i) if j < last => {
                faces.push_iter(i.boundary.iter().filter(|&&v| kept[v as usize]).map(|&v| map[v as usize]));
            }
            _ => faces.push_iter(fine.faces.face(f as usize).iter().map(|&v| map[v as usize])),
        }
    }
    let src = &fine.vertices;
    let vertices = PointCloud {
        positions: order.iter().map(|&v| fpos[v]).collect(),
        normals: src.normals.as_ref().map(|n| order.iter().map(|&v| n[v]).collect()),
        colors: src.colors.as_ref().map(|c| order.iter().map(|&v| c[v]).collect()),
        intensities: src.intensities.as_ref().map(|c| order.iter().map(|&v| c[v]).collect()),
    };
    let report = CutReport {
        finest_faces: fine.faces.len(),
        faces: faces.len(),
        vertices: order.len(),
        faces_per_level: per_level,
        complete_per_level: (0..=last)
            .map(|j| if j == last { fine.faces.len() } else { info[j].iter().flatten().count() })
            .collect(),
        max_error,
    };
    HierarchyCut { mesh: Mesh { vertices, faces }, report }
}

/// Top-down from every root (level-0 and created faces), children in quadrant order: a face is
/// selected when it is finest or `accept` says so, otherwise its children are visited.
fn select(h: &Hierarchy, children: &[Vec<[u32; 4]>], accept: impl Fn(usize, u32) -> bool) -> Vec<(usize, u32)> {
    let last = h.levels.len() - 1;
    let mut selected = Vec::new();
    let mut stack: Vec<(usize, u32)> = Vec::new();
    for (j, level) in h.levels.iter().enumerate() {
        for (f, o) in level.origins.iter().enumerate().rev() {
            if j == 0 || *o == FaceOrigin::Created {
                stack.push((j, f as u32));
            }
        }
        while let Some((j, f)) = stack.pop() {
            if j == last || accept(j, f) {
                selected.push((j, f));
                continue;
            }
            for &c in children[j][f as usize].iter().rev() {
                if c != u32::MAX {
                    stack.push((j + 1, c));
                }
            }
        }
    }
    selected
}

struct Context<'a> {
    h: &'a Hierarchy,
    fpos: &'a [DVec3],
    last: usize,
    /// Completeness of level `j + 1` (empty when `j + 1` is the finest level).
    next: &'a [Option<Info>],
    /// Finest faces per finest vertex.
    uses: &'a [u32],
    /// Non-manifold finest vertices.
    defect: &'a [bool],
    /// Tightness of the region distances.
    tol: Tolerance,
}

impl Context<'_> {
    /// The completeness data of face `f` of level `j < last`, or `None` when it is not complete.
    fn complete(&self, j: usize, f: usize, children: [u32; 4]) -> Option<Info> {
        let level = &self.h.levels[j].mesh;
        let child_level = &self.h.levels[j + 1].mesh;
        if level.faces.face(f).len() != 4 || children.contains(&u32::MAX) {
            return None;
        }
        let cf: Vec<&[u32]> = children.iter().map(|&c| child_level.faces.face(c as usize)).collect();
        if cf.iter().any(|c| c.len() != 4) {
            return None;
        }
        let mut corners = [0u32; 4];
        let mut region = Vec::new();
        for q in 0..4 {
            let own: Vec<usize> =
                (0..4).filter(|&k| (0..4).filter(|&r| r != q).all(|r| !cf[r].contains(&cf[q][k]))).collect();
            let [k] = own[..] else { return None };
            let c = children[q] as usize;
            if j + 1 == self.last {
                corners[q] = cf[q][k];
                region.push(children[q]);
            } else {
                let ci = self.next[c].as_ref()?;
                corners[q] = ci.corners[k];
                region.extend_from_slice(&ci.region);
            }
        }
        let fine = &self.h.levels[self.last].mesh.faces;
        let boundary = boundary_loop(fine, &region, corners)?;
        if !self.is_disk(fine, &region, &boundary) {
            return None;
        }
        let quad: Vec<[u32; 3]> = face_triangles(self.fpos, &corners).collect();
        let error = region_distance(self.fpos, fine, &region, &quad, self.tol);
        let bounds = Aabb::from_points(boundary.iter().map(|&v| &self.fpos[v as usize]));
        Some(Info { corners, region, boundary, error, bounds })
    }

    /// Whether the region is a disk whose boundary is manifold in the finest level: no boundary
    /// vertex is a non-manifold vertex of the finest level, the interior vertices (those off the
    /// boundary loop) are used by region faces only, and `V - E + F = 1`.
    fn is_disk(&self, fine: &FaceList, region: &[u32], boundary: &[u32]) -> bool {
        if boundary.iter().any(|&v| self.defect[v as usize]) {
            return false;
        }
        let mut corners: Vec<u32> = region.iter().flat_map(|&g| fine.face(g as usize).iter().copied()).collect();
        let mut edges: Vec<(u32, u32)> = region
            .iter()
            .flat_map(|&g| {
                let f = fine.face(g as usize);
                (0..f.len()).map(move |k| (f[k].min(f[(k + 1) % f.len()]), f[k].max(f[(k + 1) % f.len()])))
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        corners.sort_unstable();
        let mut on_loop = boundary.to_vec();
        on_loop.sort_unstable();
        let mut vertices = 0i64;
        for run in corners.chunk_by(|a, b| a == b) {
            vertices += 1;
            let v = run[0];
            if on_loop.binary_search(&v).is_err() && self.uses[v as usize] as usize != run.len() {
                return false;
            }
        }
        vertices - edges.len() as i64 + region.len() as i64 == 1
    }
}

/// The distance between the surface `surface` (triangles over finest vertices) and the finest
/// faces `region` (see the module docs): the certified symmetric Hausdorff distance's upper bound
/// (`hausdorff.rs`), computed over the region's own vertices.
fn region_distance(fpos: &[DVec3], fine: &FaceList, region: &[u32], surface: &[[u32; 3]], tol: Tolerance) -> f64 {
    let mut local: Vec<u32> = region.iter().flat_map(|&g| fine.face(g as usize).iter().copied()).collect();
    local.extend(surface.iter().flatten());
    local.sort_unstable();
    local.dedup();
    let at = |v: u32| local.binary_search(&v).map_or(0, |i| i as u32);
    let pos: Vec<DVec3> = local.iter().map(|&v| fpos[v as usize]).collect();
    let mut region_tris = Vec::with_capacity(region.len() * 2);
    for &g in region {
        let face = fine.face(g as usize);
        region_tris.extend(face_triangles(fpos, face).map(|t| t.map(at)));
    }
    let surface: Vec<[u32; 3]> = surface.iter().map(|t| t.map(at)).collect();
    crate::hausdorff::symmetric(&pos, &region_tris, &pos, &surface, tol).upper
}

/// The triangles of one face as [`Mesh::triangles`] makes them: a quad split along its shorter
/// diagonal, other polygons fanned from their first corner.
fn face_triangles<'a>(fpos: &'a [DVec3], face: &'a [u32]) -> impl Iterator<Item = [u32; 3]> + 'a {
    let quad = if let &[a, b, c, d] = face {
        let p = |v: u32| fpos[v as usize];
        Some(if p(a).distance_squared(p(c)) <= p(b).distance_squared(p(d)) {
            [[a, b, c], [a, c, d]]
        } else {
            [[a, b, d], [b, c, d]]
        })
    } else {
        None
    };
    let fan = face.split_first().filter(|_| quad.is_none()).map(|(&first, rest)| (first, rest));
    quad.into_iter()
        .flatten()
        .chain(fan.into_iter().flat_map(|(first, rest)| rest.windows(2).map(move |w| [first, w[0], w[1]])))
}

/// The boundary loop of `region` (one simple loop through the corners in order, starting at
/// `corners[0]`), or `None`.
fn boundary_loop(fine: &FaceList, region: &[u32], corners: [u32; 4]) -> Option<Vec<u32>> {
    let key = |u: u32, v: u32| (u64::from(u) << 32) | u64::from(v);
    let mut half: Vec<u64> = Vec::with_capacity(region.len() * 4);
    for &g in region {
        let f = fine.face(g as usize);
        for k in 0..f.len() {
            half.push(key(f[k], f[(k + 1) % f.len()]));
        }
    }
    half.sort_unstable();
    if half.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    let border: Vec<u64> =
        half.iter().copied().filter(|&h| half.binary_search(&key(h as u32, (h >> 32) as u32)).is_err()).collect();
    // `border` is sorted by its start vertex; a start used twice is a pinch.
    if border.windows(2).any(|w| w[0] >> 32 == w[1] >> 32) {
        return None;
    }
    let next = |u: u32| {
        let i = border.partition_point(|&h| (h >> 32) < u64::from(u));
        border.get(i).filter(|&&h| (h >> 32) as u32 == u).map(|&h| h as u32)
    };
    let mut out = Vec::with_capacity(border.len());
    let mut at = corners[0];
    loop {
        out.push(at);
        at = next(at)?;
        if at == corners[0] || out.len() > border.len() {
            break;
        }
    }
    if out.len() != border.len() || at != corners[0] {
        return None;
    }
    let mut last = 0;
    for &c in &corners[1..] {
        let i = out.iter().position(|&v| v == c)?;
        if i <= last {
            return None;
        }
        last = i;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_json_and_tolerance() {
        let c = Camera::from_json(
            r#"{"position":[0,0,10],"target":[0,0,0],"up":[0,1,0],"fov_y_degrees":90,"viewport_height_px":1000,"pixel_error":2}"#,
        )
        .unwrap();
        // 90 degrees: the viewport spans 2 d at depth d; 2 pixels of 1000 are 0.004 d.
        assert!((c.tolerance_at(10.0) - 0.04).abs() < 1e-12);
        assert!(
            Camera::from_json(
                r#"{"position":[0,0,0],"target":[0,0,0],"fov_y_degrees":60,"viewport_height_px":1,"pixel_error":1}"#
            )
            .is_err()
        );
        assert!(Camera::from_json(r#"{"position":[0,0,1],"target":[0,0,0],"fov_y_degrees":60,"viewport_height_px":1,"pixel_error":1,"up":[0,1,0],"near":3}"#).is_err());
        assert!(Camera::from_json("[1,2]").is_err());
    }
}
