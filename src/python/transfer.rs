//! Transfer-function tables for `pyvr.transferfunctions`.

use crate::transfer;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// A built-in colormap as a (256, 3) float64 array, or None if unknown.
#[pyfunction]
pub fn colormap_table<'py>(py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
    match transfer::colormap(name) {
        None => Ok(None),
        Some(t) => {
            let flat: Vec<f64> = t.into_iter().flatten().collect();
            Ok(Some(PyArray1::from_vec(py, flat).reshape([256, 3])?))
        }
    }
}

#[pyfunction]
pub fn colormap_names() -> Vec<&'static str> {
    transfer::colormap_names()
}
