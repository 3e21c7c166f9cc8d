//! A renderer's resources and their uploads: the volume (and normals),
//! the transfer-function table, the occupancy grid, the pre-integration
//! table, and the buffers a frame writes. Each is rebuilt only when its
//! input changes.

mod buffers;
mod grids;
mod stored;
mod tables;
mod uploads;

pub use buffers::*;
pub use grids::*;
pub use stored::*;
pub use tables::*;
use uploads::*;

const D2: wgpu::TextureDimension = wgpu::TextureDimension::D2;
const D3: wgpu::TextureDimension = wgpu::TextureDimension::D3;
