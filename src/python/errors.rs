//! The one place core errors become Python exceptions, by kind (never by
//! message): the caller's input and device limits are ValueError (the
//! caller can change them), GPU failures RuntimeError.

use crate::error::Error;
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pub fn to_py(e: Error) -> PyErr {
    match e {
        Error::InvalidInput(m) | Error::DeviceLimit(m) => PyValueError::new_err(m),
        Error::Gpu(m) => PyRuntimeError::new_err(m),
        Error::OutOfMemory(m) => PyMemoryError::new_err(m),
        Error::Interrupted => PyKeyboardInterrupt::new_err("rendering was interrupted"),
    }
}

/// The same, with `context` before the message (e.g. which argument).
pub fn to_py_in(context: &str, e: Error) -> PyErr {
    to_py(match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{context}: {m}")),
        Error::DeviceLimit(m) => Error::DeviceLimit(format!("{context}: {m}")),
        Error::Gpu(m) => Error::Gpu(format!("{context}: {m}")),
        other => other,
    })
}

/// Runs `work` with the GIL released. `work` gets a `stop` check that looks
/// for Python signals (Ctrl-C) by taking the GIL back for a moment; when it
/// says stop, the signal handler's exception (KeyboardInterrupt) is raised.
/// A panic inside becomes RuntimeError instead of reaching Python as a
/// PanicException (a BaseException that `except Exception` misses).
pub fn run_released<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&mut dyn FnMut() -> bool) -> Result<T, Error> + Send,
) -> PyResult<T> {
    let mut raised: Option<PyErr> = None;
    let outcome = py.detach(|| {
        let mut stop = || {
            Python::attach(|py| match py.check_signals() {
                Ok(()) => false,
                Err(e) => {
                    raised = Some(e);
                    true
                }
            })
        };
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&mut stop)))
    });
    match outcome {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(Error::Interrupted)) => Err(raised.unwrap_or_else(|| to_py(Error::Interrupted))),
        Ok(Err(e)) => Err(to_py(e)),
        Err(panic) => Err(internal_error(panic)),
    }
}

/// Runs `f` (holding the GIL); a panic becomes RuntimeError.
pub fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|panic| Err(internal_error(panic)))
}

fn internal_error(panic: Box<dyn std::any::Any + Send>) -> PyErr {
    let what = panic
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| panic.downcast_ref::<&str>().copied())
        .unwrap_or("unknown panic");
    PyRuntimeError::new_err(format!(
        "internal error in pyvr's engine ({what}); the renderer may be unusable: please report this"
    ))
}
