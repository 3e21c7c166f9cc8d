//! The shader engine's own buffers: the image a frame writes, its
//! readback, the rays' state between passes, samplers and placeholders.

use super::*;
use crate::error::Error;
use crate::gpu::context::GpuContext;

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
    /// The depth texture of frames with no opaque scene (never read).
    pub no_depth: wgpu::TextureView,
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
        let no_depth = ctx.texture_with_data(
            "allocating renderer buffers",
            "no depth",
            one,
            D2,
            wgpu::TextureFormat::R32Float,
            1,
            &f32::INFINITY.to_le_bytes(),
        )?;
        Ok(Fixed { no_normals, no_preint, no_depth, volume_samplers, linear_sampler })
    }
}
