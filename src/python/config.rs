//! `pyvr.config.RenderConfig`: a Rust class with pyvr 0.4.1's fields,
//! defaults, presets, messages and repr.

use crate::config::{OpacityCorrection, Preset, RenderConfig};
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyType;
use std::ffi::CString;

#[pyclass(name = "RenderConfig", module = "pyvr.config", subclass)]
#[derive(Clone)]
pub struct PyRenderConfig {
    pub inner: RenderConfig,
}

pub fn warn_all(py: Python<'_>, messages: &[String]) -> PyResult<()> {
    for m in messages {
        let c = CString::new(m.as_str()).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &c, 2)?;
    }
    Ok(())
}

/// Validates, emitting pyvr's UserWarnings; errors become ValueError.
pub fn checked(py: Python<'_>, c: &RenderConfig) -> PyResult<()> {
    let warnings = c.validate().map_err(|e| PyValueError::new_err(e.0))?;
    warn_all(py, &warnings)
}

fn preset(cls: &Bound<'_, PyType>, p: Preset) -> PyResult<Py<PyAny>> {
    let c = RenderConfig::preset(p);
    Ok(cls
        .call1((c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold))?
        .unbind())
}

#[pymethods]
impl PyRenderConfig {
    #[new]
    #[pyo3(signature = (step_size=0.01, max_steps=500, early_ray_termination=true, opacity_threshold=0.95, reference_step_size=0.01, opacity_correction="exponential"))]
    fn new(
        py: Python<'_>,
        step_size: f64,
        max_steps: i64,
        early_ray_termination: bool,
        opacity_threshold: f64,
        reference_step_size: f64,
        opacity_correction: &str,
    ) -> PyResult<Self> {
        let inner = RenderConfig {
            step_size,
            max_steps,
            early_ray_termination,
            opacity_threshold,
            reference_step_size,
            opacity_correction: OpacityCorrection::parse(opacity_correction)
                .map_err(|e| PyValueError::new_err(e.0))?,
        };
        checked(py, &inner)?;
        Ok(PyRenderConfig { inner })
    }

    #[getter]
    fn step_size(&self) -> f64 {
        self.inner.step_size
    }
    #[setter]
    fn set_step_size(&mut self, v: f64) {
        self.inner.step_size = v;
    }
    #[getter]
    fn max_steps(&self) -> i64 {
        self.inner.max_steps
    }
    #[setter]
    fn set_max_steps(&mut self, v: i64) {
        self.inner.max_steps = v;
    }
    #[getter]
    fn early_ray_termination(&self) -> bool {
        self.inner.early_ray_termination
    }
    #[setter]
    fn set_early_ray_termination(&mut self, v: bool) {
        self.inner.early_ray_termination = v;
    }
    #[getter]
    fn opacity_threshold(&self) -> f64 {
        self.inner.opacity_threshold
    }
    #[setter]
    fn set_opacity_threshold(&mut self, v: f64) {
        self.inner.opacity_threshold = v;
    }
    #[getter]
    fn reference_step_size(&self) -> f64 {
        self.inner.reference_step_size
    }
    #[setter]
    fn set_reference_step_size(&mut self, v: f64) {
        self.inner.reference_step_size = v;
    }
    /// "exponential" (pyvr: 1 - exp(-a*d/ref)) or "power" (VTK: 1 - (1-a)^(d/ref)).
    #[getter]
    fn opacity_correction(&self) -> &'static str {
        self.inner.opacity_correction.name()
    }
    #[setter]
    fn set_opacity_correction(&mut self, v: &str) -> PyResult<()> {
        self.inner.opacity_correction =
            OpacityCorrection::parse(v).map_err(|e| PyValueError::new_err(e.0))?;
        Ok(())
    }

    /// Raises ValueError for invalid values, warns for very large ones.
    fn validate(&self, py: Python<'_>) -> PyResult<()> {
        checked(py, &self.inner)
    }

    #[classmethod]
    fn preview(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Preview)
    }
    #[classmethod]
    fn fast(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Fast)
    }
    #[classmethod]
    fn balanced(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Balanced)
    }
    #[classmethod]
    fn high_quality(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::HighQuality)
    }
    #[classmethod]
    fn ultra_quality(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::UltraQuality)
    }
    #[classmethod]
    #[pyo3(signature = (step_size, max_steps, early_ray_termination=true, opacity_threshold=0.95))]
    fn custom(
        cls: &Bound<'_, PyType>,
        step_size: f64,
        max_steps: i64,
        early_ray_termination: bool,
        opacity_threshold: f64,
    ) -> PyResult<Py<PyAny>> {
        Ok(cls
            .call1((step_size, max_steps, early_ray_termination, opacity_threshold))?
            .unbind())
    }

    /// An independent RenderConfig (always of this base class, as in pyvr).
    fn copy(&self) -> PyRenderConfig {
        self.clone()
    }
    fn __copy__(&self) -> PyRenderConfig {
        self.clone()
    }
    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> PyRenderConfig {
        self.clone()
    }
    fn __reduce__(slf: &Bound<'_, Self>) -> PyResult<(Py<PyAny>, (f64, i64, bool, f64, f64, &'static str))> {
        let c = slf.borrow().inner;
        Ok((
            slf.get_type().into_any().unbind(),
            (c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold, c.reference_step_size, c.opacity_correction.name()),
        ))
    }

    fn with_step_size(&self, py: Python<'_>, step_size: f64) -> PyResult<PyRenderConfig> {
        let mut c = self.clone();
        c.inner.step_size = step_size;
        checked(py, &c.inner)?;
        Ok(c)
    }

    fn with_max_steps(&self, py: Python<'_>, max_steps: i64) -> PyResult<PyRenderConfig> {
        let mut c = self.clone();
        c.inner.max_steps = max_steps;
        checked(py, &c.inner)?;
        Ok(c)
    }

    fn estimate_samples_per_ray(&self) -> i64 {
        self.inner.estimate_samples_per_ray()
    }

    fn estimate_render_time_relative(&self) -> f64 {
        self.inner.estimate_render_time_relative()
    }

    fn __repr__(&self) -> String {
        self.inner.to_string()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        match other.cast::<PyRenderConfig>() {
            Ok(o) => o.borrow().inner == self.inner,
            Err(_) => false,
        }
    }
}
