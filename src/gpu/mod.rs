//! The wgpu side: device and limits (`context`), shader variants
//! (`pipeline`), and the per-renderer resources and frame (`renderer`).

pub mod bindings;
pub mod context;
pub mod half;
pub mod pipeline;
pub mod renderer;
pub mod shader;

pub use context::{GpuContext, GpuError};
pub use renderer::{FrameStats, GpuRenderer};
