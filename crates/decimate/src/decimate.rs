//! The entry point for general decimation: [`decimate`].

use octowrap_geom::{Aabb, DVec3, morton};
use octowrap_mesh::{FaceList, Mesh, PointCloud};
use rayon::prelude::*;
use serde::Serialize;

use crate::collapse::{self, Stop};
use crate::{Error, quads};

/// An error bound for [`DecimateOptions::max_error`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ErrorBound {
    /// In the mesh's units.
    Absolute(f64),
    /// As a fraction of the bounding-box diagonal (`0.001` = 0.1 %).
    Relative(f64),
}

/// What to do with quad-dominant input (see the crate docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum QuadMode {
    /// Re-pair triangles into quads when at least half of the input faces are quads.
    #[default]
    Auto,
    /// Always re-pair.
    Quads,
    /// Always output triangles.
    Triangles,
}

/// Options of [`decimate`]. At least one of `target_faces` and `max_error` must be set; with
/// both, decimation stops at whichever comes first.
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct DecimateOptions {
    /// Stop once the output has at most this many faces. Default `None`.
    pub target_faces: Option<usize>,
    /// Stop before any collapse whose quadric error would exceed this. Default `None`.
    pub max_error: Option<ErrorBound>,
    /// Keep every boundary vertex where it is (interior vertices may still collapse into them).
    /// Default false: boundary vertices may collapse along the boundary, kept near it by
    /// boundary quadrics.
    pub lock_border: bool,
    /// Quad-dominant input. Default [`QuadMode::Auto`].
    pub quads: QuadMode,
}

impl DecimateOptions {
    /// Options aiming at `faces` faces.
    pub fn target_faces(faces: usize) -> Self {
        Self { target_faces: Some(faces), ..Self::default() }
    }

    /// Options bounding the error.
    pub fn max_error(bound: ErrorBound) -> Self {
        Self { max_error: Some(bound), ..Self::default() }
    }
}

/// What [`decimate`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DecimateReport {
    /// Input faces.
    pub input_faces: usize,
    /// Output faces.
    pub output_faces: usize,
    /// Output triangles before re-pairing into quads (equal to `output_faces` for triangle output).
    pub output_triangles: usize,
    /// Output vertices.
    pub output_vertices: usize,
    /// The error reached, in the mesh's units: the square root of the largest quadric error of an
    /// applied collapse (an area-weighted RMS distance of the moved vertex to the planes of the
    /// input faces it stands for). 0 when nothing collapsed.
    pub error: f64,
    /// `error` as a fraction of the input's bounding-box diagonal.
    pub relative_error: f64,
    /// The input's bounding-box diagonal.
    pub diagonal: f64,
    /// Edge collapses applied.
    pub collapses: usize,
    /// Passes over the candidate list.
    pub passes: usize,
    /// Vertices left untouched because the input is not manifold there.
    pub frozen_vertices: usize,
    /// Why decimation stopped.
    pub stop: Stop,
    /// Whether triangles were re-paired into quads.
    pub quads: bool,
}

/// The result of [`decimate`].
#[derive(Clone, Debug)]
pub struct Decimated {
    /// The decimated mesh.
    pub mesh: Mesh,
    /// What was done.
    pub report: DecimateReport,
}

/// Decimates `mesh` by quadric-error edge collapse (see the crate docs for the guarantees).
///
/// Input: any polygon mesh (faces of 3 or more vertices, indices in range, finite positions of
/// used vertices). Output: a mesh over the surviving vertices (renumbered in their input order,
/// keeping their attributes), whose faces are triangles, or triangles and quads for quad-dominant
/// input (see [`QuadMode`]). When the input already has at most `target_faces` faces and no error
/// bound is given, the input is returned unchanged.
pub fn decimate(mesh: &Mesh, opts: &DecimateOptions) -> Result<Decimated, Error> {
    decimate_with_progress(mesh, opts, &mut |_| {})
}

/// [`decimate`], calling `progress` with the live triangle count after each pass.
pub fn decimate_with_progress(
    mesh: &Mesh,
    opts: &DecimateOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<Decimated, Error> {
    mesh.check_indices()?;
    if opts.target_faces.is_none() && opts.max_error.is_none() {
        return Err(Error::option("target", "give a face target, an error bound, or both"));
    }
    let tris = mesh.triangles();
    let pos = &mesh.vertices.positions;
    if let Some(&v) = tris.iter().flatten().find(|&&v| !pos[v as usize].is_finite()) {
        return Err(Error::NonFinite { vertex: v });
    }
    let bounds = Aabb::from_points(tris.iter().flatten().map(|&v| &pos[v as usize]));
    let diagonal = if bounds.is_empty() { 0.0 } else { bounds.diagonal() };
    let max_error = match opts.max_error {
        None => f64::INFINITY,
        Some(ErrorBound::Absolute(e)) => e,
        Some(ErrorBound::Relative(e)) => e * diagonal,
    };
    if max_error.is_nan() || max_error < 0.0 {
        return Err(Error::option("max_error", "must be zero or positive"));
    }
    let input_faces = mesh.faces.len();
    let quad_count = mesh.faces.iter().filter(|f| f.len() == 4).count();
    let repair = match opts.quads {
        QuadMode::Auto => input_faces > 0 && 2 * quad_count >= input_faces,
        QuadMode::Quads => true,
        QuadMode::Triangles => false,
    };
    if opts.max_error.is_none() && opts.target_faces.is_some_and(|t| t >= input_faces) {
        let report = DecimateReport {
            input_faces,
            output_faces: input_faces,
            output_triangles: tris.len(),
            output_vertices: mesh.vertex_count(),
            error: 0.0,
            relative_error: 0.0,
            diagonal,
            collapses: 0,
            passes: 0,
            frozen_vertices: 0,
            stop: Stop::TargetReached,
            quads: false,
        };
        return Ok(Decimated { mesh: mesh.clone(), report });
    }
    // Work in a unit frame: centred, scaled by the diagonal, so quadric sums keep their precision
    // whatever the coordinates' offset (georeferenced data) and thresholds are unit-free.
    let scale = if diagonal > 0.0 { diagonal } else { 1.0 };
    let centre = if bounds.is_empty() { DVec3::ZERO } else { bounds.center() };
    let unit: Vec<DVec3> =
        pos.iter().map(|&p| if p.is_finite() { (p - centre) / scale } else { DVec3::ZERO }).collect();
    let target_tris = opts.target_faces.map_or(0, |t| if repair { t.saturating_mul(2) } else { t });
    let max_cost = (max_error / scale).powi(2);
    let out = collapse_coherent(&unit, &tris, opts.lock_border, target_tris, max_cost, progress);
    let faces = if repair { quads::pair(&out.pos, &out.tris) } else { FaceList::from_triangles(&out.tris) };
    // Renumber the surviving vertices in input order.
    let mut map = vec![u32::MAX; pos.len()];
    let mut kept = Vec::new();
    for &v in out.tris.iter().flatten() {
        map[v as usize] = 0;
    }
    for (v, m) in map.iter_mut().enumerate() {
        if *m == 0 {
            *m = kept.len() as u32;
            kept.push(v);
        }
    }
    let src = &mesh.vertices;
    let vertices = PointCloud {
        positions: kept.iter().map(|&v| out.pos[v] * scale + centre).collect(),
        normals: src.normals.as_ref().map(|n| kept.iter().map(|&v| n[v]).collect()),
        colors: src.colors.as_ref().map(|c| kept.iter().map(|&v| c[v]).collect()),
        intensities: src.intensities.as_ref().map(|c| kept.iter().map(|&v| c[v]).collect()),
    };
    let mut renumbered = FaceList::with_capacity(faces.len(), faces.corner_count());
    for f in faces.iter() {
        renumbered.push_iter(f.iter().map(|&v| map[v as usize]));
    }
    let error = out.max_cost.sqrt() * scale;
    let report = DecimateReport {
        input_faces,
        output_faces: renumbered.len(),
        output_triangles: out.tris.len(),
        output_vertices: kept.len(),
        error,
        relative_error: if diagonal > 0.0 { error / diagonal } else { 0.0 },
        diagonal,
        collapses: out.collapses,
        passes: out.passes,
        frozen_vertices: out.frozen,
        stop: out.stop,
        quads: repair,
    };
    Ok(Decimated { mesh: Mesh { vertices, faces: renumbered }, report })
}

/// [`collapse::run`] on a spatially coherent numbering (Morton order of the positions, ties by
/// index; triangles by their lowest vertex): the collapse loops read neighbours' data, which then
/// sit nearby in memory. The result is mapped back to the input numbering.
fn collapse_coherent(
    unit: &[DVec3],
    tris: &[[u32; 3]],
    lock_border: bool,
    target: usize,
    max_cost: f64,
    progress: &mut dyn FnMut(usize),
) -> collapse::Outcome {
    let cell = |x: f64| ((x + 0.5) * f64::from(1u32 << 20)).clamp(0.0, f64::from((1u32 << 21) - 1)) as u32;
    let codes: Vec<u64> = unit.par_iter().map(|p| morton::encode(cell(p.x), cell(p.y), cell(p.z))).collect();
    let mut perm: Vec<u32> = (0..unit.len() as u32).collect();
    perm.par_sort_unstable_by_key(|&v| (codes[v as usize], v));
    let mut inv = vec![0u32; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    let local: Vec<DVec3> = perm.iter().map(|&o| unit[o as usize]).collect();
    let mut local_tris: Vec<[u32; 3]> = tris.iter().map(|t| t.map(|v| inv[v as usize])).collect();
    local_tris.par_sort_unstable_by_key(|t| (t[0].min(t[1]).min(t[2]), *t));
    let mut out = collapse::run(local, local_tris, lock_border, target, max_cost, progress);
    for t in &mut out.tris {
        *t = t.map(|v| perm[v as usize]);
    }
    out.pos = inv.iter().map(|&n| out.pos[n as usize]).collect();
    out
}
