//! `distance`: each point's unsigned distance to a mesh's surface, GIL released.

use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays;
use crate::meshes::{self, MeshArgs};

/// The distance from every row of `points` (float64, (N, 3), finite) to the nearest point of the
/// mesh's faces (quads split along their shorter diagonal), with
/// `octowrap_decimate::metrics::point_distances`.
#[pyfunction]
#[allow(clippy::needless_pass_by_value)] // pyo3 hands over extracted arguments by value
pub fn distance<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    mesh: MeshArgs<'py>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let points = arrays::positions(points, "points")?;
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(PyValueError::new_err(format!("points must be finite; row {i} is {:?}", points[i].to_array())));
    }
    let mesh = meshes::sound_mesh(&mesh)?;
    let d = py.detach(|| octowrap_decimate::metrics::point_distances(&points, &mesh));
    Ok(Array1::from_vec(d).into_pyarray(py))
}
