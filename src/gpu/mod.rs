//! The shader engine: device and limits (`context`), the shader's source
//! and variants (`shader`, `pipeline`, `bindings`), how rays are split into
//! passes (`passes`) and readbacks (`readback`). It reads the frame plan
//! (`crate::plan`) and knows nothing of the native engine (`crate::cpu`);
//! the renderer (`crate::renderer`) holds its resources and dispatches.

pub mod bindings;
pub mod context;
pub mod passes;
pub mod pipeline;
pub mod readback;
pub mod shader;

pub use context::GpuContext;
