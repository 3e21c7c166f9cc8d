//! The wgpu side: device and limits (`context`), the shader's source and
//! variants (`shader`, `pipeline`, `bindings`), the uniform block (`params`),
//! how rays are split into passes (`plan`), a renderer's resources
//! (`resources`), its frame (`renderer`) and readbacks (`readback`).

pub mod bindings;
pub mod context;
pub mod half;
pub mod params;
pub mod pipeline;
pub mod plan;
pub mod readback;
pub mod renderer;
pub mod resources;
pub mod shader;

pub use context::GpuContext;
pub use renderer::{FrameStats, GpuRenderer};
