//! `octowrap._octowrap`: the compiled half of the `octowrap` Python package (the Python half, in
//! `python/octowrap/`, wraps these functions in documented classes).
//!
//! Conventions every function here follows:
//! * Arrays come in as numpy arrays of one stated dtype and shape, C-contiguous; anything else is
//!   a `ValueError` naming the argument, what was expected and what was found (`arrays`). They are
//!   copied once into the library's types while the GIL is held, so the work that follows runs
//!   with the GIL released (`Python::detach`) without Python code mutating its input meanwhile.
//! * Arrays go out as numpy arrays that take over a Rust vector (no copy) or are made by one copy
//!   of a slice the library keeps.
//! * Hierarchies held by Python (`RawHierarchy`) are passed to `decimate` and `export_glb` by
//!   reference, without a copy (`export_tiles` takes one copy: the tiles writer consumes its
//!   hierarchy).
//! * Library errors become Python exceptions with the command line's messages (`errors`):
//!   `OSError` for the operating system, `FormatError` (a `ValueError`) for unreadable or invalid
//!   files, `ValueError` for bad arguments.

mod arrays;
mod decimate;
mod distance;
mod errors;
mod export;
mod hierarchy;
mod meshes;
mod mrq;
mod recon;
mod tiles;
mod validate;

use pyo3::prelude::*;

/// The compiled module.
#[pymodule]
fn _octowrap(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FormatError", m.py().get_type::<errors::FormatError>())?;
    m.add("FORMAT_VERSION", octowrap_format::FORMAT_VERSION)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(meshes::read, m)?)?;
    m.add_function(wrap_pyfunction!(meshes::write, m)?)?;
    m.add_function(wrap_pyfunction!(meshes::writable_extensions, m)?)?;
    m.add_function(wrap_pyfunction!(recon::reconstruct, m)?)?;
    m.add_function(wrap_pyfunction!(recon::recon_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(mrq::open_mrq, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    m.add_function(wrap_pyfunction!(decimate::decimate, m)?)?;
    m.add_function(wrap_pyfunction!(decimate::cut_chunks, m)?)?;
    m.add_function(wrap_pyfunction!(export::export_glb, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::export_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(distance::distance, m)?)?;
    m.add_class::<hierarchy::RawHierarchy>()?;
    m.add_class::<mrq::RawMrq>()?;
    Ok(())
}
