//! `validate`: the command line's checks on arrays, reported in its JSON form.

use octowrap_mesh::{Mesh, PointCloud};
use octowrap_validate::{FileResult, Outcome, Requirement, ValidateOptions, validate_mesh};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays;

/// Checks a mesh given as arrays. Returns one file entry of `octowrap validate --format json`
/// (the library's `FileResult`, serialized by serde) as JSON text; the Python side parses it.
#[pyfunction]
#[pyo3(signature = (vertices, faces, require, weld=false, self_intersections=false, max_elements=100))]
#[allow(clippy::needless_pass_by_value)]
pub fn validate(
    py: Python<'_>,
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    require: Vec<String>,
    weld: bool,
    self_intersections: bool,
    max_elements: usize,
) -> PyResult<String> {
    let required = require
        .iter()
        .map(|name| {
            Requirement::from_name(name).ok_or_else(|| {
                let known: Vec<_> = Requirement::ALL.iter().map(|r| r.name()).collect();
                PyValueError::new_err(format!("unknown requirement '{name}'; known: {}", known.join(", ")))
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let mesh = Mesh {
        vertices: PointCloud::from_positions(arrays::positions(vertices, "vertices")?),
        faces: arrays::faces(faces, "faces")?,
    };
    let mut o = ValidateOptions::default();
    o.max_elements = max_elements;
    o.weld = weld;
    o.self_intersections = self_intersections || required.contains(&Requirement::IntersectionFree);
    let result = py.detach(|| {
        let report = validate_mesh(&mesh, &o);
        FileResult::new("<arrays>".to_owned(), Outcome::Mesh(report), &required)
    });
    serde_json::to_string(&result).map_err(|e| PyValueError::new_err(e.to_string()))
}
