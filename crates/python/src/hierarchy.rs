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

/// The MRQ file a reconstruction was built for: what `save` does when not told otherwise, so that
/// `reconstruct(...).save(path)` writes the bytes `octowrap reconstruct -o PATH.mrq` writes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilePlan {
    /// The grid: the decoder lines' grid, or the `bits` asked for; `None`: 64 steps per finest
    /// voxel ([`octowrap_format::reconstruction_grid_bits`]).
    pub grid: Option<Quantization>,
    /// The levels were computed on the decoder's lines of `grid` (nothing to place).
    pub on_lines: bool,
    /// The positions are written as they are (`--keep-positions`).
    pub keep_positions: bool,
}

/// A hierarchy: from `reconstruct` (with each level's kind) or from an MRQ file.
#[pyclass(frozen, module = "octowrap._octowrap")]
pub struct RawHierarchy {
    /// The levels.
    pub hierarchy: Hierarchy,
    /// Per level: `root`, `wrapped` or `subdivided` (reconstructions only).
    pub kinds: Vec<Option<&'static str>>,
    /// The file `save` writes by default.
    pub file: FilePlan,
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

    /// Writes the hierarchy as MRQ, as `octowrap reconstruct -o PATH.mrq` does with the options
    /// `reconstruct` was given ([`FilePlan`]): on the decoder lines' grid, nothing moved; with
    /// `keep_positions` (here, or given to `reconstruct`) the positions as they are; on another
    /// grid (`bits`, `step`, `exact` unlike the reconstruction's) the vertices first slide onto
    /// their prediction lines, as the command line does with `--step`.
    #[pyo3(signature = (path, bits=None, step=None, exact=false, zstd_level=19, units=String::new(), source=String::new(), keep_positions=None))]
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
        keep_positions: Option<bool>,
    ) -> PyResult<()> {
        let plan = self.file;
        let quantization = match (bits, step, exact) {
            (Some(b), None, false) => Quantization::Bits(b),
            (None, Some(s), false) => Quantization::Step(s),
            (None, None, true) => Quantization::Exact,
            (None, None, false) => plan.grid.unwrap_or(Quantization::Bits(octowrap_format::reconstruction_grid_bits(
                self.hierarchy.levels.len().saturating_sub(1),
            ))),
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
        let keep = keep_positions.unwrap_or(plan.keep_positions);
        let placed_already = plan.on_lines && plan.grid == Some(quantization);
        let h = &self.hierarchy;
        let written = py.detach(|| {
            if keep || placed_already {
                octowrap_decimate::chunks::write_measured(&path, h, &opts)
            } else {
                let mut placed = h.clone();
                octowrap_format::place_on_prediction_lines(&mut placed, &opts)?;
                octowrap_decimate::chunks::write_measured(&path, &placed, &opts)
            }
        });
        written.map_err(|e| errors::encode_error(&e, &path))
    }
}
