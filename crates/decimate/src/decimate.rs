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
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct DecimateOptions {
    /// At most this many output faces, counted as written: for quad-dominant input a quad is one
    /// face, as is each triangle left unpaired. Default `None`.
    pub target_faces: Option<usize>,
    /// The output's symmetric Hausdorff distance to the input is at most this (checked with the
    /// certified measurement of [`crate::metrics::certified_hausdorff`]: its upper bound). Default
    /// `None`.
    pub max_error: Option<ErrorBound>,
    /// Keep every boundary vertex where it is (interior vertices may still collapse into them).
    /// Default false: boundary vertices may collapse along the boundary, kept near it by
    /// boundary quadrics.
    pub lock_border: bool,
    /// Quad-dominant input. Default [`QuadMode::Auto`].
    pub quads: QuadMode,
    /// Measure the error reached ([`DecimateReport::error`]). Default true. Without `max_error`
    /// this may be turned off to save the measurement's time (on scanned meshes about twice the
    /// decimation's; the `octowrap` command turns it off unless asked to measure); with
    /// `max_error` the measurement always runs, since it is what enforces the bound.
    pub measure: bool,
}

impl Default for DecimateOptions {
    fn default() -> Self {
        Self { target_faces: None, max_error: None, lock_border: false, quads: QuadMode::Auto, measure: true }
    }
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
    /// The error reached, in the mesh's units: the symmetric Hausdorff distance between the input
    /// and the output surfaces (their triangles, [`Mesh::triangles`]), certified: no point of
    /// either surface is farther than this from the other, between samples included, and it
    /// exceeds the largest distance actually found ([`DecimateReport::error_found`]) by at most
    /// 1 % (see [`crate::metrics::certified_hausdorff`]). `None` when not measured
    /// ([`DecimateOptions::measure`]).
    pub error: Option<f64>,
    /// `error` as a fraction of the input's bounding-box diagonal.
    pub relative_error: Option<f64>,
    /// The largest distance between the surfaces found at a sample point: a lower bound of the
    /// true Hausdorff distance, so `error_found ≤ true distance ≤ error`.
    pub error_found: Option<f64>,
    /// The square root of the largest quadric error of an applied collapse (an area-weighted RMS
    /// distance of a moved vertex to the planes of the input faces it stands for): what steers
    /// the collapses, an estimate 2 to 5 times below the Hausdorff distance.
    pub quadric_error: f64,
    /// The input's bounding-box diagonal.
    pub diagonal: f64,
    /// Edge collapses applied.
    pub collapses: usize,
    /// Passes over the candidate list (of the collapse run kept).
    pub passes: usize,
    /// Collapse runs: more than one when the measured error was over `max_error` (a run with a
    /// lower quadric threshold followed) or quads were re-paired into more faces than the target
    /// (a run with a lower triangle target followed).
    pub runs: usize,
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
    let tris = quads::triangulate(mesh);
    let pos = &mesh.vertices.positions;
    let finite = |v: &u32| pos[*v as usize].is_finite();
    if let Some(t) = tris.par_iter().find_first(|t| !t.iter().all(finite)) {
        let v = t.iter().copied().find(|v| !finite(v)).unwrap_or(t[0]);
        return Err(Error::NonFinite { vertex: v });
    }
    let bounds = tris
        .par_chunks(1 << 14)
        .map(|c| Aabb::from_points(c.iter().flatten().map(|&v| &pos[v as usize])))
        .reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
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
    let unchanged = |stop: Stop, runs: usize| {
        let report = DecimateReport {
            input_faces,
            output_faces: input_faces,
            output_triangles: tris.len(),
            output_vertices: mesh.vertex_count(),
            error: Some(0.0),
            relative_error: Some(0.0),
            error_found: Some(0.0),
            quadric_error: 0.0,
            diagonal,
            collapses: 0,
            passes: 0,
            runs,
            frozen_vertices: 0,
            stop,
            quads: false,
        };
        Decimated { mesh: mesh.clone(), report }
    };
    if opts.max_error.is_none() && opts.target_faces.is_some_and(|t| t >= input_faces) {
        return Ok(unchanged(Stop::TargetReached, 0));
    }
    // Work in a unit frame: centred, scaled by the diagonal, so quadric sums keep their precision
    // whatever the coordinates' offset (georeferenced data) and thresholds are unit-free.
    let scale = if diagonal > 0.0 { diagonal } else { 1.0 };
    let centre = if bounds.is_empty() { DVec3::ZERO } else { bounds.center() };
    let unit: Vec<DVec3> =
        pos.par_iter().map(|&p| if p.is_finite() { (p - centre) / scale } else { DVec3::ZERO }).collect();
    let run = Run { mesh, unit: &unit, tris: &tris, opts, repair, scale, centre, input_faces, diagonal };
    // The measurement's absolute slack stays well below the bound, so that it can be met (down to
    // a billionth of the diagonal, below which rounding noise makes the search long).
    let mut tol = crate::hausdorff::tolerance(diagonal);
    tol.absolute = (1e-3 * max_error).clamp(1e-9 * diagonal, tol.absolute);
    let measure = |m: &Mesh, over: f64| {
        let out_tris = m.triangles();
        let (c, over) = crate::hausdorff::symmetric_over(pos, &tris, &m.vertices.positions, &out_tris, tol, over);
        (c, over, out_tris)
    };
    let Some(max_error) = opts.max_error.map(|_| max_error) else {
        let (mut out, ..) = run.once(f64::INFINITY, &[], progress);
        if opts.measure {
            out.set_error(measure(&out.mesh, f64::INFINITY).0, diagonal);
        }
        return Ok(out);
    };
    if max_error == 0.0 {
        // Floating-point rounding leaves no decimation certifiably exact.
        return Ok(unchanged(Stop::ErrorBound, 0));
    }
    let out = within_bound(&run, max_error, &measure, progress);
    Ok(out.unwrap_or_else(|runs| unchanged(Stop::ErrorBound, runs)))
}

/// The measurement [`within_bound`] uses: the certified distance to the input, the triangles of
/// the input and of the output where a point farther than the bound was found, and the output's
/// triangles.
type Measure<'a> = dyn Fn(&Mesh, f64) -> (crate::metrics::Certified, [Vec<u32>; 2], Vec<[u32; 3]>) + 'a;

/// Decimation within the error bound `max_error` (mesh units), or the number of runs made when no
/// run came within it.
fn within_bound(
    run: &Run<'_>,
    max_error: f64,
    measure: &Measure<'_>,
    progress: &mut dyn FnMut(usize),
) -> Result<Decimated, usize> {
    let (tris, diagonal, scale) = (run.tris, run.diagonal, run.scale);
    let n = run.mesh.vertices.positions.len();
    // The error bound. Collapse under a quadric threshold `max_error / k` (the measured distance
    // is 2 to 5 times the quadric error) and measure. Over the bound: freeze, for the next run
    // from the input, every input vertex that went into a vertex of a triangle where a point too
    // far was found (on either side), so those regions keep their input resolution; when no such
    // triangle is known (the excess is within the measurement's 1 % tolerance), lower the
    // threshold instead. A run well within the bound that stopped at it (before any freezing) is
    // followed by a run with a higher threshold, kept if it is within the bound too (twice at
    // most).
    let mut k = CALIBRATION;
    let mut keep: Vec<bool> = Vec::new();
    let mut kept: Option<Decimated> = None;
    let (mut runs, mut ups, mut frozen_any) = (0, 0, false);
    for _ in 0..MAX_ATTEMPTS {
        let (mut out, rep, out_vertices) = run.once((max_error / k / scale).powi(2), &keep, progress);
        runs += out.report.runs;
        let (m, [over_in, over_out], out_tris) = measure(&out.mesh, max_error);
        out.set_error(m, diagonal);
        let ratio = if max_error > 0.0 { m.upper / max_error } else { f64::INFINITY };
        if m.upper <= max_error {
            let try_further = ups < 2 && !frozen_any && ratio < 0.85 && out.report.stop == Stop::ErrorBound;
            ups += 1;
            kept = Some(out);
            if !try_further {
                break;
            }
            k *= ratio.max(0.25) / 0.95;
            continue;
        }
        if kept.is_some() {
            break;
        }
        let mut bad: Vec<u32> = over_in.iter().flat_map(|&t| tris[t as usize]).map(|v| rep[v as usize]).collect();
        bad.extend(over_out.iter().flat_map(|&t| out_tris[t as usize]).map(|v| out_vertices[v as usize]));
        bad.sort_unstable();
        bad.dedup();
        keep.resize(n, false);
        let mut grew = false;
        for (v, k) in keep.iter_mut().enumerate() {
            if !*k && bad.binary_search(&rep[v]).is_ok() {
                *k = true;
                grew = true;
            }
        }
        frozen_any |= grew;
        if !grew {
            k *= ratio.clamp(1.25, 16.0) * 1.1;
        }
    }
    match kept {
        Some(mut out) => {
            out.report.runs = runs;
            Ok(out)
        }
        None => Err(runs),
    }
}

/// The first quadric threshold of an error-bounded run is the bound over this (the measured
/// Hausdorff distance is 2.8 to 4 times the quadric error on the test meshes).
const CALIBRATION: f64 = 4.0;

/// Collapse runs of an error-bounded decimation before giving up (and returning the input).
const MAX_ATTEMPTS: usize = 8;

/// What one collapse run needs.
struct Run<'a> {
    mesh: &'a Mesh,
    unit: &'a [DVec3],
    tris: &'a [[u32; 3]],
    opts: &'a DecimateOptions,
    repair: bool,
    scale: f64,
    centre: DVec3,
    input_faces: usize,
    diagonal: f64,
}

impl Run<'_> {
    /// Collapses under the quadric threshold `max_cost` (unit frame) to the face target, re-pairs
    /// quads, and builds the output mesh. Quads: the triangle target is twice the face target, and
    /// while pairing leaves more faces than the target, the run is redone with a triangle target
    /// lowered in proportion (it ends, at the latest, once the triangle target is the face
    /// target, since faces never outnumber triangles).
    /// Also returns, for each input vertex, the input vertex it went into, and for each output
    /// vertex its input number.
    fn once(&self, max_cost: f64, keep: &[bool], progress: &mut dyn FnMut(usize)) -> (Decimated, Vec<u32>, Vec<u32>) {
        let target = self.opts.target_faces;
        let mut target_tris = target.map_or(0, |t| if self.repair { t.saturating_mul(2) } else { t });
        let mut runs = 0;
        let (out, faces) = loop {
            runs += 1;
            let out =
                collapse_coherent(self.unit, self.tris, self.opts.lock_border, keep, target_tris, max_cost, progress);
            let faces =
                if self.repair { quads::pair(&out.pos, &out.tris) } else { FaceList::from_triangles(&out.tris) };
            match target {
                Some(t) if faces.len() > t && out.stop == Stop::TargetReached && target_tris > t => {
                    target_tris = (target_tris * t / faces.len()).clamp(t, target_tris - 1);
                }
                _ => break (out, faces),
            }
        };
        // Renumber the surviving vertices in input order.
        let pos = &self.mesh.vertices.positions;
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
        let src = &self.mesh.vertices;
        let vertices = PointCloud {
            positions: kept.iter().map(|&v| out.pos[v] * self.scale + self.centre).collect(),
            normals: src.normals.as_ref().map(|n| kept.iter().map(|&v| n[v]).collect()),
            colors: src.colors.as_ref().map(|c| kept.iter().map(|&v| c[v]).collect()),
            intensities: src.intensities.as_ref().map(|c| kept.iter().map(|&v| c[v]).collect()),
        };
        let mut renumbered = FaceList::with_capacity(faces.len(), faces.corner_count());
        for f in faces.iter() {
            renumbered.push_iter(f.iter().map(|&v| map[v as usize]));
        }
        let report = DecimateReport {
            input_faces: self.input_faces,
            output_faces: renumbered.len(),
            output_triangles: out.tris.len(),
            output_vertices: kept.len(),
            error: None,
            relative_error: None,
            error_found: None,
            quadric_error: out.max_cost.sqrt() * self.scale,
            diagonal: self.diagonal,
            collapses: out.collapses,
            passes: out.passes,
            runs,
            frozen_vertices: out.frozen,
            stop: out.stop,
            quads: self.repair,
        };
        let out_vertices = kept.iter().map(|&v| v as u32).collect();
        (Decimated { mesh: Mesh { vertices, faces: renumbered }, report }, out.rep, out_vertices)
    }
}

impl Decimated {
    fn set_error(&mut self, m: crate::metrics::Certified, diagonal: f64) {
        let r = &mut self.report;
        r.error = Some(m.upper);
        r.error_found = Some(m.lower);
        r.relative_error = Some(if diagonal > 0.0 { m.upper / diagonal } else { 0.0 });
    }
}

/// [`collapse::run`] on a spatially coherent numbering (Morton order of the positions, ties by
/// index; triangles by their lowest vertex): the collapse loops read neighbours' data, which then
/// sit nearby in memory. The result is mapped back to the input numbering.
fn collapse_coherent(
    unit: &[DVec3],
    tris: &[[u32; 3]],
    lock_border: bool,
    keep: &[bool],
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
    let local: Vec<DVec3> = perm.par_iter().map(|&o| unit[o as usize]).collect();
    // Triangles by their lowest vertex (a counting sort; input order within a vertex).
    let lowest = |t: &[u32; 3]| inv[t[0] as usize].min(inv[t[1] as usize]).min(inv[t[2] as usize]) as usize;
    let mut start = vec![0u32; unit.len() + 1];
    for t in tris {
        start[lowest(t) + 1] += 1;
    }
    for i in 0..unit.len() {
        start[i + 1] += start[i];
    }
    let mut local_tris = vec![[0u32; 3]; tris.len()];
    for t in tris {
        let slot = &mut start[lowest(t)];
        local_tris[*slot as usize] = t.map(|v| inv[v as usize]);
        *slot += 1;
    }
    let local_keep: Vec<bool> =
        if keep.is_empty() { Vec::new() } else { perm.iter().map(|&o| keep[o as usize]).collect() };
    let mut out = collapse::run(local, &local_tris, lock_border, &local_keep, target, max_cost, progress);
    for t in &mut out.tris {
        *t = t.map(|v| perm[v as usize]);
    }
    out.pos = inv.par_iter().map(|&n| out.pos[n as usize]).collect();
    out.rep = inv.par_iter().map(|&n| perm[out.rep[n as usize] as usize]).collect();
    out
}
