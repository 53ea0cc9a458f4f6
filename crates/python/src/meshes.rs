//! `read` and `write`: point clouds and meshes in every format `octowrap_io` handles.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use octowrap_io::{Format, ReadOptions, WriteOptions};
use octowrap_mesh::{Mesh, PointCloud};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::{arrays, errors};

/// Reads a point cloud or mesh (format from the content, else the extension), GIL released.
#[pyfunction]
#[allow(clippy::needless_pass_by_value)] // pyo3 hands over extracted arguments by value
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<(MeshTuple<'_>, &'static str)> {
    let read = py.detach(|| octowrap_io::read_path_detected(&path, &ReadOptions::default()));
    let (format, mesh) = read.map_err(|e| errors::io_error(&e, &path, true))?;
    Ok((mesh_out(py, mesh), format.name()))
}

/// A mesh handed to Python: positions, normals, colours, intensities, face offsets, face indices
/// and the common face size (see [`arrays::faces_out`]).
pub type MeshTuple<'py> = (
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, PyArray2<f32>>>,
    Option<Bound<'py, PyArray2<u8>>>,
    Option<Bound<'py, PyArray1<f32>>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Option<usize>,
);

/// `mesh` as numpy arrays: the per-vertex vectors are taken over, the faces copied once.
pub fn mesh_out(py: Python<'_>, mesh: Mesh) -> MeshTuple<'_> {
    let Mesh { vertices, faces } = mesh;
    let PointCloud { positions, normals, colors, intensities } = vertices;
    let (offsets, indices, k) = arrays::faces_out(py, &faces);
    (
        arrays::positions_out(py, positions),
        normals.map(|n| arrays::normals_out(py, n)),
        colors.map(|c| arrays::colors_out(py, c)),
        intensities.map(|i| numpy::IntoPyArray::into_pyarray(i, py)),
        offsets,
        indices,
        k,
    )
}

/// A mesh as Python passes it to `decimate` and `export_glb`: vertices, faces, normals, colours
/// (the last two `None` when absent).
pub type MeshArgs<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>);

/// The mesh of `args`, refused unless every face index is in range and every face has 3 or more
/// corners (the command line refuses such input files in the same words).
pub fn sound_mesh(args: &MeshArgs<'_>) -> PyResult<Mesh> {
    let (vertices, faces, normals, colors) = args;
    let mesh = mesh_from(vertices, "vertices", Some(faces), Some(normals), Some(colors), None)?;
    if let Err(e) = mesh.check_indices() {
        return Err(PyValueError::new_err(format!("broken input: {e} (octowrap.validate describes every defect)")));
    }
    Ok(mesh)
}

/// A mesh from Python's arrays (each copied once): positions (named `positions_name` in errors), then faces, normals, colours and
/// intensities when given and not `None`, each attribute with one row per position.
pub fn mesh_from(
    positions: &Bound<'_, PyAny>,
    positions_name: &str,
    faces: Option<&Bound<'_, PyAny>>,
    normals: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
    intensities: Option<&Bound<'_, PyAny>>,
) -> PyResult<Mesh> {
    let mut cloud = PointCloud::from_positions(arrays::positions(positions, positions_name)?);
    let n = cloud.len();
    let same_length = |name: &str, len: usize| {
        if len == n {
            Ok(())
        } else {
            Err(PyValueError::new_err(format!("{name} has {len} rows, but there are {n} {positions_name}")))
        }
    };
    if let Some(v) = normals.filter(|v| !v.is_none()) {
        let v = arrays::normals(v, "normals")?;
        same_length("normals", v.len())?;
        cloud.normals = Some(v);
    }
    if let Some(v) = colors.filter(|v| !v.is_none()) {
        let v = arrays::colors(v, "colors")?;
        same_length("colors", v.len())?;
        cloud.colors = Some(v);
    }
    if let Some(v) = intensities.filter(|v| !v.is_none()) {
        let v = arrays::intensities(v, "intensities")?;
        same_length("intensities", v.len())?;
        cloud.intensities = Some(v);
    }
    let faces = match faces {
        Some(f) => arrays::faces(f, "faces")?,
        None => octowrap_mesh::FaceList::default(),
    };
    Ok(Mesh { vertices: cloud, faces })
}

/// Writes positions (and faces, normals, colours, intensities when given) in the format the
/// extension names, atomically (a temporary file renamed into place), GIL released.
#[pyfunction]
#[pyo3(signature = (path, positions, faces=None, normals=None, colors=None, intensities=None, ascii=false))]
#[allow(clippy::too_many_arguments, clippy::needless_pass_by_value)]
pub fn write(
    py: Python<'_>,
    path: PathBuf,
    positions: &Bound<'_, PyAny>,
    faces: Option<&Bound<'_, PyAny>>,
    normals: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
    intensities: Option<&Bound<'_, PyAny>>,
    ascii: bool,
) -> PyResult<()> {
    let mesh = mesh_from(positions, "positions", faces, normals, colors, intensities)?;
    let format = Format::from_path(&path).filter(|f| f.writable()).ok_or_else(|| {
        PyValueError::new_err(format!(
            "cannot tell a writable format from the extension of {}; use one of: {}",
            path.display(),
            writable_extensions().join(", ")
        ))
    })?;
    if !mesh.faces.is_empty() && !format.holds_faces() {
        return Err(PyValueError::new_err(format!(
            "{format} cannot hold faces; write .ply, .obj, .off or .stl (or pass a point cloud)"
        )));
    }
    let mut opts = WriteOptions::default();
    opts.ascii = ascii;
    py.detach(|| octowrap_io::write_path(&path, &mesh, &opts)).map_err(|e| errors::io_error(&e, &path, false))
}

/// The extensions of the formats `write` writes.
#[pyfunction]
pub fn writable_extensions() -> Vec<&'static str> {
    Format::ALL.into_iter().filter(|f| f.writable()).map(Format::name).collect()
}
