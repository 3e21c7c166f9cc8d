//! Which engines a renderer has, and the limits its storage follows.
//!
//! The native engine (`crate::cpu`) renders wherever this CPU runs it; the
//! shader engine (`crate::gpu`) only where a wgpu adapter opens. A renderer
//! opens the adapter if it can and otherwise stands on the native engine
//! alone: every frame is then the native march's, and storage decisions
//! (texel formats, when a volume must be bricked) follow `Caps::native`.

use crate::error::Error;
use crate::gpu::context::GpuContext;
use crate::gpu::pipeline::max_dispatch_side;
use std::sync::Arc;

/// The limits and texel formats a renderer's storage may use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caps {
    pub max_texture_3d: usize,
    pub max_texture_2d: usize,
    /// Bytes of the largest volume upload.
    pub max_buffer: u64,
    /// Bytes of the largest image or per-pixel ray state (16 bytes a pixel).
    pub max_storage: u64,
    /// Pixels along one side of an image.
    pub max_side: u64,
    pub float32_filterable: bool,
    pub norm16: bool,
    /// The native march renders the frames it covers (the engines share the
    /// CPU's memory, so the volume's texels are kept for it).
    pub native: bool,
}

impl Caps {
    /// The limits of a renderer with no adapter. Volumes are held in one
    /// texel array up to 4096 voxels a side and 2^31 - 1 bytes (the
    /// native march addresses texels with 32-bit signed offsets; larger
    /// volumes are bricked, as on a device), images up to 2^31 - 1 bytes.
    pub fn native() -> Caps {
        const MAX_BYTES: u64 = i32::MAX as u64;
        Caps {
            max_texture_3d: 4096,
            max_texture_2d: 16384,
            max_buffer: MAX_BYTES,
            max_storage: MAX_BYTES,
            max_side: 1 << 16,
            float32_filterable: true,
            norm16: true,
            native: true,
        }
    }

    fn of(ctx: &GpuContext) -> Caps {
        let cpu_adapter = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
        Caps {
            max_texture_3d: ctx.limits.max_texture_dimension_3d as usize,
            max_texture_2d: ctx.limits.max_texture_dimension_2d as usize,
            max_buffer: ctx.limits.max_buffer_size,
            max_storage: ctx.max_storage_bytes(),
            max_side: max_dispatch_side(ctx.limits.max_compute_workgroups_per_dimension),
            float32_filterable: ctx.features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            norm16: ctx.features.contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM),
            // On a CPU adapter the shader runs on lavapipe, which the native
            // march outpaces; a real GPU renders every frame itself.
            native: cpu_adapter,
        }
    }
}

/// Which engine a renderer asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EngineChoice {
    /// The adapter if one opens, else the native engine alone.
    Auto,
    /// The native engine alone, even where an adapter would open.
    Native,
}

impl EngineChoice {
    /// From PYVR_ENGINE: "native" (or "cpu") keeps the adapter closed;
    /// unset or "auto" opens it where it can.
    pub fn from_env() -> Result<EngineChoice, Error> {
        match std::env::var("PYVR_ENGINE").as_deref().map(str::trim) {
            Err(_) | Ok("") | Ok("auto") => Ok(EngineChoice::Auto),
            Ok("native") | Ok("cpu") => Ok(EngineChoice::Native),
            Ok(other) => Err(Error::InvalidInput(format!(
                "PYVR_ENGINE={other:?} is not an engine: use 'auto' (the GPU adapter where one opens, else \
                 the native CPU engine) or 'native'"
            ))),
        }
    }
}

/// A renderer's engines: the shader's device where one opened, and the
/// limits its storage follows.
#[derive(Clone)]
pub struct Device {
    pub gpu: Option<Arc<GpuContext>>,
    pub caps: Caps,
}

impl Device {
    /// The adapter (unless `choice` is native), else the native engine
    /// alone, which runs on every CPU. Errors other than a missing or
    /// failing adapter (a bad PYVR_BACKEND) are the caller's.
    pub fn open(choice: EngineChoice) -> Result<Device, Error> {
        let opened = match choice {
            EngineChoice::Auto => GpuContext::get(),
            EngineChoice::Native => Err(Error::Gpu("PYVR_ENGINE=native".into())),
        };
        match opened {
            Ok(ctx) => Ok(Device { caps: Caps::of(&ctx), gpu: Some(ctx) }),
            // (The native engine runs on every CPU: `cpu::lanes`.)
            Err(Error::Gpu(_)) => Ok(Device { gpu: None, caps: Caps::native() }),
            Err(e) => Err(e),
        }
    }

    /// The shader's device, for steps only frames on it take.
    pub fn ctx(&self) -> &GpuContext {
        self.gpu.as_deref().expect("only frames on the shader reach the device")
    }

    /// A texture holding `data`, or None without a device (the native
    /// march reads the texels the caller keeps).
    #[allow(clippy::too_many_arguments)]
    pub fn texture(
        &self,
        what: &str,
        label: &str,
        size: wgpu::Extent3d,
        dimension: wgpu::TextureDimension,
        format: wgpu::TextureFormat,
        data: &[u8],
    ) -> Result<Option<wgpu::TextureView>, Error> {
        match &self.gpu {
            Some(ctx) => ctx.texture_with_data(what, label, size, dimension, format, 1, data).map(Some),
            None => Ok(None),
        }
    }

    /// `texture`, where the caller keeps no texels that could stand in for
    /// it: without a device that is an error.
    pub fn required_texture(
        &self,
        what: &str,
        label: &str,
        size: wgpu::Extent3d,
        dimension: wgpu::TextureDimension,
        format: wgpu::TextureFormat,
        data: &[u8],
    ) -> Result<wgpu::TextureView, Error> {
        self.texture(what, label, size, dimension, format, data)?.ok_or_else(|| {
            Error::OutOfMemory(format!(
                "{what}: the native engine could not keep a copy of the {label}'s {} bytes of texels",
                data.len()
            ))
        })
    }

    /// What renders frames, for reports.
    pub fn describe(&self) -> String {
        match &self.gpu {
            Some(ctx) => ctx.describe(),
            None => "native CPU engine (no GPU adapter)".into(),
        }
    }
}
