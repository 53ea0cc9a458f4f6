//! `reconstruct`: points to a hierarchy, in a rayon pool of the requested size, GIL released.

use octowrap_format::Quantization;
use octowrap_recon::{DEEPEST_LEVEL, DecoderGrid, LevelKind, MaxLevel, ReconOptions, SparseMode};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::arrays;
use crate::hierarchy::{FilePlan, RawHierarchy};

fn max_level(obj: &Bound<'_, PyAny>) -> PyResult<MaxLevel> {
    let bad = || {
        PyValueError::new_err(format!(
            "max_level must be \"auto\" or a level from 1 to {DEEPEST_LEVEL}, not {}",
            obj.repr().map_or_else(|_| "?".to_owned(), |r| r.to_string())
        ))
    };
    if let Ok(s) = obj.cast::<PyString>() {
        return if s.to_cow()?.eq_ignore_ascii_case("auto") { Ok(MaxLevel::Auto) } else { Err(bad()) };
    }
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad());
    }
    let n: i64 = obj.extract().map_err(|_| bad())?;
    // Out-of-range numbers go to the library, which words the error as the command line does.
    u32::try_from(n).map(MaxLevel::Level).map_err(|_| bad())
}

/// Reconstructs `points` (float64, (N, 3)); the options are `ReconOptions`' fields, and the MRQ
/// file the hierarchy is built for, as `octowrap reconstruct -o x.mrq` builds it: unless
/// `keep_positions`, every refined vertex is computed on the MRQ decoder's line
/// (`ReconOptions::decoder_lines`) on the grid of `bits` (default: 64 steps per finest voxel);
/// `RawHierarchy::save` then encodes on that grid.
#[pyfunction]
#[pyo3(signature = (points, max_level, relax_passes, relax_from_level, fit_passes, fit_max_faces, min_points, wrap_sparse, region_levels, region_density, bits, keep_positions, threads))]
#[allow(clippy::too_many_arguments, clippy::needless_pass_by_value)]
pub fn reconstruct(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    max_level: &Bound<'_, PyAny>,
    relax_passes: u32,
    relax_from_level: u32,
    fit_passes: u32,
    fit_max_faces: usize,
    min_points: f64,
    wrap_sparse: bool,
    region_levels: u32,
    region_density: f64,
    bits: Option<u32>,
    keep_positions: bool,
    threads: Option<usize>,
) -> PyResult<RawHierarchy> {
    let mut opts = ReconOptions::default();
    opts.max_level = self::max_level(max_level)?;
    opts.relax_passes = relax_passes;
    opts.relax_from_level = relax_from_level;
    opts.fit_passes = fit_passes;
    opts.fit_max_faces = fit_max_faces;
    if !(min_points.is_finite() && min_points > 0.0) {
        return Err(PyValueError::new_err(format!("min_points must be a positive number, not {min_points}")));
    }
    opts.min_median_points = min_points;
    if wrap_sparse {
        opts.sparse = SparseMode::Wrap;
    }
    if wrap_sparse && region_levels > 0 {
        return Err(PyValueError::new_err("wrap_sparse and region_levels exclude each other"));
    }
    opts.region_levels = region_levels;
    if !(region_density.is_finite() && region_density > 0.0) {
        return Err(PyValueError::new_err(format!(
            "the region density must be a positive number of points per cell, not {region_density}"
        )));
    }
    opts.region_density = region_density;
    if let Some(b) = bits.filter(|b| !(1..=octowrap_format::MAX_GRID_BITS).contains(b)) {
        return Err(PyValueError::new_err(format!("bits must lie in 1..={}, not {b}", octowrap_format::MAX_GRID_BITS)));
    }
    if !keep_positions {
        opts.decoder_lines = Some(bits.map_or(DecoderGrid::Finest, DecoderGrid::Bits));
    }
    if threads == Some(0) {
        return Err(PyValueError::new_err("threads must be at least 1 (or None for every core)"));
    }
    let points = arrays::positions(points, "points")?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| PyValueError::new_err(format!("cannot start {threads:?} threads: {e}")))?;
    let run = py.detach(|| pool.install(|| octowrap_recon::reconstruct_with_progress(&points, &opts, &mut |_| {})));
    let r = run.map_err(|e| PyValueError::new_err(e.to_string()))?;
    let kinds = r
        .levels
        .iter()
        .map(|l| {
            Some(match l.kind {
                LevelKind::Root => "root",
                LevelKind::Wrapped => "wrapped",
                LevelKind::Subdivided => "subdivided",
            })
        })
        .collect();
    let file = FilePlan {
        grid: r.line_grid.map(|g| g.quantization()).or(bits.map(Quantization::Bits)),
        on_lines: r.line_grid.is_some(),
        keep_positions,
    };
    Ok(RawHierarchy { hierarchy: r.hierarchy, kinds, file })
}

/// The library's defaults for the options `reconstruct` exposes (for the Python signature's test).
#[pyfunction]
pub fn recon_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let o = ReconOptions::default();
    let d = PyDict::new(py);
    d.set_item("max_level", if o.max_level == MaxLevel::Auto { "auto" } else { "?" })?;
    d.set_item("relax_passes", o.relax_passes)?;
    d.set_item("relax_from_level", o.relax_from_level)?;
    d.set_item("fit_passes", o.fit_passes)?;
    d.set_item("fit_max_faces", o.fit_max_faces)?;
    d.set_item("min_points", o.min_median_points)?;
    d.set_item("wrap_sparse", o.sparse == SparseMode::Wrap)?;
    d.set_item("region_levels", o.region_levels)?;
    d.set_item("region_density", o.region_density)?;
    Ok(d)
}
