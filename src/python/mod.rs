//! The PyO3 module `pyvr._core`: the only place pyo3 is used.

mod args;
mod config;
mod errors;
mod renderer;
mod transfer;

use pyo3::prelude::*;

/// Device description, or raise RuntimeError if no adapter can be opened.
#[pyfunction]
fn device_info() -> PyResult<String> {
    crate::gpu::GpuContext::get()
        .map(|c| c.describe())
        .map_err(errors::to_py)
}

/// The limits that bound what can be rendered on this device.
#[pyfunction]
fn device_limits(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    let ctx = crate::gpu::GpuContext::get().map_err(errors::to_py)?;
    let d = pyo3::types::PyDict::new(py);
    let l = &ctx.limits;
    d.set_item("max_texture_dimension_3d", l.max_texture_dimension_3d)?;
    d.set_item("max_texture_dimension_2d", l.max_texture_dimension_2d)?;
    d.set_item("max_storage_buffer_binding_size", l.max_storage_buffer_binding_size)?;
    d.set_item("max_buffer_size", l.max_buffer_size)?;
    d.set_item("max_image_pixels", ctx.max_storage_bytes() / 16)?;
    d.set_item("float32_filterable", ctx.features.contains(wgpu::Features::FLOAT32_FILTERABLE))?;
    d.set_item("norm16_textures", ctx.features.contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM))?;
    let cpu = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
    d.set_item("cpu_device", cpu)?;
    // Frames the native CPU march covers are rendered by it (crate::cpu).
    d.set_item("native_march", cpu && crate::cpu::available())?;
    Ok(d)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<config::PyRenderConfig>()?;
    m.add_class::<renderer::PyRenderer>()?;
    m.add_function(wrap_pyfunction!(renderer::convert, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::brick_ghost, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::brick_layout, m)?)?;
    m.add_function(wrap_pyfunction!(renderer::integrate_reference, m)?)?;
    m.add_function(wrap_pyfunction!(transfer::colormap_table, m)?)?;
    m.add_function(wrap_pyfunction!(transfer::colormap_names, m)?)?;
    m.add_function(wrap_pyfunction!(device_info, m)?)?;
    m.add_function(wrap_pyfunction!(device_limits, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
