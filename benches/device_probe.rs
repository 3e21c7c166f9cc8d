//! Prints the adapter, its features of interest and its limits:
//! `cargo bench --bench device_probe`.
fn main() {
    match pyvr_core::gpu::GpuContext::get() {
        Ok(ctx) => {
            println!("{}", ctx.describe());
            println!("features: {:?}", ctx.features);
            println!("max_texture_dimension_3d: {}", ctx.limits.max_texture_dimension_3d);
            println!("max_storage_buffer_binding_size: {}", ctx.limits.max_storage_buffer_binding_size);
            println!("max_buffer_size: {}", ctx.limits.max_buffer_size);
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
