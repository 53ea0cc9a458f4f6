//! `export_glb`: a mesh or hierarchy as one binary glTF file, as `octowrap export -o x.glb` writes
//! it, GIL released.

use std::path::PathBuf;

use octowrap_export::{Container, ExportOptions, Levels, Summary};
use octowrap_mesh::Hierarchy;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};
use serde_json::json;

use crate::errors;
use crate::hierarchy::RawHierarchy;
use crate::meshes::{self, MeshArgs};

fn bad(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// `"finest"`, `"all"` or a level number.
fn levels(obj: &Bound<'_, PyAny>) -> PyResult<Levels> {
    let wrong = || {
        bad(format!(
            "levels must be \"finest\", \"all\" or a level number (0 = coarsest), not {}",
            obj.repr().map_or_else(|_| "?".to_owned(), |r| r.to_string())
        ))
    };
    if let Ok(s) = obj.cast::<PyString>() {
        return match &*s.to_cow()? {
            "finest" => Ok(Levels::Finest),
            "all" => Ok(Levels::All),
            _ => Err(wrong()),
        };
    }
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(wrong());
    }
    let k: i64 = obj.extract().map_err(|_| wrong())?;
    usize::try_from(k).map(Levels::One).map_err(|_| wrong())
}

fn summary_json(s: &Summary) -> String {
    let levels: Vec<_> = s
        .levels
        .iter()
        .map(|l| {
            json!({
                "level": l.level,
                "source_faces": l.source_faces,
                "vertices": l.vertices,
                "triangles": l.triangles,
                "u32_indices": l.u32_indices,
                "geometric_error": l.geometric_error,
            })
        })
        .collect();
    json!({
        "levels": levels,
        "screen_coverage": s.screen_coverage,
        "extensions_used": s.extensions_used,
        "extensions_required": s.extensions_required,
        "bytes": s.bytes,
    })
    .to_string()
}

/// Exports a mesh given as arrays ([`MeshArgs`]) or a hierarchy as
/// GLB; the options are `ExportOptions`' fields (`screen_error` in pixels of a 1080-pixel-high
/// view). With `path`, the bytes are also written there (to a temporary file renamed into place).
/// Returns the bytes and the summary as JSON.
#[pyfunction]
#[pyo3(signature = (mesh, hierarchy, levels, quantize, meshopt, crease_angle, with_colors, screen_error, metadata, path))]
#[allow(clippy::too_many_arguments, clippy::needless_pass_by_value, clippy::fn_params_excessive_bools)]
pub fn export_glb<'py>(
    py: Python<'py>,
    mesh: Option<MeshArgs<'py>>,
    hierarchy: Option<Bound<'py, RawHierarchy>>,
    levels: &Bound<'py, PyAny>,
    quantize: bool,
    meshopt: bool,
    crease_angle: Option<f64>,
    with_colors: bool,
    screen_error: f64,
    metadata: Vec<(String, String)>,
    path: Option<PathBuf>,
) -> PyResult<(Bound<'py, PyBytes>, String)> {
    if crease_angle.is_some_and(|a| !(0.0..=180.0).contains(&a)) {
        return Err(bad(format!(
            "the crease angle must be 0 to 180 degrees, not {:?}",
            crease_angle.unwrap_or_default()
        )));
    }
    if !(screen_error.is_finite() && screen_error > 0.0) {
        return Err(bad(format!("the screen error must be a positive number of pixels, not {screen_error:?}")));
    }
    if let Some(p) = &path {
        if Container::from_path(p) != Some(Container::Glb) {
            return Err(bad(format!("export_glb writes binary glTF: {} must end in .glb", p.display())));
        }
    }
    let mut opts = ExportOptions::default();
    opts.levels = self::levels(levels)?;
    opts.quantize = quantize;
    opts.meshopt = meshopt;
    opts.crease_angle_deg = crease_angle;
    opts.colors = with_colors;
    opts.max_screen_error = screen_error / 1080.0;
    opts.metadata = metadata;
    let single;
    let h: &Hierarchy = if let Some(raw) = &hierarchy {
        &raw.get().hierarchy
    } else {
        let mesh = meshes::sound_mesh(mesh.as_ref().ok_or_else(|| bad("give a mesh or a hierarchy"))?)?;
        single = Hierarchy::single(mesh);
        &single
    };
    // The target is checked before the work, as `octowrap export` checks it.
    let file_opts = octowrap_fsutil::WriteOptions::default();
    if let Some(p) = &path {
        octowrap_fsutil::check_output(p, &file_opts).map_err(|e| errors::file_error(&e, p))?;
    }
    let (bytes, summary) = py.detach(|| octowrap_export::to_glb(h, &opts)).map_err(|e| bad(e.to_string()))?;
    if let Some(p) = &path {
        let written = py.detach(|| octowrap_fsutil::write_file(p, &file_opts, |w| w.write_all(&bytes)));
        written.map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| {
            errors::file_error(&e, p)
        })?;
    }
    Ok((PyBytes::new(py, &bytes), summary_json(&summary)))
}
