//! `decimate`: error-bounded decimation of a mesh, and adaptive cuts through a hierarchy, chosen
//! and reported as `octowrap decimate` does, GIL released.

use std::borrow::Cow;
use std::time::Instant;

use octowrap_decimate::metrics::{Sampling, distance};
use octowrap_decimate::{Camera, CutCriterion, DecimateOptions, ErrorBound, QuadMode};
use octowrap_mesh::Mesh;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::{Map, Value, json};

use crate::hierarchy::RawHierarchy;
use crate::meshes::{self, MeshArgs, MeshTuple};

fn bad(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// Decimates a mesh given as arrays ([`MeshArgs`]), or a hierarchy:
/// cut through its levels with `max_error` alone or `view`, else its finest level decimated.
/// `max_error` is a length, or a fraction of the bounding-box diagonal when `max_error_relative`;
/// `view` is the camera's JSON; `quads` is `auto`, `quads` or `triangles`. Returns the mesh and
/// the report `octowrap decimate --json` prints (without the file names) as JSON.
#[pyfunction]
#[pyo3(signature = (mesh, hierarchy, target_faces, ratio, max_error, max_error_relative, view, lock_border, quads, measure))]
#[allow(clippy::too_many_arguments, clippy::needless_pass_by_value, clippy::fn_params_excessive_bools)]
pub fn decimate<'py>(
    py: Python<'py>,
    mesh: Option<MeshArgs<'py>>,
    hierarchy: Option<Bound<'py, RawHierarchy>>,
    target_faces: Option<usize>,
    ratio: Option<f64>,
    max_error: Option<f64>,
    max_error_relative: bool,
    view: Option<String>,
    lock_border: bool,
    quads: &str,
    measure: bool,
) -> PyResult<(MeshTuple<'py>, String)> {
    if target_faces == Some(0) {
        return Err(bad("target_faces must be 1 face or more (a mesh of 0 faces is no mesh)"));
    }
    if ratio.is_some_and(|r| !(r > 0.0 && r <= 1.0)) {
        return Err(bad(format!("ratio must be in (0, 1], not {:?}", ratio.unwrap_or_default())));
    }
    if max_error.is_some_and(|e| !(e >= 0.0 && e.is_finite())) {
        return Err(bad("max_error must be zero or positive"));
    }
    if target_faces.is_none() && ratio.is_none() && max_error.is_none() && view.is_none() {
        return Err(bad("give a target: target_faces, ratio, max_error or view"));
    }
    if view.is_some() && (target_faces.is_some() || ratio.is_some() || max_error.is_some()) {
        return Err(bad("view cuts for a camera: it excludes target_faces, ratio and max_error"));
    }
    let quad_mode = match quads {
        "auto" => QuadMode::Auto,
        "quads" => QuadMode::Quads,
        "triangles" => QuadMode::Triangles,
        other => return Err(bad(format!("quads must be \"auto\", \"quads\" or \"triangles\", not {other:?}"))),
    };
    let hierarchy = hierarchy.as_ref().map(|h| &h.get().hierarchy);
    let camera = match (&view, hierarchy) {
        (Some(_), None) => {
            return Err(bad("view cuts a hierarchy; a mesh is decimated with ratio, target_faces or max_error"));
        }
        (Some(text), Some(_)) => Some(Camera::from_json(text).map_err(|e| bad(e.to_string()))?),
        (None, _) => None,
    };
    let input: Cow<'_, Mesh> = if let Some(h) = hierarchy {
        Cow::Borrowed(&h.levels.last().ok_or_else(|| bad("the hierarchy holds no levels"))?.mesh)
    } else {
        Cow::Owned(meshes::sound_mesh(mesh.as_ref().ok_or_else(|| bad("give a mesh or a hierarchy"))?)?)
    };
    if input.faces.is_empty() {
        return Err(bad("the mesh has no faces: decimation needs a mesh, not a point cloud"));
    }
    let input = &*input;
    let bound = max_error.map(|e| if max_error_relative { ErrorBound::Relative(e) } else { ErrorBound::Absolute(e) });
    // As the command line decides: a hierarchy is cut for a camera, or for an error bound without
    // a face target; anything else is decimated (a hierarchy's finest level).
    let cut = match (hierarchy, camera, bound) {
        (Some(h), Some(c), _) => Some((h, CutCriterion::View(c))),
        (Some(h), None, Some(b)) if target_faces.is_none() && ratio.is_none() => {
            let e = match b {
                ErrorBound::Absolute(e) => e,
                ErrorBound::Relative(r) => r * input.vertices.bounds().diagonal(),
            };
            Some((h, CutCriterion::MaxError(e)))
        }
        _ => None,
    };
    if cut.is_some() && (lock_border || quad_mode != QuadMode::Auto) {
        let option = if lock_border { "lock_border" } else { "quads" };
        return Err(bad(format!(
            "{option} steers edge collapse, but a hierarchy with {} is cut through its levels, which keeps every \
             boundary and face kind of the hierarchy: drop {option}, or add target_faces or ratio to decimate",
            if view.is_some() { "view" } else { "max_error alone" }
        )));
    }
    let run = py.detach(|| -> Result<(Mesh, Value), octowrap_decimate::Error> {
        let start = Instant::now();
        let mut report = Map::new();
        let mesh = if let Some((h, criterion)) = &cut {
            let out = octowrap_decimate::cut(h, criterion)?;
            report.insert("mode".into(), json!("cut"));
            report.insert("cut".into(), json!(out.report));
            out.mesh
        } else {
            let mut opts = DecimateOptions::default();
            opts.target_faces =
                target_faces.or_else(|| ratio.map(|r| ((input.faces.len() as f64 * r).round() as usize).max(1)));
            opts.max_error = bound;
            opts.lock_border = lock_border;
            opts.measure = measure;
            opts.quads = quad_mode;
            let out = octowrap_decimate::decimate(input, &opts)?;
            report.insert("mode".into(), json!("decimate"));
            report.insert("decimate".into(), json!(out.report));
            out.mesh
        };
        report.insert("input_faces".into(), json!(input.faces.len()));
        report.insert("output_faces".into(), json!(mesh.faces.len()));
        report.insert("output_vertices".into(), json!(mesh.vertex_count()));
        report.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
        if measure {
            report.insert("measured".into(), json!(distance(input, &mesh, &Sampling::default())));
        }
        Ok((mesh, Value::Object(report)))
    });
    let (mesh, report) = run.map_err(|e| bad(e.to_string()))?;
    Ok((meshes::mesh_out(py, mesh), report.to_string()))
}

/// Cuts a chunked MRQ file (`raw`, format version 5) through whole chunks, as `octowrap decimate
/// FILE.mrq --view` or `--max-error` does by default: the chunks chosen by their geometric errors
/// for the camera `view` (JSON) or the error bound, read alone, stitched crack-free. Returns the
/// mesh and the command's report (without the file names) as JSON.
#[pyfunction]
#[pyo3(signature = (raw, max_error, max_error_relative, view, measure))]
#[allow(clippy::needless_pass_by_value)]
pub fn cut_chunks<'py>(
    py: Python<'py>,
    raw: Bound<'py, crate::mrq::RawMrq>,
    max_error: Option<f64>,
    max_error_relative: bool,
    view: Option<String>,
    measure: bool,
) -> PyResult<(MeshTuple<'py>, String)> {
    use octowrap_decimate::chunks::{ChunkCriterion, cut_chunks};
    let raw = raw.get();
    let path = raw.path().to_path_buf();
    if raw.version() < 5 {
        return Err(bad(format!(
            "cut=\"chunks\" needs a chunked MRQ file (format version 5); {} is version {}",
            path.display(),
            raw.version()
        )));
    }
    let criterion = match (view, max_error) {
        (Some(text), None) => ChunkCriterion::View(Camera::from_json(&text).map_err(|e| bad(e.to_string()))?),
        (None, Some(e)) if e >= 0.0 && e.is_finite() => {
            ChunkCriterion::MaxError(if max_error_relative { ErrorBound::Relative(e) } else { ErrorBound::Absolute(e) })
        }
        (None, Some(_)) => return Err(bad("max_error must be zero or positive")),
        _ => return Err(bad("a chunk cut takes view or max_error, one of them")),
    };
    let run = py.detach(|| -> Result<(Mesh, Value), String> {
        let start = Instant::now();
        let file = std::fs::File::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let file_bytes = file.metadata().map_or(0, |m| m.len());
        let source = octowrap_format::SeekSource(std::io::BufReader::new(file));
        let mut reader = octowrap_format::ChunkedMrq::open(source, &octowrap_format::Limits::default())
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let cut = cut_chunks(&mut reader, &criterion, file_bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut report = Map::new();
        report.insert("mode".into(), json!("chunk cut"));
        report.insert("input_faces".into(), json!(cut.finest_faces));
        report.insert("output_faces".into(), json!(cut.mesh.faces.len()));
        report.insert("output_vertices".into(), json!(cut.mesh.vertex_count()));
        report.insert("chunk_cut".into(), json!(cut.report));
        report.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
        if measure {
            let h = octowrap_format::read_path(&path, &octowrap_format::DecodeOptions::default())
                .map_err(|e| format!("{}: {e}", path.display()))?
                .hierarchy;
            let finest = &h.levels.last().ok_or("the file holds no levels")?.mesh;
            report.insert("measured".into(), json!(distance(finest, &cut.mesh, &Sampling::default())));
        }
        Ok((cut.mesh, Value::Object(report)))
    });
    let (mesh, report) = run.map_err(bad)?;
    Ok((meshes::mesh_out(py, mesh), report.to_string()))
}
