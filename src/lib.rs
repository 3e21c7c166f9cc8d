//! pyvr's engine: direct volume rendering of 3-D scalar fields by ray
//! marching in wgpu compute shaders, with an f64 CPU integrator as the oracle.
//!
//! Everything here is plain Rust; the Python binding lives in `python/` and
//! is compiled only with the `python` feature.

pub mod bricks;
pub mod config;
pub mod cores;
pub mod cpu;
pub mod error;
pub mod fixed16;
pub mod gpu;
pub mod gradients;
pub mod half;
pub mod integrate;
pub mod model;
pub mod occupancy;
pub mod output;
pub mod plan;
pub mod preintegrate;
pub mod renderer;
pub mod scene;
pub mod transfer;
pub mod volume;

#[cfg(feature = "python")]
mod python;
