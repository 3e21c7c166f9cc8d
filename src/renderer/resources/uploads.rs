//! How a volume is stored: the texel format each precision and device
//! takes, the native march's copy of the texels, and the textures made
//! from them.

use super::*;
use crate::cpu::{CpuVolume, Texels};
use crate::error::Error;
use crate::error::{try_collect, try_vec};
use crate::fixed16::{normal_code, Fixed16};
use crate::gradients;
use crate::half::{f16_to_f32, f32_to_f16};
use crate::occupancy::MinMaxGrid;
use crate::renderer::device::Device;
use crate::transfer::ValueMap;
use crate::volume::{sanitize, unit_direction, Precision, VolumeView, Voxels};

impl VolumeGpu {
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
    pub(super) fn upload_fixed16(dev: &Device, vol: &VolumeView, native: CpuCopy) -> Result<VolumeGpu, Error> {
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
    pub(super) fn upload_f16(
        dev: &Device,
        vol: &VolumeView,
        values: &[f32],
        native: CpuCopy,
    ) -> Result<VolumeGpu, Error> {
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
    pub(super) fn whole_texels(
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
    pub(super) fn described(vol: &VolumeView, format: wgpu::TextureFormat, grid: MinMaxGrid) -> VolumeGpu {
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
    pub(super) fn whole_rgba32(
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
    pub(super) fn rgba32_fits(dev: &Device, voxels: Voxels, texels: u64) -> bool {
        dev.caps.float32_filterable
            && texels * 16 <= dev.caps.max_buffer
            && !matches!(voxels, Voxels::F32(v) if !v.iter().all(|x| x.is_finite()))
    }

    /// Float32 values with their normals' directions, one Rgba32Float texel each.
    pub(super) fn upload_packed_f32(
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
}

/// The texels for the native march: only where the caller asks
/// (`native`), the adapter is a CPU (whose "device memory" is the same RAM)
/// and the march runs there, and with `IfRoom` only while they take at
/// most half the memory the system says is available (frames then stay on
/// the shader): with a frame on the shader they double what the volume
/// takes, and a process over its memory is killed, not told.
pub(super) fn cpu_copy(
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
pub(super) fn marches_natively(dev: &Device, native: CpuCopy) -> bool {
    native != CpuCopy::No && dev.caps.native
}

/// Subnormal floats to zero (keeping the sign): fields that fall off
/// exponentially hold them far from their features, and on a CPU each
/// operation reading one takes a microcode assist. They stand for
/// values under 1.2e-38, which GPUs that flush subnormals read as zero too.
pub(super) fn flush_subnormals(x: &mut [f32]) {
    for v in x {
        if v.abs() < f32::MIN_POSITIVE {
            *v *= 0.0;
        }
    }
}

/// `bytes` as texels of type T, then `extra` zero texels; None where the
/// memory cannot be had.
pub(super) fn copied<T: bytemuck::Pod>(bytes: &[u8], extra: usize) -> Option<Vec<T>> {
    let n = bytes.len() / std::mem::size_of::<T>();
    let mut v = try_vec(n + extra, T::zeroed(), "the native march's texels").ok()?;
    bytemuck::cast_slice_mut::<T, u8>(&mut v[..n]).copy_from_slice(&bytes[..n * std::mem::size_of::<T>()]);
    Some(v)
}

/// Memory the system can give without swapping (Linux's MemAvailable), if known.
pub(super) fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// (value, normal direction) texels: each value followed by its normal's
/// unit direction, converted by `component`.
pub(super) fn with_normals<T: Copy>(
    values: &[T],
    normals: &[f32],
    component: impl Fn(f32) -> T,
) -> Result<Vec<[T; 4]>, Error> {
    let texels = values.iter().zip(normals.chunks_exact(3)).map(|(&v, c)| {
        let u = unit_direction([c[0], c[1], c[2]]);
        [v, component(u[0]), component(u[1]), component(u[2])]
    });
    try_collect(values.len(), "packing values with normals", texels)
}

/// numpy's last axis is the fastest: it becomes the texture's x.
pub(super) fn extent_of([s0, s1, s2]: [usize; 3]) -> wgpu::Extent3d {
    wgpu::Extent3d { width: s2 as u32, height: s1 as u32, depth_or_array_layers: s0 as u32 }
}

/// 4 bytes per voxel: each normal's direction (normals are directions;
/// VolumeView::normal reads them so too), its components to 1/127, where
/// they cannot share the values' texels. The lighting error this allows is
/// under 0.4% (against f32 normals: at most 1 level, mean 0.004), with half
/// the bytes a lit sample fetches of a separate Rgba16Float texture.
/// Normals as Rgba8Snorm texels: each unit direction's components in codes
/// of 1/127, and a fourth byte unused.
pub(super) fn packed_normals(n: &[f32]) -> Result<Vec<[i8; 4]>, Error> {
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

pub(super) fn upload_normals(
    dev: &Device,
    size: wgpu::Extent3d,
    packed: &[[i8; 4]],
) -> Result<(wgpu::TextureView, u64), Error> {
    let data: &[u8] = bytemuck::cast_slice(packed);
    let snorm8 = wgpu::TextureFormat::Rgba8Snorm;
    let view = dev.required_texture("uploading the normals", "normals", size, D3, snorm8, data)?;
    Ok((view, data.len() as u64))
}
