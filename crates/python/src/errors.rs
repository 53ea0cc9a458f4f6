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

/// An error of the operating system writing `path`, worded as the writers word it
/// ("PATH: i/o error: ..."); errors made up by the library (a missing folder) get the `errno` of
/// their kind, so Python still picks `FileNotFoundError`, `PermissionError`, ...
pub fn file_error(e: &std::io::Error, path: &Path) -> PyErr {
    let errno = e.raw_os_error().unwrap_or(match e.kind() {
        std::io::ErrorKind::NotFound => 2,
        std::io::ErrorKind::PermissionDenied => 13,
        std::io::ErrorKind::AlreadyExists => 17,
        _ => 0,
    });
    PyOSError::new_err((errno, format!("{}: i/o error: {e}", path.display()), path.display().to_string()))
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
