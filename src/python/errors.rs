//! The one place core errors become Python exceptions, by kind (never by
//! message): the caller's input and device limits are ValueError (the
//! caller can change them), GPU failures RuntimeError.

use crate::error::Error;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::PyErr;

pub fn to_py(e: Error) -> PyErr {
    match e {
        Error::InvalidInput(m) | Error::DeviceLimit(m) => PyValueError::new_err(m),
        Error::Gpu(m) => PyRuntimeError::new_err(m),
    }
}

/// The same, with `context` before the message (e.g. which argument).
pub fn to_py_in(context: &str, e: Error) -> PyErr {
    to_py(match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{context}: {m}")),
        Error::DeviceLimit(m) => Error::DeviceLimit(format!("{context}: {m}")),
        Error::Gpu(m) => Error::Gpu(format!("{context}: {m}")),
    })
}
