//! The frame plan both engines read: the uniform block (`params`) the
//! shader and the native march take, and the constants their rules share.
//! Neither engine imports the other; the renderer (`crate::renderer`) fills
//! a plan and hands it to the engine that renders the frame.

pub mod params;

pub use params::{world_unit, FrameInputs, Params, MAX_CLIP_PLANES};

/// Bisection steps that place an isosurface hit between two samples (to
/// 1/256 of their distance, then a secant step). The oracle bisects to
/// convergence instead, so tests see this rule's error.
pub const ISO_BISECTIONS: u32 = 8;

/// Cells either side of a cell over which a maximum (minimum) projection
/// also bounds the values: where the bound shows a ray's maximum cannot
/// grow, it leaps out of that cube of 7^3 cells (24 voxels or more ahead)
/// instead of out of the cell.
pub const PROJECTION_REACH: usize = 3;
