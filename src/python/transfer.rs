//! Transfer-function tables for `pyvr.transferfunctions`.

use crate::transfer;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Piecewise-linear lookup table at `linspace(0, 1, size)` (numpy.interp
/// rules): `scalars` (N,) increasing, `values` (N, C). Returns (size, C) float32.
#[pyfunction]
pub fn lut_from_points<'py>(
    py: Python<'py>,
    scalars: PyReadonlyArray1<'py, f64>,
    values: PyReadonlyArray2<'py, f64>,
    size: usize,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let xs = scalars.as_slice().map_err(|_| PyValueError::new_err("scalars must be contiguous"))?;
    let shape = values.shape().to_vec();
    if xs.is_empty() || shape[0] != xs.len() {
        return Err(PyValueError::new_err(format!(
            "need one value row per control point: {} scalars, values of shape {shape:?}",
            xs.len()
        )));
    }
    if xs.windows(2).any(|w| !(w[1] >= w[0])) {
        return Err(PyValueError::new_err("control-point scalars must be sorted and not NaN"));
    }
    if size == 0 {
        return Err(PyValueError::new_err("lookup table size must be at least 1"));
    }
    let vs = values.as_slice().map_err(|_| PyValueError::new_err("values must be C-contiguous"))?;
    let lut = transfer::lut_from_points(xs, vs, shape[1], size);
    PyArray1::from_vec(py, lut).reshape([size, shape[1]])
}

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
