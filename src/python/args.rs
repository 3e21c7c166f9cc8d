//! Numbers from Python, checked the way users need: a bool is not a number
//! (`step_size=True` is a mistake, TypeError), and an integer out of range
//! is a ValueError naming the range (never OverflowError).

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBool;

fn is_bool(v: &Bound<'_, PyAny>) -> bool {
    v.is_instance_of::<PyBool>() || v.get_type().name().map(|n| n == "bool" || n == "bool_").unwrap_or(false)
}

/// A real number (int, float or numpy scalar; not bool, not complex).
pub fn real(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    if is_bool(v) {
        return Err(PyTypeError::new_err(format!("{name} must be a number, got bool")));
    }
    v.extract::<f64>().map_err(|e| {
        if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(v.py()) {
            PyValueError::new_err(format!("{name} is too large for a float: {v}"))
        } else {
            PyTypeError::new_err(format!("{name} must be a real number, got {}", type_name(v)))
        }
    })
}

/// An integer in [low, high] (int or numpy integer; not bool, not float).
pub fn integer(name: &str, v: &Bound<'_, PyAny>, low: i128, high: i128) -> PyResult<i128> {
    if is_bool(v) {
        return Err(PyTypeError::new_err(format!("{name} must be an integer, got bool")));
    }
    let out_of_range = || PyValueError::new_err(format!("{name} must be between {low} and {high}, got {v}"));
    match v.extract::<i128>() {
        Ok(n) if (low..=high).contains(&n) => Ok(n),
        Ok(_) => Err(out_of_range()),
        Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(v.py()) => Err(out_of_range()),
        Err(_) => Err(PyTypeError::new_err(format!("{name} must be an integer, got {}", type_name(v)))),
    }
}

/// True or False (bool or numpy bool).
pub fn flag(name: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
    if !is_bool(v) {
        return Err(PyTypeError::new_err(format!("{name} must be True or False, got {}", type_name(v))));
    }
    v.extract::<bool>()
}

fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

/// How a config field's Python value becomes its Rust value.
pub trait FromArg: Sized {
    fn from_arg(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Self>;
}

impl FromArg for f64 {
    fn from_arg(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
        real(name, v)
    }
}

impl FromArg for bool {
    fn from_arg(name: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
        flag(name, v)
    }
}

/// Step counts: the engine marches at most 2^32 - 1 steps per ray.
impl FromArg for i64 {
    fn from_arg(name: &str, v: &Bound<'_, PyAny>) -> PyResult<i64> {
        // Below 1 stays the config's own error ("must be at least 1").
        match integer(name, v, i128::MIN, i128::MAX)? {
            n if n > u32::MAX as i128 => {
                Err(PyValueError::new_err(format!("{name} must be at most {} (2**32 - 1), got {n}", u32::MAX)))
            }
            n => Ok(n.max(i64::MIN as i128) as i64),
        }
    }
}
