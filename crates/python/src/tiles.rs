//! `export_tiles`: a hierarchy or mesh as an OGC 3D Tiles 1.1 tileset, as
//! `octowrap export IN -o DIR/tileset.json` writes it, GIL released.

use std::path::PathBuf;

use octowrap_mesh::Hierarchy;
use octowrap_tiles::{Frame, Summary, TilesOptions};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use serde_json::json;

use crate::errors;
use crate::hierarchy::RawHierarchy;
use crate::meshes::{self, MeshArgs};
use crate::mrq::RawMrq;

fn summary_json(s: &Summary) -> String {
    json!({
        "tiles": s.tiles,
        "content_tiles": s.content_tiles,
        "levels": s.levels,
        "bytes": s.bytes,
        "root_error": s.root_error,
        "frame": s.frame,
    })
    .to_string()
}

/// The tiles writer's error: `OSError` (with `errno`) for the operating system, else `ValueError`.
fn tiles_error(e: &octowrap_tiles::Error) -> PyErr {
    match e {
        octowrap_tiles::Error::Io { file, source } => {
            PyOSError::new_err((source.raw_os_error().unwrap_or(0), e.to_string(), file.clone()))
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Writes the tileset `path` (`.../tileset.json`, its folder created when missing; the tiles go
/// under `tiles/` beside it) of one of: a mesh given as arrays ([`MeshArgs`]), a hierarchy, or an
/// MRQ file (decoded whole; its units, source and generator recorded and its CRS, when it has
/// one, georeferencing the tileset, as the command line does). `metadata` pairs follow in the
/// tileset's `extras`. Returns the summary as JSON.
#[pyfunction]
#[pyo3(signature = (path, mesh, hierarchy, mrq, quantize, meshopt, colors, metadata))]
#[allow(clippy::too_many_arguments, clippy::needless_pass_by_value, clippy::fn_params_excessive_bools)]
pub fn export_tiles<'py>(
    py: Python<'py>,
    path: PathBuf,
    mesh: Option<MeshArgs<'py>>,
    hierarchy: Option<Bound<'py, RawHierarchy>>,
    mrq: Option<Bound<'py, RawMrq>>,
    quantize: bool,
    meshopt: bool,
    colors: bool,
    metadata: Vec<(String, String)>,
) -> PyResult<String> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        return Err(PyValueError::new_err(format!(
            "a tileset is a .json file: {} does not end in .json",
            path.display()
        )));
    }
    let mut opts = TilesOptions::default();
    opts.quantize = quantize;
    opts.meshopt = meshopt;
    opts.colors = colors;
    let (h, frame) = if let Some(f) = &mrq {
        let f = f.get();
        let (pairs, crs) = f.tiles_metadata();
        opts.metadata = pairs;
        (f.decode_all(py)?, crs.map_or(Frame::Local, Frame::Crs))
    } else if let Some(raw) = &hierarchy {
        (raw.get().hierarchy.clone(), Frame::Local)
    } else {
        let mesh = mesh.as_ref().ok_or_else(|| PyValueError::new_err("give a mesh, a hierarchy or an MRQ file"))?;
        (Hierarchy::single(meshes::sound_mesh(mesh)?), Frame::Local)
    };
    opts.metadata.extend(metadata);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| errors::file_error(&e, dir))?;
    }
    let written = py.detach(|| octowrap_tiles::write_tileset(&path, h, &frame, &opts));
    Ok(summary_json(&written.map_err(|e| tiles_error(&e))?))
}
