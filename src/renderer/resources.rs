//! A renderer's GPU resources and their uploads: the volume (and normals),
//! the transfer-function table, the occupancy grid, the pre-integration
//! table, and the buffers a frame writes. Each is rebuilt only when its
//! input changes.

use super::device::Device;
use crate::config::OpacityCorrection;
use crate::cpu::{CellBounds, CpuVolume, Texels};
use crate::error::Error;
use crate::error::{try_collect, try_vec};
use crate::fixed16::{normal_code, Fixed16, CODE_MAX};
use crate::gpu::context::GpuContext;
use crate::gradients;
use crate::half::{f16_to_f32, f32_to_f16};
use crate::occupancy::{empty_radius, occupied_bounds, MinMaxGrid, SegmentRanges, UNIFORM_FLAG};
use crate::plan::PROJECTION_REACH;
use crate::preintegrate;
use crate::scene::Bounds;
use crate::transfer::ValueMap;
use crate::volume::{sanitize, unit_direction, Precision, VolumeView, Voxels};

const D2: wgpu::TextureDimension = wgpu::TextureDimension::D2;
const D3: wgpu::TextureDimension = wgpu::TextureDimension::D3;

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

/// The texels for the native march: only where the caller asks
/// (`native`), the adapter is a CPU (whose "device memory" is the same RAM)
/// and the march runs there, and with `IfRoom` only while they take at
/// most half the memory the system says is available (frames then stay on
/// the shader): with a frame on the shader they double what the volume
/// takes, and a process over its memory is killed, not told.
fn cpu_copy(
    dev: &Device,
    native: CpuCopy,
    format: wgpu::TextureFormat,
    dims: [usize; 3],
    bytes: &[u8],
    normals: &mut Option<Vec<[i8; 4]>>,
) -> Option<CpuVolume> {
    if !marches_natively(dev, native) {
        return None;
    }
    // (The normals were made for the texture: keeping them adds no peak.)
    let kept = bytes.len() + normals.as_ref().map_or(0, |n| 4 * n.len());
    if native == CpuCopy::IfRoom && available_memory().is_some_and(|free| kept as u64 > free / 2) {
        return None;
    }
    // The march gathers with 32-bit signed offsets: floats for float32
    // texels, whole texels otherwise.
    let units = match format {
        wgpu::TextureFormat::Rgba32Float | wgpu::TextureFormat::R32Float => bytes.len() / 4,
        wgpu::TextureFormat::Rgba16Snorm | wgpu::TextureFormat::Rgba16Float => bytes.len() / 8,
        wgpu::TextureFormat::R8Unorm => bytes.len(),
        _ => bytes.len() / 2,
    };
    if units >= i32::MAX as usize {
        return None;
    }
    let texels = match format {
        wgpu::TextureFormat::Rgba32Float => {
            let mut t: Vec<[f32; 4]> = copied(bytes, 0)?;
            flush_subnormals(t.as_flattened_mut());
            Texels::Rgba32Float(t)
        }
        wgpu::TextureFormat::Rgba16Snorm => Texels::Rgba16Snorm(copied(bytes, 0)?),
        wgpu::TextureFormat::R32Float => {
            let mut t: Vec<f32> = copied(bytes, 1)?;
            flush_subnormals(&mut t);
            Texels::R32Float(t)
        }
        wgpu::TextureFormat::R16Snorm => Texels::R16Snorm(copied(bytes, 1)?),
        wgpu::TextureFormat::R8Unorm => Texels::R8Unorm(copied(bytes, 3)?),
        wgpu::TextureFormat::R16Unorm => Texels::R16Unorm(copied(bytes, 1)?),
        wgpu::TextureFormat::R16Float => Texels::R16Float(copied(bytes, 1)?),
        wgpu::TextureFormat::Rgba16Float => Texels::Rgba16Float(copied(bytes, 0)?),
        _ => return None,
    };
    Some(CpuVolume { texels, dims, normals: normals.take() })
}

/// Whether the native march keeps its own texels of a volume: asked for,
/// and the only adapter is a CPU that runs the march.
fn marches_natively(dev: &Device, native: CpuCopy) -> bool {
    native != CpuCopy::No && dev.caps.native
}

/// Subnormal floats to zero (keeping the sign): fields that fall off
/// exponentially hold them far from their features, and on a CPU each
/// operation reading one takes a microcode assist. They stand for
/// values under 1.2e-38, which GPUs that flush subnormals read as zero too.
fn flush_subnormals(x: &mut [f32]) {
    for v in x {
        if v.abs() < f32::MIN_POSITIVE {
            *v *= 0.0;
        }
    }
}

/// `bytes` as texels of type T, then `extra` zero texels; None where the
/// memory cannot be had.
fn copied<T: bytemuck::Pod>(bytes: &[u8], extra: usize) -> Option<Vec<T>> {
    let n = bytes.len() / std::mem::size_of::<T>();
    let mut v = try_vec(n + extra, T::zeroed(), "the native march's texels").ok()?;
    bytemuck::cast_slice_mut::<T, u8>(&mut v[..n]).copy_from_slice(&bytes[..n * std::mem::size_of::<T>()]);
    Some(v)
}

/// Memory the system can give without swapping (Linux's MemAvailable), if known.
fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
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

    /// Uploads `vol`, storing float data at `precision`. `native`: keep the
    /// texels for the native march where it runs (`cpu_copy`), and make
    /// the texture from them when a frame on the shader needs it.
    pub fn upload(dev: &Device, vol: &VolumeView, precision: Precision, native: CpuCopy) -> Result<VolumeGpu, Error> {
        let max3d = dev.caps.max_texture_3d;
        if let Some(&big) = vol.dims.iter().find(|&&d| d > max3d) {
            return Err(Error::DeviceLimit(format!(
                "volume shape {:?} has an axis of {big} voxels, over this device's 3-D texture limit \
                 of {max3d}",
                vol.dims
            )));
        }
        // A texture's data goes through one staging buffer: more than the
        // device's largest buffer fails validation with no useful message.
        let unorm16 = dev.caps.norm16;
        let packed32 = Self::packs_float32(dev, vol, precision);
        let texel: u64 = match (vol.voxels, precision, vol.normals.is_some()) {
            (_, Precision::Fixed16, true) => 8,
            (_, Precision::Fixed16, false) => 2,
            (Voxels::F32(_), Precision::Float16, true) => 8,
            (Voxels::F32(_), Precision::Float16, false) => 2,
            (Voxels::F32(_), _, true) if packed32 => 16,
            (Voxels::F32(_), _, _) => 4,
            (Voxels::U16(_), _, _) if unorm16 => 2,
            (Voxels::U16(_), _, _) => 4,
            (Voxels::U8(_), _, _) => 1,
        };
        // Other normals are a texture of their own (4 bytes a voxel).
        let separate_normals = vol.normals.is_some() && texel < 8;
        let bytes = vol.voxels.len() as u64 * texel.max(if separate_normals { 4 } else { 0 });
        let max = dev.caps.max_buffer;
        if bytes > max {
            return Err(Error::DeviceLimit(format!(
                "volume shape {:?} needs {bytes} bytes on the device, over its limit of {max} bytes per upload",
                vol.dims
            )));
        }
        if precision == Precision::Fixed16 {
            if !unorm16 {
                return Err(Error::InvalidInput(
                    "precision 'fixed16' needs 16-bit normalized textures, which this device lacks: \
                     use 'float32' or 'float16'"
                        .into(),
                ));
            }
            return Self::upload_fixed16(dev, vol, native);
        }
        if let (Voxels::F32(v), Precision::Float16) = (vol.voxels, precision) {
            precision.check(v)?;
            return Self::upload_f16(dev, vol, v, native);
        }
        if let (Voxels::F32(v), Some(n), true) = (vol.voxels, vol.normals, packed32) {
            return Self::upload_packed_f32(dev, vol, v, n, native);
        }
        let converted: Vec<u8>;
        let (format, bytes): (wgpu::TextureFormat, &[u8]) = match vol.voxels {
            Voxels::U8(v) => (wgpu::TextureFormat::R8Unorm, v),
            Voxels::U16(v) if unorm16 => (wgpu::TextureFormat::R16Unorm, bytemuck::cast_slice(v)),
            Voxels::U16(v) => {
                let bytes = v.iter().flat_map(|&x| (x as f32 / 65535.0).to_ne_bytes());
                converted = try_collect(v.len() * 4, "converting the volume", bytes)?;
                (wgpu::TextureFormat::R32Float, &converted)
            }
            Voxels::F32(v) => {
                // (A fold, not `any`: a clean volume is read to its end
                // either way, and without an early exit the loop is vectorised.)
                if v.iter().fold(false, |a, x| a | x.is_infinite()) {
                    let bytes = v.iter().flat_map(|&x| sanitize(x).to_ne_bytes());
                    converted = try_collect(v.len() * 4, "converting the volume", bytes)?;
                    (wgpu::TextureFormat::R32Float, &converted)
                } else {
                    (wgpu::TextureFormat::R32Float, bytemuck::cast_slice(v))
                }
            }
        };
        // NaN (missing data) must poison every sample whose eight neighbours
        // include it, as in the f64 integrator; hardware filtering of NaN is
        // undefined, so such volumes are interpolated in the shader.
        // (The grid's build reads every voxel and notes NaN.)
        let grid = MinMaxGrid::build(vol);
        let has_nan = matches!(vol.voxels, Voxels::F32(_)) && grid.has_nan;
        let mut packed = vol.normals.map(packed_normals).transpose()?;
        let normal_bytes = packed.as_ref().map_or(0, |n| 4 * n.len() as u64);
        let cpu = cpu_copy(dev, native, format, vol.dims, bytes, &mut packed);
        // Where the native march keeps the texels, the textures wait for a
        // frame on the shader: on a CPU adapter they would double the memory.
        let (view, normals) = match cpu {
            Some(_) => (None, None),
            None => {
                let size = extent_of(vol.dims);
                let view = dev.required_texture("uploading the volume", "volume", size, D3, format, bytes)?;
                (Some(view), packed.as_deref().map(|n| upload_normals(dev, size, n)).transpose()?.map(|(v, _)| v))
            }
        };
        // R8Unorm is filtered in the shader: lavapipe's 8-bit filtering path
        // returns results quantised to 1/255, which loses faint structure
        // (measured: alpha 0.006 instead of 0.029 at a sphere's rim).
        let filterable = match format {
            wgpu::TextureFormat::R8Unorm => false,
            wgpu::TextureFormat::R32Float => dev.caps.float32_filterable && !has_nan,
            _ => true,
        };
        Ok(VolumeGpu {
            filterable,
            view,
            normals,
            normals_apart: vol.normals.is_some(),
            normals_in_volume: false,
            gradients: false,
            format,
            dims: vol.dims,
            bounds: vol.bounds,
            bytes: bytes.len() as u64 + normal_bytes,
            grid,
            projection_bounds: Default::default(),
            stored: ValueMap::IDENTITY,
            cpu,
        })
    }

    /// Values as 16-bit fixed point over their range (`crate::fixed16`):
    /// R16Snorm, or with normals one Rgba16Snorm texel (value, normal) per
    /// voxel, half the bytes of (value, normal) in float32. Float data's
    /// occupancy grid is built from the values the device reads.
    fn upload_fixed16(dev: &Device, vol: &VolumeView, native: CpuCopy) -> Result<VolumeGpu, Error> {
        let coded = Fixed16::encode(vol.voxels)?;
        let grid = match vol.voxels {
            Voxels::F32(_) => {
                let read = try_collect(
                    coded.codes.len(),
                    "coding the volume in 16 bits",
                    coded.codes.iter().map(|&c| Fixed16::decode(coded.map, c) as f32),
                )?;
                MinMaxGrid::build(&VolumeView { voxels: Voxels::F32(&read), ..*vol })
            }
            _ => MinMaxGrid::build(vol),
        };
        let (format, texels) = match vol.normals {
            None => (wgpu::TextureFormat::R16Snorm, coded.codes),
            Some(n) => {
                let mut texels = try_collect(coded.codes.len() * 4, "packing values with normals", std::iter::empty())?;
                for (&c, m) in coded.codes.iter().zip(n.chunks_exact(3)) {
                    let u = unit_direction([m[0], m[1], m[2]]);
                    texels.extend_from_slice(&[c, normal_code(u[0]), normal_code(u[1]), normal_code(u[2])]);
                }
                (wgpu::TextureFormat::Rgba16Snorm, texels)
            }
        };
        let mut gpu = Self::whole_texels(dev, vol, vol.dims, format, bytemuck::cast_slice(&texels), grid, native)?;
        gpu.stored = coded.map;
        Ok(gpu)
    }

    /// Float data as float16: R16Float, or with normals one Rgba16Float texel
    /// (value, normal) per voxel, so that a lit sample fetches once. The
    /// occupancy grid is built from the rounded values the device reads.
    fn upload_f16(dev: &Device, vol: &VolumeView, values: &[f32], native: CpuCopy) -> Result<VolumeGpu, Error> {
        let halves =
            try_collect(values.len(), "converting the volume to float16", values.iter().map(|&v| f32_to_f16(v)))?;
        // Built before the texels so that the rounded copy is freed first
        // (a 512^3 volume's texels alone take 1 GB).
        let grid = {
            let rounded =
                try_collect(halves.len(), "converting the volume to float16", halves.iter().map(|&h| f16_to_f32(h)))?;
            MinMaxGrid::build(&VolumeView { voxels: Voxels::F32(&rounded), ..*vol })
        };
        let (format, data) = match vol.normals {
            None => (wgpu::TextureFormat::R16Float, halves),
            Some(n) => (wgpu::TextureFormat::Rgba16Float, with_normals(&halves, n, f32_to_f16)?.into_flattened()),
        };
        Self::whole_texels(dev, vol, vol.dims, format, bytemuck::cast_slice(&data), grid, native)
    }

    /// A volume whose texels hold everything a sample reads (values, and
    /// normals when given), filtered by the sampler; `texels` is the
    /// texture's size (the volume's, or larger by a border).
    fn whole_texels(
        dev: &Device,
        vol: &VolumeView,
        texels: [usize; 3],
        format: wgpu::TextureFormat,
        bytes: &[u8],
        grid: MinMaxGrid,
        native: CpuCopy,
    ) -> Result<VolumeGpu, Error> {
        let cpu = cpu_copy(dev, native, format, texels, bytes, &mut None);
        let view = match cpu {
            Some(_) => None,
            None => {
                Some(dev.required_texture("uploading the volume", "volume", extent_of(texels), D3, format, bytes)?)
            }
        };
        Ok(VolumeGpu { view, cpu, bytes: bytes.len() as u64, ..Self::described(vol, format, grid) })
    }

    /// A whole volume's description in `format`, with neither texture nor
    /// texels yet.
    fn described(vol: &VolumeView, format: wgpu::TextureFormat, grid: MinMaxGrid) -> VolumeGpu {
        VolumeGpu {
            filterable: true,
            view: None,
            normals: None,
            normals_apart: false,
            normals_in_volume: vol.normals.is_some(),
            gradients: false,
            format,
            dims: vol.dims,
            bounds: vol.bounds,
            bytes: 0,
            grid,
            projection_bounds: Default::default(),
            stored: ValueMap::IDENTITY,
            cpu: None,
        }
    }

    /// `whole_texels` for Rgba32Float texels made here: where the native
    /// march keeps texels it takes these (their subnormals flushed), not a
    /// copy (a 256^3 volume's lit texels are 256 MiB).
    fn whole_rgba32(
        dev: &Device,
        vol: &VolumeView,
        texels: [usize; 3],
        mut data: Vec<[f32; 4]>,
        grid: MinMaxGrid,
        native: CpuCopy,
    ) -> Result<VolumeGpu, Error> {
        let format = wgpu::TextureFormat::Rgba32Float;
        // (Offsets past i32 are the copy's rule too: whole texels of four floats.)
        if !marches_natively(dev, native) || 4 * data.len() >= i32::MAX as usize {
            return Self::whole_texels(dev, vol, texels, format, bytemuck::cast_slice(&data), grid, CpuCopy::No);
        }
        let bytes = 16 * data.len() as u64;
        flush_subnormals(data.as_flattened_mut());
        let cpu = CpuVolume { texels: Texels::Rgba32Float(data), dims: texels, normals: None };
        Ok(VolumeGpu { bytes, cpu: Some(cpu), view: None, ..Self::described(vol, format, grid) })
    }

    /// Whether float32 values and their normals share one Rgba32Float texel
    /// (value, normal): then a lit sample makes one texture fetch instead of
    /// two (docs/performance.md, "Memory and uploads"), and the normals keep
    /// f32 precision; it takes 16 bytes
    /// a voxel instead of 8. Only where the device filters float32 textures
    /// and every value is finite (volumes with NaN are interpolated in the
    /// shader, which reads values alone) and the texels fit one upload.
    pub fn packs_float32(dev: &Device, vol: &VolumeView, precision: Precision) -> bool {
        match (vol.voxels, vol.normals, precision) {
            (Voxels::F32(v), Some(_), Precision::Float32) => Self::rgba32_fits(dev, vol.voxels, v.len() as u64),
            _ => false,
        }
    }

    /// Whether `texels` Rgba32Float texels made from `values` can be
    /// filtered and uploaded: the device filters float32, they fit one
    /// upload, and every value is finite (volumes with NaN are interpolated
    /// in the shader, which reads values alone; integer codes always are).
    fn rgba32_fits(dev: &Device, voxels: Voxels, texels: u64) -> bool {
        dev.caps.float32_filterable
            && texels * 16 <= dev.caps.max_buffer
            && !matches!(voxels, Voxels::F32(v) if !v.iter().all(|x| x.is_finite()))
    }

    /// Float32 values with their normals' directions, one Rgba32Float texel each.
    fn upload_packed_f32(
        dev: &Device,
        vol: &VolumeView,
        values: &[f32],
        normals: &[f32],
        native: CpuCopy,
    ) -> Result<VolumeGpu, Error> {
        let texels = with_normals(values, normals, |c| c)?;
        Self::whole_rgba32(dev, vol, vol.dims, texels, MinMaxGrid::build(vol), native)
    }

    /// Values (float32, or integer codes as the fractions of their range
    /// the shader reads) with their gradients (`gradients::bordered_texels`),
    /// one Rgba32Float texel each, for gradient-shaded frames: a lit sample
    /// then fetches once instead of seven times. None where the device
    /// cannot filter float32 textures, a value is not finite, or the texels
    /// pass its limits. `grid` is the volume's own: the shader
    /// takes the border off before finding a sample's cell.
    pub fn with_gradients(dev: &Device, vol: &VolumeView, grid: &MinMaxGrid) -> Result<Option<VolumeGpu>, Error> {
        let big = vol.dims.map(|d| d + 2);
        let texels = big.iter().product::<usize>() as u64;
        let max3d = dev.caps.max_texture_3d;
        if big.iter().any(|&d| d > max3d) || !Self::rgba32_fits(dev, vol.voxels, texels) {
            return Ok(None);
        }
        // Only the spacings' ratios matter: in units of the box's longest
        // side (as the shader's are), a box light years or femtometres
        // across neither flushes the gradients to 0 nor overflows them.
        let extent = vol.bounds.extent().to_array();
        let unit = extent.iter().copied().fold(0.0, f64::max);
        let spacing = std::array::from_fn(|a| extent[a] / unit / vol.dims[a] as f64);
        // Integer codes as the fractions of their range the shader reads.
        let data = match vol.voxels {
            Voxels::F32(v) => gradients::bordered_texels(|n| v[n], vol.dims, spacing),
            Voxels::U8(v) => gradients::bordered_texels(|n| v[n] as f32 / 255.0, vol.dims, spacing),
            Voxels::U16(v) => gradients::bordered_texels(|n| v[n] as f32 / 65535.0, vol.dims, spacing),
        }?;
        let mut gpu = Self::whole_rgba32(dev, vol, big, data, grid.clone(), CpuCopy::Always)?;
        gpu.normals_in_volume = true;
        gpu.gradients = true;
        Ok(Some(gpu))
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

/// (value, normal direction) texels: each value followed by its normal's
/// unit direction, converted by `component`.
fn with_normals<T: Copy>(values: &[T], normals: &[f32], component: impl Fn(f32) -> T) -> Result<Vec<[T; 4]>, Error> {
    let texels = values.iter().zip(normals.chunks_exact(3)).map(|(&v, c)| {
        let u = unit_direction([c[0], c[1], c[2]]);
        [v, component(u[0]), component(u[1]), component(u[2])]
    });
    try_collect(values.len(), "packing values with normals", texels)
}

/// numpy's last axis is the fastest: it becomes the texture's x.
fn extent_of([s0, s1, s2]: [usize; 3]) -> wgpu::Extent3d {
    wgpu::Extent3d { width: s2 as u32, height: s1 as u32, depth_or_array_layers: s0 as u32 }
}

/// 4 bytes per voxel: each normal's direction (normals are directions;
/// VolumeView::normal reads them so too), its components to 1/127, where
/// they cannot share the values' texels. The lighting error this allows is
/// under 0.4% (against f32 normals: at most 1 level, mean 0.004), with half
/// the bytes a lit sample fetches of a separate Rgba16Float texture.
/// Normals as Rgba8Snorm texels: each unit direction's components in codes
/// of 1/127, and a fourth byte unused.
fn packed_normals(n: &[f32]) -> Result<Vec<[i8; 4]>, Error> {
    let q = |v: f32| (v * 127.0).round() as i8;
    try_collect(
        n.len() / 3,
        "packing the normals",
        n.chunks_exact(3).map(|c| {
            let u = unit_direction([c[0], c[1], c[2]]);
            [q(u[0]), q(u[1]), q(u[2]), 0]
        }),
    )
}

fn upload_normals(dev: &Device, size: wgpu::Extent3d, packed: &[[i8; 4]]) -> Result<(wgpu::TextureView, u64), Error> {
    let data: &[u8] = bytemuck::cast_slice(packed);
    let snorm8 = wgpu::TextureFormat::Rgba8Snorm;
    let view = dev.required_texture("uploading the normals", "normals", size, D3, snorm8, data)?;
    Ok((view, data.len() as u64))
}

/// RGBA rows as a filterable texture: f32 when the device can filter it,
/// else f16 (`cap` caps values f16 cannot hold).
fn float_table(dev: &Device, rows: &[[f32; 4]], cap: Option<f32>) -> (wgpu::TextureFormat, Vec<u8>) {
    if dev.caps.float32_filterable {
        (wgpu::TextureFormat::Rgba32Float, bytemuck::cast_slice(rows).to_vec())
    } else {
        let h: Vec<u16> = rows.iter().flatten().map(|&v| f32_to_f16(cap.map_or(v, |c| v.min(c)))).collect();
        (wgpu::TextureFormat::Rgba16Float, bytemuck::cast_slice(&h).to_vec())
    }
}

/// The pre-integration texture's texels, `side` wide: the `side` x `side`
/// table, then the running sums of the opacity change between `lut`'s
/// entries (`preintegrate::opacity_change_sums`, in every channel; read by
/// refined frames), then the transfer-function table `lut`, so that a
/// pre-integrated frame reads a shorter segment's midpoint entry from the
/// same texture as a full segment's, in one fetch chosen by select (a fetch
/// of its own, in a branch, cost 12-18% of such a frame on lavapipe). Both
/// are wrapped into rows of the table's width (`preintegrate::wrapped_rows`):
/// a longer transfer function made every row as wide as itself, 34 MB of
/// texels at 4096 entries instead of 4.4. Each row of `lut` comes twice, and
/// frames sample it between the two, where the sampler's filtering mixes
/// the row with nothing but itself. Rows short of the width repeat their
/// last entry.
fn with_lut_row(key: &PreintKey, lut: &[[f32; 4]]) -> crate::cpu::PreintTable {
    let side = preintegrate::table_side(lut.len());
    let rows = preintegrate::wrapped_rows(lut.len(), side);
    let mut texels = Vec::with_capacity(side * (side + 3 * rows));
    preintegrate::append_table(lut, key.len_over_ref, key.form, key.reach, &mut texels);
    let wrapped = |texels: &mut Vec<[f32; 4]>, entries: &[[f32; 4]], copies: usize| {
        let last = entries.last().copied().unwrap_or([0.0; 4]);
        for r in 0..rows {
            for _ in 0..copies {
                texels.extend((0..side).map(|c| entries.get(r * (side - 1) + c).copied().unwrap_or(last)));
            }
        }
    };
    let sums: Vec<[f32; 4]> = preintegrate::opacity_change_sums(lut).into_iter().map(|c| [c; 4]).collect();
    wrapped(&mut texels, &sums, 1);
    wrapped(&mut texels, lut, 2);
    crate::cpu::PreintTable { texels, side, rows }
}

/// The transfer-function table and what is derived from it.
pub struct Tables {
    /// The table (entries at scalars m / (M - 1)) as an M x 1 texture the
    /// sampler interpolates, and M.
    pub lut: Option<(Option<wgpu::TextureView>, u32)>,
    /// The rows last uploaded, kept to recompute occupancy and pre-integration.
    pub rows: Vec<[f32; 4]>,
    /// A one-entry table as two equal entries: the native march reads a
    /// sample's pair of neighbouring entries (a texture of one entry is the
    /// same constant to the sampler).
    pair: [[f32; 4]; 2],
    /// Bumped by every upload, so derived tables know when to rebuild.
    pub version: u64,
    /// The pre-integration table and what it was built for; its texture
    /// is uploaded when a frame on the device first needs it (the native
    /// march reads only the texels).
    pub preint: Option<(Option<wgpu::TextureView>, PreintKey)>,
    /// The same texture's texels, for the native march.
    pub preint_texels: crate::cpu::PreintTable,
    /// Tables of this transfer function for other segment lengths, latest
    /// first: a session that switches steps (a coarse step while the view
    /// moves, a fine one at rest; pilots of a step search) swaps them back
    /// in instead of rebuilding.
    preint_spares: Vec<(Option<wgpu::TextureView>, PreintKey, crate::cpu::PreintTable)>,
}

/// Pre-integration tables kept besides the current one, and the most
/// their texels may take together: 1 MiB for 256 entries (and as much
/// again on the device), 4.2-5.2 MiB from 512 entries on (`with_lut_row`).
const PREINT_SPARES: usize = 3;
const PREINT_SPARE_BYTES: usize = 24 << 20;

/// What a pre-integration table depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreintKey {
    pub lut_version: u64,
    pub len_over_ref: f64,
    pub form: OpacityCorrection,
    /// Entries apart that a segment's front and back can lie
    /// (`preintegrate::table_reach`): only those are integrated.
    pub reach: usize,
}

impl Tables {
    pub fn new() -> Tables {
        Tables {
            lut: None,
            rows: Vec::new(),
            pair: [[0.0; 4]; 2],
            version: 0,
            preint: None,
            preint_texels: Default::default(),
            preint_spares: Vec::new(),
        }
    }

    /// Uploads the table: a texture fetch is far cheaper than an indexed
    /// storage-buffer read on CPU drivers; f16 (where f32 cannot be filtered)
    /// is within 0.13 of an 8-bit level. Returns the bytes written.
    pub fn upload_lut(&mut self, dev: &Device, lut: &[[f32; 4]]) -> Result<u64, Error> {
        if lut.is_empty() {
            return Err(Error::InvalidInput("the transfer-function table must have at least one entry".into()));
        }
        let max = dev.caps.max_texture_2d;
        if lut.len() > max {
            return Err(Error::DeviceLimit(format!(
                "transfer-function table of {} entries exceeds this device's limit of {max} entries",
                lut.len()
            )));
        }
        let (format, bytes) = float_table(dev, lut, None);
        let size = wgpu::Extent3d { width: lut.len() as u32, height: 1, depth_or_array_layers: 1 };
        let view = dev.texture("uploading the transfer function", "lut", size, D2, format, &bytes)?;
        // (Without a device nothing is uploaded.)
        let uploaded = if view.is_some() { bytes.len() as u64 } else { 0 };
        self.lut = Some((view, lut.len() as u32));
        self.rows = lut.to_vec();
        self.pair = [lut[0]; 2];
        self.version += 1;
        self.preint_spares.clear();
        Ok(uploaded)
    }

    /// The table as the native march reads it: at least two entries.
    pub fn march_rows(&self) -> &[[f32; 4]] {
        if self.rows.len() >= 2 {
            &self.rows
        } else {
            &self.pair
        }
    }

    /// Makes the pre-integration table for `key` current: the current one
    /// if it was built for `key`, else a kept one, else a new one (its
    /// texture not yet uploaded: `upload_preint`). Returns whether the table
    /// changed.
    pub fn ensure_preint(&mut self, key: PreintKey) -> bool {
        if self.preint.as_ref().is_some_and(|(_, k)| *k == key) {
            return false;
        }
        if let Some(i) = self.preint_spares.iter().position(|(_, k, _)| *k == key) {
            let (view, key, texels) = self.preint_spares.remove(i);
            self.keep_current_preint();
            self.preint = Some((view, key));
            self.preint_texels = texels;
            return true;
        }
        let texels = with_lut_row(&key, &self.rows);
        self.keep_current_preint();
        self.preint = Some((None, key));
        self.preint_texels = texels;
        true
    }

    /// Uploads the current pre-integration table's texture if it is not
    /// yet (`preint`); returns the bytes that took.
    pub fn upload_preint(&mut self, dev: &Device) -> Result<u64, Error> {
        let Some((view @ None, _)) = self.preint.as_mut() else {
            return Ok(0);
        };
        let t = &self.preint_texels;
        // f16 tops out at 65504: deeper segments are opaque anyway.
        let (format, bytes) = float_table(dev, &t.texels, Some(6.0e4));
        let height = (t.side + 3 * t.rows) as u32;
        let size = wgpu::Extent3d { width: t.side as u32, height, depth_or_array_layers: 1 };
        let uploaded = dev.ctx().texture_with_data(
            "uploading the pre-integration table",
            "preint",
            size,
            D2,
            format,
            1,
            &bytes,
        )?;
        *view = Some(uploaded);
        Ok(bytes.len() as u64)
    }

    /// Moves the current table to the front of the spares if it is for the
    /// current transfer function.
    fn keep_current_preint(&mut self) {
        if let Some((view, key)) = self.preint.take() {
            let texels = std::mem::take(&mut self.preint_texels);
            if key.lut_version == self.version {
                self.preint_spares.insert(0, (view, key, texels));
                self.preint_spares.truncate(PREINT_SPARES);
                let bytes = |t: &crate::cpu::PreintTable| std::mem::size_of_val(t.texels.as_slice());
                while self.preint_spares.iter().map(|(_, _, t)| bytes(t)).sum::<usize>() > PREINT_SPARE_BYTES {
                    self.preint_spares.pop();
                }
            }
        }
    }
}

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

/// The image a frame writes and its readback copy (16 bytes per pixel).
pub struct Output {
    pub storage: wgpu::Buffer,
    pub readback: wgpu::Buffer,
}

impl Output {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Output, Error> {
        let size = width as u64 * height as u64 * 16;
        let device = &ctx.device;
        ctx.scoped("allocating the output image", || Output {
            storage: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("image"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: readback_buffer(device, "image readback", size),
        })
    }
}

pub fn readback_buffer(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Where rays wait between passes: 16 bytes of state and a done flag per
/// pixel. A one-pixel placeholder pair is bound while every frame fits one pass.
pub struct RayState {
    pub state: wgpu::Buffer,
    pub done: wgpu::Buffer,
    pub pixels: u64,
}

impl RayState {
    pub fn new(ctx: &GpuContext, pixels: u64) -> Result<RayState, Error> {
        let device = &ctx.device;
        ctx.scoped("allocating ray state", || RayState {
            state: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ray state"),
                size: pixels * 16,
                // Copied out for the isosurface model's depth image.
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            done: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ray done"),
                size: pixels * 4,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }),
            pixels,
        })
    }
}

/// Samplers and the placeholders bound where a frame needs no normals or
/// pre-integration table.
pub struct Fixed {
    pub no_normals: wgpu::TextureView,
    pub no_preint: wgpu::TextureView,
    /// [non-filtering, filtering]: the volume's sampler by filterability.
    pub volume_samplers: [wgpu::Sampler; 2],
    pub linear_sampler: wgpu::Sampler,
}

impl Fixed {
    pub fn new(ctx: &GpuContext) -> Result<Fixed, Error> {
        let device = &ctx.device;
        let no_normals = ctx.scoped("allocating renderer buffers", || {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some("no normals"),
                    size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: D3,
                    format: wgpu::TextureFormat::Rgba16Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        })?;
        let sampler = |filter: wgpu::FilterMode| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("volume"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                address_mode_w: wgpu::AddressMode::ClampToEdge,
                mag_filter: filter,
                min_filter: filter,
                mipmap_filter: wgpu::MipmapFilterMode::Nearest,
                ..Default::default()
            })
        };
        let volume_samplers = [sampler(wgpu::FilterMode::Nearest), sampler(wgpu::FilterMode::Linear)];
        let linear_sampler = sampler(wgpu::FilterMode::Linear);
        let one = wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 };
        let no_preint = ctx.texture_with_data(
            "allocating renderer buffers",
            "no table",
            one,
            D2,
            wgpu::TextureFormat::Rgba16Float,
            1,
            &[0u8; 8],
        )?;
        Ok(Fixed { no_normals, no_preint, volume_samplers, linear_sampler })
    }
}
