//! The volume as the renderer stores it (its uploads: `uploads`): the
//! native march's texels, the shader's textures made from them when a
//! frame on the shader first needs them, and the projections' cell bounds.

use super::*;
use crate::cpu::{CellBounds, CpuVolume};
use crate::error::try_vec;
use crate::error::Error;
use crate::fixed16::CODE_MAX;
use crate::half::{f16_to_f32, f32_to_f16};
use crate::occupancy::MinMaxGrid;
use crate::plan::PROJECTION_REACH;
use crate::renderer::device::Device;
use crate::scene::Bounds;
use crate::transfer::ValueMap;

/// The volume as stored on the device.
pub struct VolumeGpu {
    /// The stored format can be filtered by the sampler.
    pub filterable: bool,
    /// The texture; None while the native march's copy (`cpu`) stands in
    /// for it, until a frame on the shader needs it (`ensure_textures`).
    pub view: Option<wgpu::TextureView>,
    /// Normals in their own texture (None while deferred as `view` is).
    pub normals: Option<wgpu::TextureView>,
    /// The normals are a texture of their own.
    pub normals_apart: bool,
    /// Normals in the volume's texels: (value, nx, ny, nz), Rgba16Float.
    pub normals_in_volume: bool,
    /// The texels are (value, gradient) with a one-voxel border
    /// (`gradients::bordered_texels`): gradient shading reads them as normals.
    pub gradients: bool,
    /// The device's texel format for the values, for reports.
    pub format: wgpu::TextureFormat,
    pub dims: [usize; 3],
    pub bounds: Bounds,
    pub bytes: u64,
    pub grid: MinMaxGrid,
    /// Maximum or minimum projections' cell bounds, for the value map and
    /// kind they were made for, at the first such frame after either changed.
    pub projection_bounds: std::sync::Mutex<Option<ProjectionBounds>>,
    /// What the shader's texel value stands for: the sampled value is
    /// `stored.apply(texel.r)` (the identity but for fixed-point storage).
    pub stored: ValueMap,
    /// The texels for the native march (`crate::cpu`), where the adapter
    /// is a CPU that runs it and the format is one it reads.
    pub cpu: Option<CpuVolume>,
}

/// Whether a volume keeps texels of its own for the native march.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CpuCopy {
    No,
    /// While they take at most half the memory the system says is
    /// available (a frame on the shader would double what they take).
    IfRoom,
    /// Where they can be had at all: a brick's, which the frames of a
    /// bricked volume on the native march read brick after brick.
    Always,
}

/// The cells' bounds a maximum (`upper`) or minimum projection leaps by,
/// under value map `map`; and, once a frame on the shader needs them, the
/// same as an Rg32Uint texture of the occupancy grid's size (each cell's
/// bound and its cube's, as f32 bits), bound where the occupancy grid is.
pub struct ProjectionBounds {
    map: ValueMap,
    upper: bool,
    bounds: CellBounds,
    view: Option<wgpu::TextureView>,
}

impl VolumeGpu {
    fn projection_entry(&self, map: ValueMap, upper: bool) -> std::sync::MutexGuard<'_, Option<ProjectionBounds>> {
        let mut kept = self.projection_bounds.lock().unwrap_or_else(|e| e.into_inner());
        if kept.as_ref().is_some_and(|k| k.map == map && k.upper == upper) {
            return kept;
        }
        let g = &self.grid;
        // (Without the grid's own wide ranges, which projections do not read.)
        let wide = MinMaxGrid { min: g.min.clone(), max: g.max.clone(), wide: Vec::new(), ..*g };
        let wide = wide.widened([PROJECTION_REACH; 3]);
        let stored = |x: f32| self.as_stored(x);
        let bounds = CellBounds {
            cell: g.value_bounds(map, upper, stored).into(),
            wide: wide.value_bounds(map, upper, stored).into(),
            reach: PROJECTION_REACH as i32 + 1,
            grid: g.dims,
        };
        *kept = Some(ProjectionBounds { map, upper, bounds, view: None });
        kept
    }

    /// Value `x` (a sample's, as the grid holds it) as the texels store it:
    /// float16 rounds it to the nearest half, 16-bit fixed point to the
    /// nearest code (`fixed16`, whose map `stored` is).
    fn as_stored(&self, x: f32) -> f64 {
        use wgpu::TextureFormat as F;
        match self.format {
            F::R16Float | F::Rgba16Float => f16_to_f32(f32_to_f16(x)) as f64,
            F::R16Snorm | F::Rgba16Snorm => {
                let code = ((x as f64 - self.stored.offset) / self.stored.scale * CODE_MAX as f64)
                    .clamp(-CODE_MAX as f64, CODE_MAX as f64)
                    .round();
                self.stored.apply(code / CODE_MAX as f64)
            }
            _ => x as f64,
        }
    }

    /// The cells' bounds a maximum (`upper`) or minimum projection leaps by
    /// under value map `map`: made once for each map and kind, not every frame.
    pub fn projection_bounds(&self, map: ValueMap, upper: bool) -> CellBounds {
        self.projection_entry(map, upper).as_ref().expect("made above").bounds.clone()
    }

    /// The same bounds as the texture the shader reads (`projections.wgsl`),
    /// uploaded at the first frame that needs it; and the bytes uploaded.
    pub fn projection_view(&self, dev: &Device, map: ValueMap, upper: bool) -> Result<(wgpu::TextureView, u64), Error> {
        let mut kept = self.projection_entry(map, upper);
        let entry = kept.as_mut().expect("made above");
        if let Some(view) = &entry.view {
            return Ok((view.clone(), 0));
        }
        let b = &entry.bounds;
        let mut data = try_vec(b.cell.len() * 8, 0u8, "the projection's cell bounds")?;
        for ((texel, &cell), &wide) in data.chunks_exact_mut(8).zip(b.cell.iter()).zip(b.wide.iter()) {
            texel[..4].copy_from_slice(&cell.to_bits().to_le_bytes());
            texel[4..].copy_from_slice(&wide.to_bits().to_le_bytes());
        }
        let [g0, g1, g2] = b.grid;
        let size = wgpu::Extent3d { width: g2 as u32, height: g1 as u32, depth_or_array_layers: g0 as u32 };
        let rg32 = wgpu::TextureFormat::Rg32Uint;
        let view = dev.ctx().texture_with_data(
            "uploading the projection's cell bounds",
            "cell bounds",
            size,
            D3,
            rg32,
            1,
            &data,
        )?;
        entry.view = Some(view.clone());
        Ok((view, data.len() as u64))
    }

    /// Makes the textures a frame on the shader reads where the native
    /// march's copy stood in for them (`upload`): from that copy, whose
    /// float32 subnormals are flushed to zero, as GPUs that flush them read.
    /// Returns the bytes it uploaded (0 where the textures were there).
    pub fn ensure_textures(&mut self, dev: &Device) -> Result<u64, Error> {
        if self.view.is_some() {
            return Ok(0);
        }
        let cpu = self.cpu.as_ref().expect("a volume without its texture keeps the native march's copy");
        let (size, n) = (extent_of(cpu.dims), cpu.dims.iter().product());
        let bytes = cpu.texels.bytes(n);
        let view = dev.ctx().texture_with_data("uploading the volume", "volume", size, D3, self.format, 1, bytes)?;
        if self.normals_apart {
            let packed = cpu.normals.as_deref().expect("kept with the texels");
            self.normals = Some(upload_normals(dev, size, &packed[..n])?.0);
        }
        self.view = Some(view);
        Ok(self.bytes)
    }

    /// Bytes uploaded when the volume was made: its `bytes`, or none while
    /// its textures wait for a frame on the shader.
    pub fn uploaded(&self) -> u64 {
        if self.view.is_some() {
            self.bytes
        } else {
            0
        }
    }

    /// The stored format and where the normals are, for reports.
    pub fn storage(&self) -> String {
        let texel = format!("{:?}", self.format).to_lowercase();
        if self.gradients {
            return format!("{texel} (value, gradient)");
        }
        if matches!(self.format, wgpu::TextureFormat::R16Snorm | wgpu::TextureFormat::Rgba16Snorm) {
            let kind = if self.normals_in_volume { "16-bit fixed point (value, normal)" } else { "16-bit fixed point" };
            return format!("{texel} ({kind})");
        }
        match (self.normals_apart, self.normals_in_volume) {
            (true, _) => format!("{texel} + rgba8snorm normals"),
            (false, true) => format!("{texel} (value, normal)"),
            (false, false) => texel,
        }
    }
}
