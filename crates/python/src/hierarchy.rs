//! A multiresolution hierarchy held by Python: levels as numpy arrays, saving as MRQ.

use std::path::PathBuf;

use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use octowrap_format::{EncodeOptions, Quantization};
use octowrap_mesh::{FaceOrigin, Hierarchy, Level};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;

use crate::{arrays, errors};

/// One level for Python: positions, face offsets, face indices, the common face size, parent
/// face per face (`-1`: created), quadrant per face (`-1`: created), and how it was made.
pub type LevelTuple<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Option<usize>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i8>>,
    Option<&'static str>,
);

/// `level`'s arrays, each made by one copy.
pub fn level_tuple<'py>(py: Python<'py>, level: &Level, kind: Option<&'static str>) -> LevelTuple<'py> {
    let (offsets, indices, k) = arrays::faces_out(py, &level.mesh.faces);
    let (parent, quadrant): (Vec<i64>, Vec<i8>) = level
        .origins
        .iter()
        .map(|o| match *o {
            FaceOrigin::Subface { parent, quadrant } => (i64::from(parent), quadrant.0 as i8),
            FaceOrigin::Created => (-1, -1),
        })
        .unzip();
    (
        arrays::positions_out(py, level.mesh.vertices.positions.clone()),
        offsets,
        indices,
        k,
        Array1::from_vec(parent).into_pyarray(py),
        Array1::from_vec(quadrant).into_pyarray(py),
        kind,
    )
}

/// A hierarchy: from `reconstruct` (with each level's kind) or from an MRQ file.
#[pyclass(frozen, module = "octowrap._octowrap")]
pub struct RawHierarchy {
    /// The levels.
    pub hierarchy: Hierarchy,
    /// Per level: `root`, `wrapped` or `subdivided` (reconstructions only).
    pub kinds: Vec<Option<&'static str>>,
}

impl RawHierarchy {
    fn get(&self, k: usize) -> PyResult<&Level> {
        self.hierarchy.levels.get(k).ok_or_else(|| {
            PyIndexError::new_err(format!(
                "level {k}: the hierarchy has levels 0 to {}",
                self.hierarchy.levels.len() - 1
            ))
        })
    }
}

#[pymethods]
impl RawHierarchy {
    fn __len__(&self) -> usize {
        self.hierarchy.levels.len()
    }

    /// Level `k`'s arrays (see [`LevelTuple`]).
    fn level<'py>(&self, py: Python<'py>, k: usize) -> PyResult<LevelTuple<'py>> {
        Ok(level_tuple(py, self.get(k)?, self.kinds.get(k).copied().flatten()))
    }

    /// The octree root cube `(min, max)`, when the hierarchy came from an octree.
    #[getter]
    fn cube(&self) -> Option<([f64; 3], [f64; 3])> {
        self.hierarchy.cube.map(|c| (c.min.to_array(), c.max.to_array()))
    }

    /// Writes the hierarchy as MRQ, as `octowrap reconstruct -o PATH.mrq` does: the vertices
    /// placed on their prediction lines (unless `keep_positions`), then encoded.
    #[pyo3(signature = (path, bits=None, step=None, exact=false, zstd_level=19, units=String::new(), source=String::new(), keep_positions=false))]
    #[allow(clippy::too_many_arguments, clippy::needless_pass_by_value)]
    fn save(
        &self,
        py: Python<'_>,
        path: PathBuf,
        bits: Option<u32>,
        step: Option<f64>,
        exact: bool,
        zstd_level: i32,
        units: String,
        source: String,
        keep_positions: bool,
    ) -> PyResult<()> {
        // The options `octowrap reconstruct -o x.mrq` takes for the same choices: a grid of a
        // 64th of the finest voxel unless bits, step or exact says otherwise, zstd level 19, the generator named.
        let quantization = match (bits, step, exact) {
            (Some(b), None, false) => Quantization::Bits(b),
            (None, Some(s), false) => Quantization::Step(s),
            (None, None, true) => Quantization::Exact,
            (None, None, false) => Quantization::Bits(octowrap_format::reconstruction_grid_bits(
                self.hierarchy.levels.len().saturating_sub(1),
            )),
            _ => return Err(PyValueError::new_err("give at most one of bits, step and exact")),
        };
        if !(1..=22).contains(&zstd_level) {
            return Err(PyValueError::new_err(format!("zstd_level must lie in 1..=22, not {zstd_level}")));
        }
        let mut opts = EncodeOptions::with_quantization(quantization);
        opts.zstd_level = zstd_level;
        opts.metadata.units = units;
        opts.metadata.source = source;
        opts.metadata.generator = format!("octowrap {}", env!("CARGO_PKG_VERSION"));
        let h = &self.hierarchy;
        let written = py.detach(|| {
            if keep_positions {
                octowrap_format::write_path(&path, h, &opts)
            } else {
                let mut placed = h.clone();
                octowrap_format::place_on_prediction_lines(&mut placed, &opts)?;
                octowrap_format::write_path(&path, &placed, &opts)
            }
        });
        written.map_err(|e| errors::encode_error(&e, &path))
    }
}
