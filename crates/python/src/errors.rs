//! Library errors as Python exceptions, with the command line's messages.

use std::path::Path;

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    _octowrap,
    FormatError,
    PyValueError,
    "A file octowrap cannot read: it breaks its format's rules, uses a feature octowrap does not \
     read, or declares more than its size or the limits justify. The message names the file and \
     where in it."
);

/// An `OSError` carrying `errno` (so Python picks `FileNotFoundError`, `PermissionError`, ...),
/// the message and the path.
fn os_error(err: Option<&std::io::Error>, message: String, path: &Path) -> PyErr {
    let errno = err.and_then(std::io::Error::raw_os_error).unwrap_or(0);
    PyOSError::new_err((errno, message, path.display().to_string()))
}

/// A reader's or writer's error. `reading` picks the class of the non-I/O errors: a file that
/// cannot be read is a [`FormatError`]; a mesh or path that cannot be written is a `ValueError`.
pub fn io_error(e: &octowrap_io::Error, path: &Path, reading: bool) -> PyErr {
    let message = e.to_string();
    match e.kind {
        octowrap_io::ErrorKind::Io => {
            let source = e.source.as_deref().and_then(|s| s.downcast_ref::<std::io::Error>());
            os_error(source, message, path)
        }
        _ if reading => FormatError::new_err(message),
        _ => PyValueError::new_err(message),
    }
}

/// An MRQ decoding error, worded as `octowrap info` / `extract` word it ("reading PATH: ...").
pub fn decode_error(e: &octowrap_format::DecodeError, path: &Path) -> PyErr {
    let message = format!("reading {}: {e}", path.display());
    match e {
        octowrap_format::DecodeError::Io(io) => os_error(Some(io), message, path),
        _ => FormatError::new_err(message),
    }
}

/// An MRQ encoding error, worded as `octowrap reconstruct -o x.mrq` words it ("writing PATH: ...").
pub fn encode_error(e: &octowrap_format::EncodeError, path: &Path) -> PyErr {
    let message = format!("writing {}: {e}", path.display());
    match e {
        octowrap_format::EncodeError::Io(io) => os_error(Some(io), message, path),
        _ => PyValueError::new_err(message),
    }
}
