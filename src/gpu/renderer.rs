//! A renderer's GPU resources and its frame. Resources live as long as the
//! renderer and are replaced only when their input changes: a camera, light
//! or config change rewrites one 256-byte uniform block and nothing else.

use super::bindings;
use super::context::{GpuContext, GpuError};
use super::half::{f16_to_f32, f32_to_f16};
use super::pipeline::{Layout, Pipelines, Variant, WORKGROUP};
use crate::config::{OpacityCorrection, RenderConfig};
use crate::model::Model;
use crate::preintegrate;
use crate::occupancy::{pyramid, MinMaxGrid};
use crate::scene::{Bounds, Camera, Light, LightKind, Shading};
use crate::transfer::ValueMap;
use crate::volume::{sanitize, Precision, VolumeView, Voxels};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use std::sync::{Arc, OnceLock};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, Default)]
struct Params {
    cam_pos: [f32; 4],
    cam_fwd: [f32; 4],
    cam_right: [f32; 4],
    cam_up: [f32; 4],
    extent: [f32; 4],
    inv_extent: [f32; 4],
    inv_two_spacing: [f32; 4],
    light_pos: [f32; 4],
    light_dir: [f32; 4],
    step_size: f32,
    inv_ref: f32,
    ambient: f32,
    diffuse: f32,
    threshold: f32,
    max_steps: u32,
    width: u32,
    height: u32,
    lut_size: u32,
    light_valid: u32,
    pass_start: u32,
    pass_steps: u32,
    first_pass: u32,
    last_pass: u32,
    occ_levels: u32,
    jitter_seed: u32,
    iso_value: f32,
    /// Henyey–Greenstein g.
    anisotropy: f32,
    shadow_step: f32,
    /// Side of the pre-integration table.
    preint_side: f32,
    /// Sampled value -> transfer-function domain: v * scale + offset.
    value_scale: f32,
    value_offset: f32,
    value_pad: [f32; 2],
    /// The box rays march in, relative to the volume's min corner.
    clip_lo: [f32; 4],
    clip_hi: [f32; 4],
}

/// Steps one dispatch marches at most. Below lavapipe's 65535-iteration loop
/// cap, and short enough that a pass stays far from GPU watchdog timeouts.
pub const PASS_STEPS: u32 = 16384;
/// Loop iterations one invocation may run in one dispatch (lavapipe stops
/// loops at 65535 iterations, nested loops included).
const PASS_ITERATIONS: u64 = 60_000;
/// Longest shadow ray, in steps, single scattering accepts.
pub const MAX_SHADOW_STEPS: u64 = 30_000;

fn v4(v: DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// Leaping over empty cells makes every sample's loop heavier: it pays only
/// when enough of the volume is empty. Measured on lavapipe (benchmark scene,
/// 512^2, step 0.1): with 18.7% of cells empty, the leaps removed 3% of the
/// samples and made the frame 25% slower.
const SKIP_MIN_EMPTY: f64 = 0.25;

struct VolumeGpu {
    /// The stored format can be filtered by the sampler.
    filterable: bool,
    view: wgpu::TextureView,
    /// Normals in their own texture.
    normals: Option<wgpu::TextureView>,
    /// Normals in the volume's texels: (value, nx, ny, nz), Rgba16Float.
    normals_in_volume: bool,
    /// The device's texel format for the values, for reports.
    format: wgpu::TextureFormat,
    dims: [usize; 3],
    bounds: Bounds,
    bytes: u64,
    grid: MinMaxGrid,
}

struct Output {
    storage: wgpu::Buffer,
    readback: wgpu::Buffer,
}

/// Where rays wait between passes: 16 bytes of state and a done flag per
/// pixel. A one-pixel placeholder pair is bound while every frame fits one pass.
struct RayState {
    state: wgpu::Buffer,
    done: wgpu::Buffer,
    pixels: u64,
}

impl RayState {
    fn new(device: &wgpu::Device, pixels: u64) -> RayState {
        let buf = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        let state = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ray state"),
            size: pixels * 16,
            // Copied out for the isosurface model's depth image.
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        RayState { state, done: buf("ray done", pixels * 4), pixels }
    }
}

/// What one frame did, for tests and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Largest step count a ray needed when `max_steps` cut it short; 0 if none.
    pub truncated_needed: u32,
    /// Bytes written to the GPU for this frame (uniforms only, unless a
    /// volume, LUT or image size changed since the last frame).
    pub uploaded_bytes: u64,
    /// Dispatches the frame took (rays longer than PASS_STEPS need several).
    pub passes: u32,
    /// Samples the frame took over all rays (skipped empty space not counted).
    pub samples: u64,
}

/// Counters over the renderer's life.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counters {
    pub frames: u64,
    pub volume_uploads: u64,
    pub lut_uploads: u64,
    pub uploaded_bytes: u64,
}

pub struct GpuRenderer {
    ctx: Arc<GpuContext>,
    pipelines: Arc<Pipelines>,
    width: u32,
    height: u32,
    uniform: wgpu::Buffer,
    stats: wgpu::Buffer,
    stats_readback: wgpu::Buffer,
    dummy_normals: wgpu::TextureView,
    /// [non-filtering, filtering]: the volume's sampler by filterability.
    volume_samplers: [wgpu::Sampler; 2],
    linear_sampler: wgpu::Sampler,
    volume: Option<VolumeGpu>,
    /// The table last uploaded, kept to recompute occupancy for a new volume.
    lut_rows: Vec<[f32; 4]>,
    occupancy: Option<wgpu::TextureView>,
    /// What the occupancy grid was built from.
    occ_source: Option<OccSource>,
    /// Fraction of level-0 cells the current table leaves empty. Above 0 the
    /// skipping variant is worth its cost (its branch slows dense scenes by
    /// ~20% on lavapipe); at 1 no ray needs marching.
    empty_fraction: f64,
    /// Mip levels of the occupancy texture (cells of 8, 16, 32, 64 voxels).
    occ_levels: u32,
    /// Leap over empty cells (on by default; off to measure what it saves).
    pub skip_empty: bool,
    bound_hw_filter: bool,
    /// Interpolate in the shader even when the format could be filtered
    /// (the path used without FLOAT32_FILTERABLE); for tests and comparisons.
    pub shader_filtering: bool,
    lut: Option<(wgpu::TextureView, u32)>,
    /// Bumped by every set_lut, so derived tables know when to rebuild.
    lut_version: u64,
    /// Sampled value -> table domain.
    value_map: ValueMap,
    /// Crop box in world coordinates (None: the whole volume).
    clip: Option<Bounds>,
    /// The pre-integration table and what it was built for.
    preint: Option<(wgpu::TextureView, PreintKey)>,
    /// Bound when no frame has needed a pre-integration table.
    dummy_preint: wgpu::TextureView,
    /// The last frame was an isosurface: its depth is in the ray state.
    depth_ready: bool,
    output: Option<Output>,
    ray_state: RayState,
    bind_group: Option<wgpu::BindGroup>,
    pending_upload: u64,
    pub counters: Counters,
}

/// What decides which occupancy cells are empty.
#[derive(Clone, Copy, Debug, PartialEq)]
enum OccSource {
    /// Zero opacity under this version of the transfer function.
    Lut(u64),
    /// Values below this iso value (bits of the f64).
    Below(u64),
}

/// What a pre-integration table depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PreintKey {
    lut_version: u64,
    len_over_ref: f64,
    form: OpacityCorrection,
}

static PIPELINES: OnceLock<Result<Arc<Pipelines>, GpuError>> = OnceLock::new();

fn shared_pipelines(ctx: &GpuContext) -> Result<Arc<Pipelines>, GpuError> {
    PIPELINES.get_or_init(|| Pipelines::new(ctx).map(Arc::new)).clone()
}

impl GpuRenderer {
    pub fn new(width: u32, height: u32) -> Result<GpuRenderer, GpuError> {
        let ctx = GpuContext::get()?;
        let pipelines = shared_pipelines(&ctx)?;
        let device = &ctx.device;
        let (uniform, stats, stats_readback, dummy_normals) = ctx.scoped("allocating renderer buffers", || {
            let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let stats = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("stats"),
                size: 12,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let stats_readback = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("stats readback"),
                size: 12,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let dummy = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("no normals"),
                size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::Rgba16Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let view = dummy.create_view(&Default::default());
            (uniform, stats, stats_readback, view)
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
        let ray_state = ctx.scoped("allocating ray state", || RayState::new(device, 1))?;
        let linear_sampler = sampler(wgpu::FilterMode::Linear);
        let d2 = wgpu::TextureDimension::D2;
        let one = wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 };
        let dummy_preint =
            ctx.texture_with_data("allocating renderer buffers", "no table", one, d2, wgpu::TextureFormat::Rgba16Float, 1, &[0u8; 8])?;
        let mut r = GpuRenderer {
            ctx,
            pipelines,
            width: 1,
            height: 1,
            uniform,
            stats,
            stats_readback,
            dummy_normals,
            volume_samplers,
            linear_sampler,
            volume: None,
            lut_rows: Vec::new(),
            occupancy: None,
            occ_source: None,
            empty_fraction: 0.0,
            occ_levels: 1,
            skip_empty: true,
            bound_hw_filter: false,
            shader_filtering: false,
            lut: None,
            lut_version: 0,
            value_map: ValueMap::IDENTITY,
            clip: None,
            preint: None,
            dummy_preint,
            depth_ready: false,
            output: None,
            ray_state,
            bind_group: None,
            pending_upload: 0,
            counters: Counters::default(),
        };
        r.resize(width, height)?;
        Ok(r)
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Bytes the current volume (and normals) occupy on the GPU.
    pub fn volume_bytes(&self) -> u64 {
        self.volume.as_ref().map_or(0, |v| v.bytes)
    }

    /// How the current volume is stored: its texel format, and where the
    /// normals are ("" without a volume).
    pub fn volume_storage(&self) -> String {
        self.volume.as_ref().map_or(String::new(), |v| {
            let texel = format!("{:?}", v.format).to_lowercase();
            match (v.normals.is_some(), v.normals_in_volume) {
                (true, _) => format!("{texel} + rgba8snorm normals"),
                (false, true) => format!("{texel} (value, normal)"),
                (false, false) => texel,
            }
        })
    }

    pub fn cached_variants(&self) -> usize {
        self.pipelines.cached_variants()
    }

    /// Checks an image size against the device's limits.
    pub fn check_size(ctx: &GpuContext, width: u32, height: u32) -> Result<(), GpuError> {
        if width == 0 || height == 0 {
            return Err(GpuError(format!("width and height must be positive, got {width}x{height}")));
        }
        let bytes = width as u64 * height as u64 * 16;
        let limit = ctx.max_storage_bytes();
        if bytes > limit {
            return Err(GpuError(format!(
                "image {width}x{height} needs {bytes} bytes of output, over this device's limit of {limit} \
                 bytes (at most {} pixels)",
                limit / 16
            )));
        }
        let groups = ctx.limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
        if width as u64 > groups || height as u64 > groups {
            return Err(GpuError(format!(
                "image {width}x{height} exceeds this device's limit of {groups} pixels per side"
            )));
        }
        Ok(())
    }

    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        Self::check_size(&self.ctx, width, height)?;
        if self.output.is_some() && (width, height) == (self.width, self.height) {
            return Ok(());
        }
        let size = width as u64 * height as u64 * 16;
        let device = &self.ctx.device;
        let out = self.ctx.scoped("allocating the output image", || Output {
            storage: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("image"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("image readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        })?;
        self.output = Some(out);
        self.width = width;
        self.height = height;
        self.bind_group = None;
        Ok(())
    }

    /// Uploads a volume (and its normals), replacing the previous one, with
    /// float data stored exactly.
    pub fn set_volume(&mut self, vol: &VolumeView) -> Result<(), GpuError> {
        self.set_volume_with_precision(vol, Precision::Float32)
    }

    /// Uploads a volume, storing float data at `precision`.
    pub fn set_volume_with_precision(&mut self, vol: &VolumeView, precision: Precision) -> Result<(), GpuError> {
        let ctx = self.ctx.clone();
        let max3d = ctx.limits.max_texture_dimension_3d as usize;
        if let Some(&big) = vol.dims.iter().find(|&&d| d > max3d) {
            return Err(GpuError(format!(
                "volume shape {:?} has an axis of {big} voxels, over this device's 3-D texture limit \
                 of {max3d}",
                vol.dims
            )));
        }
        let [s0, s1, s2] = vol.dims;
        // numpy's last axis is the fastest: it becomes the texture's x.
        let size = wgpu::Extent3d { width: s2 as u32, height: s1 as u32, depth_or_array_layers: s0 as u32 };
        let unorm16 = ctx.features.contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM);
        if let (Voxels::F32(v), Precision::Float16) = (vol.voxels, precision) {
            precision.check(v).map_err(|e| GpuError(e.0))?;
            return self.set_volume_f16(vol, v);
        }
        let converted: Vec<u8>;
        let (format, bytes, bpp): (wgpu::TextureFormat, &[u8], u32) = match vol.voxels {
            Voxels::U8(v) => (wgpu::TextureFormat::R8Unorm, v, 1),
            Voxels::U16(v) if unorm16 => (wgpu::TextureFormat::R16Unorm, bytemuck::cast_slice(v), 2),
            Voxels::U16(v) => {
                let f: Vec<f32> = v.iter().map(|&x| x as f32 / 65535.0).collect();
                converted = bytemuck::cast_slice(&f).to_vec();
                (wgpu::TextureFormat::R32Float, &converted, 4)
            }
            Voxels::F32(v) => {
                if v.iter().any(|x| x.is_infinite()) {
                    let f: Vec<f32> = v.iter().map(|&x| sanitize(x)).collect();
                    converted = bytemuck::cast_slice(&f).to_vec();
                    (wgpu::TextureFormat::R32Float, &converted, 4)
                } else {
                    (wgpu::TextureFormat::R32Float, bytemuck::cast_slice(v), 4)
                }
            }
        };
        debug_assert_eq!(bytes.len(), s0 * s1 * s2 * bpp as usize);
        let d3 = wgpu::TextureDimension::D3;
        let view = ctx.texture_with_data("uploading the volume", "volume", size, d3, format, 1, bytes)?;
        // R8Unorm is filtered in the shader: lavapipe's 8-bit filtering path
        // returns results quantised to 1/255, which loses faint structure
        // (measured: alpha 0.006 instead of 0.029 at a sphere's rim).
        let filterable = match format {
            wgpu::TextureFormat::R8Unorm => false,
            wgpu::TextureFormat::R32Float => ctx.features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            _ => true,
        };
        let mut total = bytes.len() as u64;
        let normals = match vol.normals {
            None => None,
            Some(n) => {
                // 4 bytes per voxel: each normal's direction (normals are
                // directions; VolumeView::normal reads them so too), its
                // components to 1/127. The lighting error this allows is under
                // 0.4% (against f32 normals: at most 1 level, mean 0.004), and
                // on lavapipe the lit frame is 18% faster than with Rgba16Float.
                let mut packed: Vec<i8> = Vec::with_capacity(n.len() / 3 * 4);
                for c in n.chunks_exact(3) {
                    let u = crate::volume::unit_direction([c[0], c[1], c[2]]);
                    let q = |v: f32| (v * 127.0).round() as i8;
                    packed.extend_from_slice(&[q(u[0]), q(u[1]), q(u[2]), 0]);
                }
                let data: &[u8] = bytemuck::cast_slice(&packed);
                total += data.len() as u64;
                let snorm8 = wgpu::TextureFormat::Rgba8Snorm;
                Some(ctx.texture_with_data("uploading the normals", "normals", size, d3, snorm8, 1, data)?)
            }
        };
        let grid = MinMaxGrid::build(vol);
        self.install_volume(VolumeGpu {
            filterable,
            view,
            normals,
            normals_in_volume: false,
            format,
            dims: vol.dims,
            bounds: vol.bounds,
            bytes: total,
            grid,
        })
    }

    /// Float data as float16: R16Float, or with normals one Rgba16Float texel
    /// (value, normal) per voxel, so that a lit sample fetches once. The
    /// occupancy grid is built from the rounded values the device reads.
    fn set_volume_f16(&mut self, vol: &VolumeView, values: &[f32]) -> Result<(), GpuError> {
        let [s0, s1, s2] = vol.dims;
        let size = wgpu::Extent3d { width: s2 as u32, height: s1 as u32, depth_or_array_layers: s0 as u32 };
        let halves: Vec<u16> = values.iter().map(|&v| f32_to_f16(v)).collect();
        // Built before the texels so that the rounded copy is freed first
        // (a 512^3 volume's texels alone take 1 GB).
        let grid = {
            let rounded: Vec<f32> = halves.iter().map(|&h| f16_to_f32(h)).collect();
            MinMaxGrid::build(&VolumeView { voxels: Voxels::F32(&rounded), ..*vol })
        };
        let (format, data) = match vol.normals {
            None => (wgpu::TextureFormat::R16Float, halves),
            Some(n) => {
                let mut texels = Vec::with_capacity(halves.len() * 4);
                for (&h, c) in halves.iter().zip(n.chunks_exact(3)) {
                    let u = crate::volume::unit_direction([c[0], c[1], c[2]]);
                    texels.extend_from_slice(&[h, f32_to_f16(u[0]), f32_to_f16(u[1]), f32_to_f16(u[2])]);
                }
                (wgpu::TextureFormat::Rgba16Float, texels)
            }
        };
        let bytes: &[u8] = bytemuck::cast_slice(&data);
        let view = self.ctx.texture_with_data("uploading the volume", "volume", size, wgpu::TextureDimension::D3, format, 1, bytes)?;
        self.install_volume(VolumeGpu {
            filterable: true,
            view,
            normals: None,
            normals_in_volume: vol.normals.is_some(),
            format,
            dims: vol.dims,
            bounds: vol.bounds,
            bytes: bytes.len() as u64,
            grid,
        })
    }

    fn install_volume(&mut self, volume: VolumeGpu) -> Result<(), GpuError> {
        let total = volume.bytes;
        self.volume = Some(volume);
        self.bind_group = None;
        self.occ_source = None;
        if !self.lut_rows.is_empty() {
            self.update_occupancy(OccSource::Lut(self.lut_version))?;
        }
        self.pending_upload += total;
        self.counters.volume_uploads += 1;
        Ok(())
    }

    /// Uploads an RGBA lookup table (entries at scalars `m / (M - 1)`) as an
    /// M x 1 texture the sampler interpolates: a texture fetch is far cheaper
    /// than an indexed storage-buffer read on CPU drivers. f32 when the device
    /// can filter it, else f16 (error under 0.13 of an 8-bit level).
    pub fn set_lut(&mut self, lut: &[[f32; 4]]) -> Result<(), GpuError> {
        if lut.is_empty() {
            return Err(GpuError("the transfer-function table must have at least one entry".into()));
        }
        let max = self.ctx.limits.max_texture_dimension_2d as usize;
        if lut.len() > max {
            return Err(GpuError(format!(
                "transfer-function table of {} entries exceeds this device's limit of {max} entries",
                lut.len()
            )));
        }
        let f32_ok = self.ctx.features.contains(wgpu::Features::FLOAT32_FILTERABLE);
        let (format, bytes): (wgpu::TextureFormat, Vec<u8>) = if f32_ok {
            (wgpu::TextureFormat::Rgba32Float, bytemuck::cast_slice(lut).to_vec())
        } else {
            let h: Vec<u16> = lut.iter().flatten().map(|&v| f32_to_f16(v)).collect();
            (wgpu::TextureFormat::Rgba16Float, bytemuck::cast_slice(&h).to_vec())
        };
        let size = wgpu::Extent3d { width: lut.len() as u32, height: 1, depth_or_array_layers: 1 };
        let d2 = wgpu::TextureDimension::D2;
        let view = self.ctx.texture_with_data("uploading the transfer function", "lut", size, d2, format, 1, &bytes)?;
        self.lut = Some((view, lut.len() as u32));
        self.lut_rows = lut.to_vec();
        self.lut_version += 1;
        self.bind_group = None;
        if self.volume.is_some() {
            self.update_occupancy(OccSource::Lut(self.lut_version))?;
        }
        self.pending_upload += bytes.len() as u64;
        self.counters.lut_uploads += 1;
        Ok(())
    }

    /// Maps sampled values to the table's [0, 1] (a value range in data
    /// units). Recomputes which cells are empty when it changes.
    pub fn set_value_map(&mut self, map: ValueMap) -> Result<(), GpuError> {
        if map != self.value_map {
            self.value_map = map;
            self.occ_source = None;
            if self.volume.is_some() && !self.lut_rows.is_empty() {
                self.update_occupancy(OccSource::Lut(self.lut_version))?;
            }
        }
        Ok(())
    }

    /// Rays march only inside `clip` (world coordinates) from the next frame
    /// on; None marches the whole volume. Nothing is uploaded.
    pub fn set_clip(&mut self, clip: Option<Bounds>) {
        self.clip = clip;
    }

    /// Which occupancy cells the current table can make visible (or, for
    /// the isosurface, can reach the iso value), uploaded as a small R8Uint
    /// 3-D texture (one byte per 8^3 voxels).
    fn update_occupancy(&mut self, source: OccSource) -> Result<(), GpuError> {
        let Some(vol) = self.volume.as_ref() else {
            return Ok(());
        };
        if self.occ_source == Some(source) {
            return Ok(());
        }
        let occ = match source {
            OccSource::Lut(_) => vol.grid.occupancy(&self.lut_rows, self.value_map),
            OccSource::Below(bits) => vol.grid.occupancy_reaching(f64::from_bits(bits), self.value_map),
        };
        let [g0, g1, g2] = vol.grid.dims;
        // Up to 4 levels (cells of 8, 16, 32, 64 voxels), as a mip chain allows.
        let largest = g0.max(g1).max(g2) as u32;
        let levels = (32 - largest.leading_zeros()).clamp(1, 4) as usize;
        let data: Vec<u8> = pyramid(&occ, vol.grid.dims, levels).into_iter().flat_map(|(l, _)| l).collect();
        let size = wgpu::Extent3d { width: g2 as u32, height: g1 as u32, depth_or_array_layers: g0 as u32 };
        let (d3, r8) = (wgpu::TextureDimension::D3, wgpu::TextureFormat::R8Uint);
        let view = self.ctx.texture_with_data("uploading the occupancy grid", "occupancy", size, d3, r8, levels as u32, &data)?;
        self.pending_upload += data.len() as u64;
        self.empty_fraction = occ.iter().filter(|&&o| o == 0).count() as f64 / occ.len() as f64;
        self.occ_levels = levels as u32;
        self.occupancy = Some(view);
        self.occ_source = Some(source);
        self.bind_group = None;
        Ok(())
    }

    /// Fraction of occupancy cells the current transfer function leaves empty.
    pub fn empty_fraction(&self) -> f64 {
        self.empty_fraction
    }

    fn params(&self, vol: &VolumeGpu, camera: &Camera, light: &Light, cfg: &RenderConfig) -> Result<Params, GpuError> {
        let basis = camera.basis(self.width, self.height).map_err(|e| GpuError(e.0))?;
        let ext = vol.bounds.extent();
        let spacing = ext / DVec3::new(vol.dims[0] as f64, vol.dims[1] as f64, vol.dims[2] as f64);
        let light_dir = (light.target - light.position).normalize_or_zero();
        // A crop that misses the volume leaves an empty box: no ray enters it.
        let clip = match self.clip {
            Some(c) => vol.bounds.intersection(&c).unwrap_or(Bounds { min: vol.bounds.min, max: vol.bounds.min }),
            None => vol.bounds,
        };
        Ok(Params {
            cam_pos: v4(basis.origin - vol.bounds.min),
            cam_fwd: v4(basis.forward),
            cam_right: v4(basis.right),
            cam_up: v4(basis.up),
            extent: v4(ext),
            inv_extent: v4(1.0 / ext),
            inv_two_spacing: v4(0.5 / spacing),
            light_pos: v4(light.position - vol.bounds.min),
            light_dir: v4(light_dir),
            step_size: cfg.step_size as f32,
            inv_ref: (1.0 / cfg.reference_step_size) as f32,
            ambient: light.ambient as f32,
            diffuse: light.diffuse as f32,
            threshold: cfg.opacity_threshold as f32,
            max_steps: cfg.max_steps.clamp(0, u32::MAX as i64) as u32,
            width: self.width,
            height: self.height,
            lut_size: self.lut.as_ref().map_or(1, |(_, n)| *n),
            light_valid: (light.kind == LightKind::Directional && light_dir != DVec3::ZERO) as u32,
            pass_start: 0,
            pass_steps: PASS_STEPS,
            first_pass: 1,
            last_pass: 1,
            occ_levels: self.occ_levels,
            jitter_seed: cfg.jitter_seed,
            iso_value: cfg.iso_value as f32,
            anisotropy: cfg.anisotropy as f32,
            shadow_step: cfg.shadow_step() as f32,
            preint_side: preintegrate::table_side(self.lut_rows.len()) as f32,
            value_scale: self.value_map.scale as f32,
            value_offset: self.value_map.offset as f32,
            value_pad: [0.0; 2],
            clip_lo: v4(clip.min - vol.bounds.min),
            clip_hi: v4(clip.max - vol.bounds.min),
        })
    }

    /// Renders into `out` (width * height * 4 floats: premultiplied RGBA,
    /// row 0 at the bottom).
    pub fn render_into(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        out: &mut [f32],
    ) -> Result<FrameStats, GpuError> {
        let n = self.width as usize * self.height as usize * 4;
        if out.len() != n {
            return Err(GpuError(format!("output slice has {} floats, expected {n}", out.len())));
        }
        if self.volume.is_none() {
            return Err(GpuError("no volume loaded: call load_volume() first".into()));
        }
        if self.lut.is_none() {
            return Err(GpuError("no transfer function set: call set_transfer_functions() first".into()));
        }
        cfg.validate().map_err(|e| GpuError(e.0))?;
        let source = match cfg.model {
            Model::Isosurface => OccSource::Below(cfg.iso_value.to_bits()),
            _ => OccSource::Lut(self.lut_version),
        };
        self.update_occupancy(source)?;
        let vol = self.volume.as_ref().expect("checked above");
        let mut params = self.params(vol, camera, light, cfg)?;
        self.depth_ready = false;
        if self.skip_empty && self.empty_fraction == 1.0 && cfg.model.skips_transparent() {
            // Every sample of every ray would have opacity 0.
            out.fill(0.0);
            self.counters.frames += 1;
            let uploaded = std::mem::take(&mut self.pending_upload);
            self.counters.uploaded_bytes += uploaded;
            return Ok(FrameStats { truncated_needed: 0, uploaded_bytes: uploaded, passes: 0, samples: 0 });
        }
        let shading = Shading::choose(light, vol.normals.is_some() || vol.normals_in_volume);
        // Texels holding normals are only read through the sampler.
        let hw_filter = vol.filterable && (!self.shader_filtering || vol.normals_in_volume);
        let layout = Layout { hw_filter, normals_in_volume: vol.normals_in_volume };
        let skip = self.skip_empty && self.empty_fraction >= SKIP_MIN_EMPTY;
        let variant = Variant::new(shading, light.kind, cfg, layout, skip);
        // An upper bound on any ray's step count decides how many passes.
        let longest = vol.bounds.max_chord_from(camera.position);
        let max_n = cfg.steps_for_length(longest).saturating_add(2).min(params.max_steps as u64);
        let mut pass_steps = PASS_STEPS as u64;
        if cfg.model == Model::SingleScattering && variant.shading != Shading::AmbientOnly {
            // Every step may march a shadow ray: fewer steps per dispatch.
            let shadow = (vol.bounds.extent().length() / cfg.shadow_step()).ceil() + 1.0;
            if !(shadow <= MAX_SHADOW_STEPS as f64) {
                return Err(GpuError(format!(
                    "shadow rays of up to {shadow} steps exceed the limit of {MAX_SHADOW_STEPS}: \
                     shadow_step_size must be at least {:.3e} for these bounds",
                    vol.bounds.extent().length() / MAX_SHADOW_STEPS as f64
                )));
            }
            pass_steps = (PASS_ITERATIONS / (shadow as u64 + 1)).clamp(1, PASS_STEPS as u64);
        }
        let passes = max_n.div_ceil(pass_steps).max(1);
        if passes > u32::MAX as u64 {
            return Err(GpuError(format!("rays of {max_n} steps need too many passes; use a larger step_size")));
        }
        let passes = passes as u32;
        params.pass_steps = pass_steps as u32;
        let pixels = self.width as u64 * self.height as u64;
        let per_pixel_state = passes > 1 || cfg.model == Model::Isosurface;
        if per_pixel_state && self.ray_state.pixels < pixels {
            let limit = self.ctx.max_storage_bytes();
            if pixels * 16 > limit {
                return Err(GpuError(format!(
                    "rays of up to {max_n} steps are marched in passes, which need 16 bytes per pixel: \
                     {}x{} is over this device's limit of {limit} bytes; use fewer pixels or fewer steps",
                    self.width, self.height
                )));
            }
            let device = &self.ctx.device;
            self.ray_state = self.ctx.scoped("allocating ray state", || RayState::new(device, pixels))?;
            self.bind_group = None;
        }
        if variant.pre_integrated {
            self.ensure_preint(cfg)?;
        }
        let vol = self.volume.as_ref().expect("checked above");
        let pipeline = self.pipelines.get(&self.ctx, variant)?;
        let ctx = self.ctx.clone();
        if self.bound_hw_filter != hw_filter {
            self.bind_group = None;
        }
        if self.bind_group.is_none() {
            let output = self.output.as_ref().expect("resize() always leaves an output");
            let (lut, _) = self.lut.as_ref().expect("checked above");
            let normals = vol.normals.as_ref().unwrap_or(&self.dummy_normals);
            let preint = self.preint.as_ref().map_or(&self.dummy_preint, |(v, _)| v);
            let occupancy = self
                .occupancy
                .as_ref()
                .ok_or_else(|| GpuError("the occupancy grid is missing: load the volume again".into()))?;
            let bg = ctx.scoped("binding frame resources", || {
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("raymarch"),
                    layout: &self.pipelines.layouts[hw_filter as usize].bind_group,
                    entries: &[
                        wgpu::BindGroupEntry { binding: bindings::PARAMS, resource: self.uniform.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: bindings::VOLUME, resource: wgpu::BindingResource::TextureView(&vol.view) },
                        wgpu::BindGroupEntry { binding: bindings::NORMALS, resource: wgpu::BindingResource::TextureView(normals) },
                        wgpu::BindGroupEntry { binding: bindings::LUT, resource: wgpu::BindingResource::TextureView(lut) },
                        wgpu::BindGroupEntry { binding: bindings::IMAGE, resource: output.storage.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: bindings::STATS, resource: self.stats.as_entire_binding() },
                        wgpu::BindGroupEntry {
                            binding: bindings::VOLUME_SAMPLER,
                            resource: wgpu::BindingResource::Sampler(&self.volume_samplers[hw_filter as usize]),
                        },
                        wgpu::BindGroupEntry { binding: bindings::LINEAR_SAMPLER, resource: wgpu::BindingResource::Sampler(&self.linear_sampler) },
                        wgpu::BindGroupEntry { binding: bindings::RAY_STATE, resource: self.ray_state.state.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: bindings::RAY_DONE, resource: self.ray_state.done.as_entire_binding() },
                        wgpu::BindGroupEntry {
                            binding: bindings::OCCUPANCY,
                            resource: wgpu::BindingResource::TextureView(occupancy),
                        },
                        wgpu::BindGroupEntry { binding: bindings::PREINT, resource: wgpu::BindingResource::TextureView(preint) },
                    ],
                })
            })?;
            self.bind_group = Some(bg);
            self.bound_hw_filter = hw_filter;
        }
        let bind_group = self.bind_group.as_ref().expect("set above");
        let output = self.output.as_ref().expect("resize() always leaves an output");
        let queue = &ctx.queue;
        queue.write_buffer(&self.stats, 0, &[0u8; 12]);
        let uploaded = self.pending_upload + passes as u64 * std::mem::size_of::<Params>() as u64 + 12;
        self.pending_upload = 0;

        let bytes = n as u64 * 4;
        for pass in 0..passes {
            let mut p = params;
            p.pass_start = pass * params.pass_steps;
            p.first_pass = (pass == 0) as u32;
            p.last_pass = (pass + 1 == passes) as u32;
            // Writes before a submit are ordered with it: each pass sees its own.
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&p));
            ctx.scoped("rendering", || {
                let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
                {
                    let mut cpass =
                        enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("raymarch"), timestamp_writes: None });
                    cpass.set_pipeline(&pipeline);
                    cpass.set_bind_group(0, bind_group, &[]);
                    cpass.dispatch_workgroups(self.width.div_ceil(WORKGROUP), self.height.div_ceil(WORKGROUP), 1);
                }
                if p.last_pass == 1 {
                    enc.copy_buffer_to_buffer(&output.storage, 0, &output.readback, 0, bytes);
                    enc.copy_buffer_to_buffer(&self.stats, 0, &self.stats_readback, 0, 12);
                }
                queue.submit([enc.finish()]);
            })?;
        }
        let image = output.readback.slice(..);
        let stat = self.stats_readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        let tx2 = tx.clone();
        image.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        stat.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx2.send(r);
        });
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError(format!("waiting for the GPU failed: {e}")))?;
        for _ in 0..2 {
            rx.recv()
                .map_err(|_| GpuError("the GPU dropped a readback".into()))?
                .map_err(|e| GpuError(format!("reading the image back failed: {e}")))?;
        }
        {
            let data = image
                .get_mapped_range()
                .map_err(|e| GpuError(format!("reading the image back failed: {e}")))?;
            out.copy_from_slice(bytemuck::cast_slice(&data));
        }
        let (truncated_needed, samples) = {
            let data = stat
                .get_mapped_range()
                .map_err(|e| GpuError(format!("reading frame statistics failed: {e}")))?;
            let w: &[u32] = bytemuck::cast_slice(&data);
            (w[0], w[1] as u64 | (w[2] as u64) << 32)
        };
        output.readback.unmap();
        self.stats_readback.unmap();
        self.counters.frames += 1;
        self.counters.uploaded_bytes += uploaded;
        self.depth_ready = cfg.model == Model::Isosurface;
        Ok(FrameStats { truncated_needed, uploaded_bytes: uploaded, passes, samples })
    }

    /// Builds the pre-integration table for this config's step unless the
    /// current one was built for the same table, step and correction form.
    fn ensure_preint(&mut self, cfg: &RenderConfig) -> Result<(), GpuError> {
        let key = PreintKey {
            lut_version: self.lut_version,
            len_over_ref: cfg.step_size / cfg.reference_step_size,
            form: cfg.opacity_correction,
        };
        if self.preint.as_ref().is_some_and(|(_, k)| *k == key) {
            return Ok(());
        }
        let table = preintegrate::table(&self.lut_rows, key.len_over_ref, key.form);
        let side = preintegrate::table_side(self.lut_rows.len()) as u32;
        let f32_ok = self.ctx.features.contains(wgpu::Features::FLOAT32_FILTERABLE);
        let (format, bytes): (wgpu::TextureFormat, Vec<u8>) = if f32_ok {
            (wgpu::TextureFormat::Rgba32Float, bytemuck::cast_slice(&table).to_vec())
        } else {
            // f16 tops out at 65504: deeper segments are opaque anyway.
            let h: Vec<u16> = table.iter().flatten().map(|&v| f32_to_f16(v.min(6.0e4))).collect();
            (wgpu::TextureFormat::Rgba16Float, bytemuck::cast_slice(&h).to_vec())
        };
        let size = wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 };
        let d2 = wgpu::TextureDimension::D2;
        let view = self.ctx.texture_with_data("uploading the pre-integration table", "preint", size, d2, format, 1, &bytes)?;
        self.pending_upload += bytes.len() as u64;
        self.preint = Some((view, key));
        self.bind_group = None;
        Ok(())
    }

    /// Ray parameter (distance from the camera along each unit-length ray)
    /// of the last frame's isosurface hits, row 0 at the bottom; infinity
    /// where a ray found no surface. `None` unless the last frame was an
    /// isosurface.
    pub fn depth(&mut self) -> Result<Option<Vec<f32>>, GpuError> {
        if !self.depth_ready {
            return Ok(None);
        }
        let pixels = self.width as u64 * self.height as u64;
        let ctx = self.ctx.clone();
        let staging = ctx.scoped("reading the depth image", || {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("depth readback"),
                size: pixels * 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("depth") });
        enc.copy_buffer_to_buffer(&self.ray_state.state, 0, &staging, 0, pixels * 16);
        ctx.queue.submit([enc.finish()]);
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError(format!("waiting for the GPU failed: {e}")))?;
        rx.recv()
            .map_err(|_| GpuError("the GPU dropped a readback".into()))?
            .map_err(|e| GpuError(format!("reading the depth back failed: {e}")))?;
        let data = slice.get_mapped_range().map_err(|e| GpuError(format!("reading the depth back failed: {e}")))?;
        let v: &[[f32; 4]] = bytemuck::cast_slice(&data);
        Ok(Some(v.iter().map(|s| s[0]).collect()))
    }

    pub fn render(&mut self, camera: &Camera, light: &Light, cfg: &RenderConfig) -> Result<(Vec<f32>, FrameStats), GpuError> {
        let mut out = vec![0.0f32; self.width as usize * self.height as usize * 4];
        let stats = self.render_into(camera, light, cfg, &mut out)?;
        Ok((out, stats))
    }
}

/// Converts premultiplied float RGBA to 8-bit. `straight` divides colour by
/// alpha (unassociated output); values are clamped to [0, 1] and rounded.
pub fn to_u8(rgba: &[f32], straight: bool, out: &mut [u8]) {
    let q = |v: f32| -> u8 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (v * 255.0 + 0.5) as u8
    };
    for (px, o) in rgba.chunks_exact(4).zip(out.chunks_exact_mut(4)) {
        let a = px[3];
        let s = if straight && a > 0.0 { 1.0 / a } else { 1.0 };
        o[0] = q(px[0] * s);
        o[1] = q(px[1] * s);
        o[2] = q(px[2] * s);
        o[3] = q(a);
    }
}
