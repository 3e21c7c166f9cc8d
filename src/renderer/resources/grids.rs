//! The occupancy grid a frame leaps by: which cells are empty (or uniform)
//! under the current table, value map or iso value.

use super::*;
use crate::config::OpacityCorrection;
use crate::error::Error;
use crate::occupancy::{empty_radius, occupied_bounds, MinMaxGrid, SegmentRanges, UNIFORM_FLAG};
use crate::renderer::device::Device;

/// What decides which occupancy cells are empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OccSource {
    /// Zero opacity under this version of the transfer function, over each
    /// cell's range or, for unbiased frames with per-cell rates, over the
    /// range of the segments centred in it (`MinMaxGrid::for_segments`);
    /// occupied cells hold the code of their largest extinction under the
    /// correction `form` (`MinMaxGrid::majorants`).
    Lut { version: u64, ranges: SegmentRanges, form: OpacityCorrection },
    /// Values below this iso value (bits of the f64).
    Below(u64),
}

/// Which cells of the volume can show anything, as an Rg8Uint 3-D texture,
/// one texel per 8^3 voxels: r is 0 where the cell is empty (else its
/// majorant code), g its empty radius (`occupancy::empty_radius`), so that
/// a ray in empty space leaves the whole empty cube around its cell in one
/// leap from one fetch; or, for a uniform cell, UNIFORM_FLAG + its uniform
/// radius, so that a ray composites the cube of one colour and opacity
/// around it as one segment.
pub struct Occupancy {
    pub view: Option<wgpu::TextureView>,
    /// What the grid was built from.
    pub source: Option<OccSource>,
    /// Fraction of level-0 cells left empty. Above 0 the skipping variant is
    /// worth its cost (its branch slows dense scenes by ~20% on lavapipe);
    /// at 1 no ray needs marching.
    pub empty_fraction: f64,
    /// Fraction of the occupied cells that are uniform (0 where not built).
    pub uniform_fraction: f64,
    /// The box of cells that are not empty (`occupancy::occupied_bounds`),
    /// in the grid's (numpy) axis order.
    pub occupied: Option<[[usize; 2]; 3]>,
    /// The grid's size (cells, numpy axis order) and each cell's code as
    /// the texture's second channel holds it (empty radius, or UNIFORM_FLAG
    /// + uniform radius), followed by three zero bytes (the native march
    /// reads each code as the low byte of a 32-bit word).
    pub dims: [usize; 3],
    pub codes: Vec<u8>,
    /// Each cell's code as the texture's first channel holds it: 0 where
    /// empty, else 1, or the cell's majorant (`occupancy::majorant_code`)
    /// where unbiased frames' segments take their cells' rates; followed by
    /// three zero bytes, as `codes`.
    pub majorants: Vec<u8>,
}

impl Occupancy {
    pub fn new() -> Occupancy {
        Occupancy {
            view: None,
            source: None,
            empty_fraction: 0.0,
            uniform_fraction: 0.0,
            occupied: None,
            dims: [0; 3],
            codes: Vec::new(),
            majorants: Vec::new(),
        }
    }

    /// Uploads the grid `occ` (0 = empty) of `grid`'s cells, built from
    /// `source`. Returns the bytes written.
    /// `uniform`: each cell's uniform radius (`occupancy::uniform_radius`),
    /// where the frames this grid serves may composite uniform cells whole.
    pub fn upload(
        &mut self,
        dev: &Device,
        grid: &MinMaxGrid,
        occ: &[u8],
        uniform: Option<&[u8]>,
        source: OccSource,
    ) -> Result<u64, Error> {
        let [g0, g1, g2] = grid.dims;
        let mut radius = empty_radius(occ, grid.dims);
        let occupied = occ.iter().filter(|&&o| o != 0).count();
        self.uniform_fraction = 0.0;
        if let Some(uniform) = uniform {
            // Occupied cells have empty radius 0: the byte holds one or the other.
            for (r, &u) in radius.iter_mut().zip(uniform) {
                if u > 0 {
                    *r = UNIFORM_FLAG + u;
                }
            }
            self.uniform_fraction = uniform.iter().filter(|&&u| u > 0).count() as f64 / occupied.max(1) as f64;
        }
        let data: Vec<u8> = occ.iter().zip(&radius).flat_map(|(&o, &r)| [o, r]).collect();
        let size = wgpu::Extent3d { width: g2 as u32, height: g1 as u32, depth_or_array_layers: g0 as u32 };
        let rg8 = wgpu::TextureFormat::Rg8Uint;
        let view = dev.texture("uploading the occupancy grid", "occupancy", size, D3, rg8, &data)?;
        self.empty_fraction = occ.iter().filter(|&&o| o == 0).count() as f64 / occ.len() as f64;
        self.occupied = occupied_bounds(occ, grid.dims);
        self.dims = grid.dims;
        radius.extend([0; 3]);
        self.codes = radius;
        self.majorants = occ.iter().copied().chain([0; 3]).collect();
        let uploaded = if view.is_some() { data.len() as u64 } else { 0 };
        self.view = view;
        self.source = Some(source);
        Ok(uploaded)
    }
}
