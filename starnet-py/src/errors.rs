//! Rust errors as Python exceptions, carrying the library's message (which names the file, line
//! or key): a missing file is `FileNotFoundError`, anything else [`StarnetError`].

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError};
use pyo3::prelude::*;
use std::error::Error;

create_exception!(
    _starnet,
    StarnetError,
    PyException,
    "An error of the starnet library: bad input (a malformed file, label, config key or checkpoint) or a failed operation; the message names the file, line or key."
);

/// `e` as the Python exception a caller expects.
pub fn to_py(e: impl Error + 'static) -> PyErr {
    let first: &(dyn Error + 'static) = &e;
    let not_found = std::iter::successors(Some(first), |e: &&(dyn Error + 'static)| (*e).source())
        .filter_map(|e| e.downcast_ref::<std::io::Error>())
        .any(|io| io.kind() == std::io::ErrorKind::NotFound);
    if not_found {
        PyFileNotFoundError::new_err(e.to_string())
    } else {
        StarnetError::new_err(e.to_string())
    }
}
