//! The PyO3 module `pyvr._core`: the only place pyo3 is used.

mod args;
mod config;
mod errors;
mod pick;
mod renderer;
mod transfer;

use pyo3::prelude::*;

/// The engines a renderer made now would have (`renderer::device`).
fn device() -> PyResult<crate::renderer::device::Device> {
    use crate::renderer::device::{Device, EngineChoice};
    EngineChoice::from_env().and_then(Device::open).map_err(errors::to_py)
}

/// What renders frames: the GPU adapter, or the native CPU engine alone.
/// Raises RuntimeError where neither can.
#[pyfunction]
fn device_info() -> PyResult<String> {
    device().map(|d| d.describe())
}

/// The limits that bound what can be rendered here.
#[pyfunction]
fn device_limits(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    let dev = device()?;
    let d = pyo3::types::PyDict::new(py);
    let c = &dev.caps;
    d.set_item("max_texture_dimension_3d", c.max_texture_3d)?;
    d.set_item("max_texture_dimension_2d", c.max_texture_2d)?;
    let binding = dev.gpu.as_ref().map_or(c.max_storage, |g| g.limits.max_storage_buffer_binding_size);
    d.set_item("max_storage_buffer_binding_size", binding)?;
    d.set_item("max_buffer_size", c.max_buffer)?;
    d.set_item("max_image_pixels", c.max_storage / 16)?;
    d.set_item("float32_filterable", c.float32_filterable)?;
    d.set_item("norm16_textures", c.norm16)?;
    let cpu = dev.gpu.as_ref().is_none_or(|g| g.adapter_info.device_type == wgpu::DeviceType::Cpu);
    d.set_item("cpu_device", cpu)?;
    // Whether a GPU adapter (or lavapipe) runs the shader engine at all.
    d.set_item("gpu_adapter", dev.gpu.is_some())?;
    // Frames the native CPU march covers are rendered by it (crate::cpu).
    d.set_item("native_march", c.native)?;
    // The native march's code: "avx2", or "portable" (PYVR_NATIVE_LANES).
    d.set_item("native_lanes", crate::cpu::lanes().name())?;
    Ok(d)
}

/// Each optical model's abilities, as the core declares them (`crate::model`):
/// name -> {"integrates", "projects", "unbiased", "lit_by_normals",
/// "terminates_early", "reduction"}.
#[pyfunction]
fn model_abilities(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    let all = pyo3::types::PyDict::new(py);
    for m in crate::model::Model::ALL {
        let d = pyo3::types::PyDict::new(py);
        d.set_item("integrates", m.integrates())?;
        d.set_item("projects", m.projects())?;
        d.set_item("unbiased", m.tracks())?;
        d.set_item("lit_by_normals", m.lit_by_normals())?;
        d.set_item("terminates_early", m.terminates_early())?;
        d.set_item("reduction", m.reduction())?;
        all.set_item(m.name(), d)?;
    }
    Ok(all)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<config::PyRenderConfig>()?;
    m.add_class::<renderer::PyRenderer>()?;
    m.add_function(wrap_pyfunction!(renderer::convert, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::brick_ghost, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::brick_layout, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::integrate_reference, m)?)?;
    m.add_function(wrap_pyfunction!(pick::pick_reference, m)?)?;
    m.add_function(wrap_pyfunction!(transfer::colormap_table, m)?)?;
    m.add_function(wrap_pyfunction!(transfer::colormap_names, m)?)?;
    m.add_function(wrap_pyfunction!(device_info, m)?)?;
    m.add_function(wrap_pyfunction!(device_limits, m)?)?;
    m.add_function(wrap_pyfunction!(model_abilities, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
