//! `pyvr.config.RenderConfig`: a Rust class with pyvr 0.4.1's fields,
//! defaults, presets, messages and repr.

use super::args::{integer, real, FromArg};
use super::errors::to_py;
use crate::config::{OpacityCorrection, Preset, RenderConfig};
use crate::model::{Model, Order};
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;
use pyo3::types::PyType;
use std::ffi::CString;

/// Field names `replace()` accepts.
const FIELDS: [&str; 17] = [
    "step_size",
    "max_steps",
    "early_ray_termination",
    "opacity_threshold",
    "reference_step_size",
    "opacity_correction",
    "model",
    "iso_value",
    "anisotropy",
    "shadow_step_size",
    "jitter",
    "jitter_seed",
    "pre_integrated",
    "refine",
    "unbiased",
    "exact_filtering",
    "order",
];

/// How frames are marched: pyvr 0.4.1's fields (`step_size`, `max_steps`,
/// `early_ray_termination`, `opacity_threshold`, `reference_step_size`,
/// `opacity_correction`) and its presets, plus the optical model (`model`,
/// `iso_value`, `anisotropy`, `shadow_step_size`), the marching `order`,
/// `jitter`/`jitter_seed`, `pre_integrated`, `refine`, `unbiased` and
/// `exact_filtering`. Fields are checked when set (ValueError/TypeError
/// naming the field); `replace(**fields)` gives a changed copy.
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
    let warnings = c.validate().map_err(to_py)?;
    warn_all(py, &warnings)
}

/// A jitter seed must fit the shader's 32-bit hash.
fn seed(v: &Bound<'_, PyAny>) -> PyResult<u32> {
    integer("jitter_seed", v, 0, u32::MAX as i128).map(|n| n as u32)
}

fn preset(cls: &Bound<'_, PyType>, p: Preset) -> PyResult<Py<PyAny>> {
    let c = RenderConfig::preset(p);
    Ok(cls.call1((c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold))?.unbind())
}

/// The `#[pymethods]` block, with a getter and a setter generated for each
/// field that maps one to one (`plain`) or through its name (`named`).
macro_rules! render_config_methods {
    (
        plain { $($(#[$pm:meta])* $p:ident / $pset:ident : $pty:ty;)* }
        named { $($(#[$nm:meta])* $n:ident / $nset:ident : $nty:ident;)* }
        $($rest:tt)*
    ) => {
        #[pymethods]
        impl PyRenderConfig {
            $(
                $(#[$pm])*
                #[getter]
                fn $p(&self) -> $pty {
                    self.inner.$p
                }
                #[setter]
                fn $pset(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                    self.inner.$p = <$pty as FromArg>::from_arg(stringify!($p), v)?;
                    Ok(())
                }
            )*
            $(
                $(#[$nm])*
                #[getter]
                fn $n(&self) -> &'static str {
                    self.inner.$n.name()
                }
                #[setter]
                fn $nset(&mut self, v: &str) -> PyResult<()> {
                    self.inner.$n = $nty::parse(v).map_err(to_py)?;
                    Ok(())
                }
            )*
            $($rest)*
        }
    };
}

render_config_methods! {
    plain {
        step_size / set_step_size: f64;
        max_steps / set_max_steps: i64;
        early_ray_termination / set_early_ray_termination: bool;
        opacity_threshold / set_opacity_threshold: f64;
        reference_step_size / set_reference_step_size: f64;
        /// The isosurface model's threshold (data units after uint scaling).
        iso_value / set_iso_value: f64;
        /// Henyey–Greenstein g in (-1, 1) for single scattering; 0 is isotropic.
        anisotropy / set_anisotropy: f64;
        /// Step of single scattering's shadow rays; 0 means step_size.
        shadow_step_size / set_shadow_step_size: f64;
        /// Start each pixel's sample grid at a random fraction of a step.
        jitter / set_jitter: bool;
        /// Integrate each segment from a (front, back) table (emission_absorption only).
        pre_integrated / set_pre_integrated: bool;
        /// With pre_integrated: midpoint samples (2-16) for a segment whose
        /// values may reach an opacity change its ramp misses (0: off).
        refine / set_refine: i64;
        /// Each frame an unbiased estimate of the exact integral (Poisson
        /// points, ratio tracking): ``render(accumulate=n)`` converges to it.
        unbiased / set_unbiased: bool;
        /// Interpolate the volume and the tables with f32 weights in the
        /// shader rather than the texture units' 8-bit ones (GPUs only;
        /// ``config_for_error`` turns it on there).
        exact_filtering / set_exact_filtering: bool;
    }
    named {
        /// "exponential" (pyvr: 1 - exp(-a*d/ref)) or "power" (VTK: 1 - (1-a)^(d/ref)).
        opacity_correction / set_opacity_correction: OpacityCorrection;
        /// "emission_absorption" (default), "absorption", "emission",
        /// "single_scattering", "mip", "minip", "average" or "isosurface".
        model / set_model: Model;
        /// "front_to_back" (default) or "back_to_front" (equal; ignores early termination).
        order / set_order: Order;
    }

    // None (also accepted) means the default; the text signature shows
    // pyvr 0.4.1's defaults for its fields.
    #[new]
    #[pyo3(
        signature = (step_size=None, max_steps=None, early_ray_termination=None, opacity_threshold=None, reference_step_size=None, opacity_correction="exponential", *, model="emission_absorption", iso_value=None, anisotropy=None, shadow_step_size=None, jitter=None, jitter_seed=None, pre_integrated=None, refine=None, unbiased=None, exact_filtering=None, order="front_to_back"),
        text_signature = "(step_size=0.01, max_steps=500, early_ray_termination=True, opacity_threshold=0.95, reference_step_size=0.01, opacity_correction='exponential', *, model='emission_absorption', iso_value=None, anisotropy=None, shadow_step_size=None, jitter=None, jitter_seed=None, pre_integrated=None, refine=None, unbiased=None, exact_filtering=None, order='front_to_back')"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        step_size: Option<&Bound<'_, PyAny>>,
        max_steps: Option<&Bound<'_, PyAny>>,
        early_ray_termination: Option<&Bound<'_, PyAny>>,
        opacity_threshold: Option<&Bound<'_, PyAny>>,
        reference_step_size: Option<&Bound<'_, PyAny>>,
        opacity_correction: &str,
        model: &str,
        iso_value: Option<&Bound<'_, PyAny>>,
        anisotropy: Option<&Bound<'_, PyAny>>,
        shadow_step_size: Option<&Bound<'_, PyAny>>,
        jitter: Option<&Bound<'_, PyAny>>,
        jitter_seed: Option<&Bound<'_, PyAny>>,
        pre_integrated: Option<&Bound<'_, PyAny>>,
        refine: Option<&Bound<'_, PyAny>>,
        unbiased: Option<&Bound<'_, PyAny>>,
        exact_filtering: Option<&Bound<'_, PyAny>>,
        order: &str,
    ) -> PyResult<Self> {
        let d = RenderConfig::default();
        fn arg<T: FromArg>(name: &str, v: Option<&Bound<'_, PyAny>>, default: T) -> PyResult<T> {
            v.map_or(Ok(default), |v| T::from_arg(name, v))
        }
        let inner = RenderConfig {
            step_size: arg("step_size", step_size, d.step_size)?,
            max_steps: arg("max_steps", max_steps, d.max_steps)?,
            early_ray_termination: arg("early_ray_termination", early_ray_termination, d.early_ray_termination)?,
            opacity_threshold: arg("opacity_threshold", opacity_threshold, d.opacity_threshold)?,
            reference_step_size: arg("reference_step_size", reference_step_size, d.reference_step_size)?,
            opacity_correction: OpacityCorrection::parse(opacity_correction).map_err(to_py)?,
            model: Model::parse(model).map_err(to_py)?,
            iso_value: arg("iso_value", iso_value, d.iso_value)?,
            anisotropy: arg("anisotropy", anisotropy, d.anisotropy)?,
            shadow_step_size: arg("shadow_step_size", shadow_step_size, d.shadow_step_size)?,
            jitter: arg("jitter", jitter, d.jitter)?,
            jitter_seed: jitter_seed.map_or(Ok(d.jitter_seed), seed)?,
            pre_integrated: arg("pre_integrated", pre_integrated, d.pre_integrated)?,
            refine: arg("refine", refine, d.refine)?,
            unbiased: arg("unbiased", unbiased, d.unbiased)?,
            exact_filtering: arg("exact_filtering", exact_filtering, d.exact_filtering)?,
            order: Order::parse(order).map_err(to_py)?,
        };
        checked(py, &inner)?;
        Ok(PyRenderConfig { inner })
    }

    #[getter]
    fn jitter_seed(&self) -> u32 {
        self.inner.jitter_seed
    }
    #[setter]
    fn set_jitter_seed(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
        self.inner.jitter_seed = seed(v)?;
        Ok(())
    }

    /// A copy with the given fields replaced, validated:
    /// ``cfg.replace(model="mip", step_size=0.005)``.
    #[pyo3(signature = (**changes))]
    fn replace(slf: &Bound<'_, Self>, changes: Option<&Bound<'_, pyo3::types::PyDict>>) -> PyResult<PyRenderConfig> {
        let py = slf.py();
        let copy = Bound::new(py, slf.borrow().clone())?;
        if let Some(ch) = changes {
            for (k, v) in ch.iter() {
                let name: String = k.extract()?;
                if !FIELDS.contains(&name.as_str()) {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "RenderConfig has no field '{name}'; fields are {}",
                        FIELDS.join(", ")
                    )));
                }
                copy.setattr(name.as_str(), v)?;
            }
        }
        let out = copy.borrow().clone();
        checked(py, &out.inner)?;
        Ok(out)
    }

    /// Raises ValueError for invalid values, warns for very large ones.
    fn validate(&self, py: Python<'_>) -> PyResult<()> {
        checked(py, &self.inner)
    }

    /// Fastest: step 0.05, at most 50 steps, early termination at 0.80 opacity.
    #[classmethod]
    fn preview(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Preview)
    }
    /// Step 0.02, at most 100 steps, early termination at 0.90 opacity.
    #[classmethod]
    fn fast(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Fast)
    }
    /// The default: step 0.01, at most 500 steps, early termination at 0.95 opacity.
    #[classmethod]
    fn balanced(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::Balanced)
    }
    /// Step 0.005, at most 1000 steps, early termination at 0.98 opacity.
    #[classmethod]
    fn high_quality(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::HighQuality)
    }
    /// Step 0.001, at most 2000 steps, no early termination.
    #[classmethod]
    fn ultra_quality(cls: &Bound<'_, PyType>) -> PyResult<Py<PyAny>> {
        preset(cls, Preset::UltraQuality)
    }
    /// A config from pyvr's four fields (the other fields at their defaults).
    #[classmethod]
    // None (also accepted) means the same defaults; the text signature shows
    // them as pyvr 0.4.1 did.
    #[pyo3(
        signature = (step_size, max_steps, early_ray_termination=None, opacity_threshold=None),
        text_signature = "(step_size, max_steps, early_ray_termination=True, opacity_threshold=0.95)"
    )]
    fn custom(
        cls: &Bound<'_, PyType>,
        step_size: &Bound<'_, PyAny>,
        max_steps: &Bound<'_, PyAny>,
        early_ray_termination: Option<&Bound<'_, PyAny>>,
        opacity_threshold: Option<&Bound<'_, PyAny>>,
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
    /// Pickles as the class, pyvr's positional fields, then the rest as state.
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Py<PyAny>, (f64, i64, bool, f64, f64, &'static str), Bound<'py, pyo3::types::PyDict>)> {
        let py = slf.py();
        let c = slf.borrow().inner;
        let state = pyo3::types::PyDict::new(py);
        state.set_item("model", c.model.name())?;
        state.set_item("iso_value", c.iso_value)?;
        state.set_item("anisotropy", c.anisotropy)?;
        state.set_item("shadow_step_size", c.shadow_step_size)?;
        state.set_item("jitter", c.jitter)?;
        state.set_item("jitter_seed", c.jitter_seed)?;
        state.set_item("pre_integrated", c.pre_integrated)?;
        state.set_item("refine", c.refine)?;
        state.set_item("unbiased", c.unbiased)?;
        state.set_item("exact_filtering", c.exact_filtering)?;
        state.set_item("order", c.order.name())?;
        Ok((
            slf.get_type().into_any().unbind(),
            (c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold, c.reference_step_size, c.opacity_correction.name()),
            state,
        ))
    }

    fn __setstate__(slf: &Bound<'_, Self>, state: &Bound<'_, pyo3::types::PyDict>) -> PyResult<()> {
        for (k, v) in state.iter() {
            slf.setattr(k.extract::<String>()?.as_str(), v)?;
        }
        Ok(())
    }

    /// A copy with `step_size` changed (checked as when set).
    fn with_step_size(&self, py: Python<'_>, step_size: &Bound<'_, PyAny>) -> PyResult<PyRenderConfig> {
        let mut c = self.clone();
        c.inner.step_size = real("step_size", step_size)?;
        checked(py, &c.inner)?;
        Ok(c)
    }

    /// A copy with `max_steps` changed (checked as when set).
    fn with_max_steps(&self, py: Python<'_>, max_steps: &Bound<'_, PyAny>) -> PyResult<PyRenderConfig> {
        let mut c = self.clone();
        c.inner.max_steps = i64::from_arg("max_steps", max_steps)?;
        checked(py, &c.inner)?;
        Ok(c)
    }

    /// Samples a ray takes across the unit cube's diagonal, as pyvr estimates it: int(1.732 / step_size), at most max_steps.
    fn estimate_samples_per_ray(&self) -> i64 {
        self.inner.estimate_samples_per_ray()
    }

    /// Samples per ray relative to the balanced preset's: a rough cost estimate.
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
