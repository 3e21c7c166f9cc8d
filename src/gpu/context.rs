//! One wgpu device per process, shared by every renderer: adapter choice,
//! the limits and features actually present, and error capture.

use crate::error::Error;
use std::sync::{Arc, Mutex};

pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    /// Validation errors the device reported outside an error scope.
    pub(crate) uncaptured: Arc<Mutex<Vec<String>>>,
}

static CONTEXT: ProcessSlot<Result<Arc<GpuContext>, Error>> = ProcessSlot::new();

/// A value made once per process. A child made by fork() inherits the
/// parent's value, whose GPU objects it cannot use (the driver's threads
/// stayed in the parent): the child makes its own, and the inherited one is
/// leaked, never used or dropped, since dropping it would call the driver.
pub struct ProcessSlot<T>(Mutex<Option<(u32, T)>>);

impl<T: Clone> ProcessSlot<T> {
    pub const fn new() -> Self {
        ProcessSlot(Mutex::new(None))
    }

    pub fn get_or_make(&self, make: impl FnOnce() -> T) -> T {
        let pid = std::process::id();
        let mut slot = self.0.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((owner, value)) = slot.as_ref() {
            if *owner == pid {
                return value.clone();
            }
        }
        if let Some(inherited) = slot.take() {
            std::mem::forget(inherited);
        }
        let value = make();
        *slot = Some((pid, value.clone()));
        value
    }
}

/// Which backends to try. `PYVR_BACKEND` (vulkan, metal, dx12, gl) or wgpu's
/// `WGPU_BACKEND` override; otherwise the native APIs only. GL is left out
/// unless asked for, because creating a GL instance takes over the thread's
/// EGL context (moderngl's, in the same process).
fn requested_backends() -> Result<wgpu::Backends, Error> {
    if let Ok(v) = std::env::var("PYVR_BACKEND") {
        return match v.to_ascii_lowercase().as_str() {
            "vulkan" => Ok(wgpu::Backends::VULKAN),
            "metal" => Ok(wgpu::Backends::METAL),
            "dx12" => Ok(wgpu::Backends::DX12),
            "gl" | "gles" => Ok(wgpu::Backends::GL),
            other => {
                Err(Error::InvalidInput(format!("PYVR_BACKEND must be one of vulkan, metal, dx12, gl; got '{other}'")))
            }
        };
    }
    Ok(wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY))
}

impl GpuContext {
    /// The process-wide context, created on first use.
    pub fn get() -> Result<Arc<GpuContext>, Error> {
        CONTEXT.get_or_make(|| GpuContext::create().map(Arc::new))
    }

    fn create() -> Result<GpuContext, Error> {
        let backends = requested_backends()?;
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            // Bucketing hides real limits (for fingerprinting on the web); we
            // want the adapter's true 3-D texture and buffer sizes.
            apply_limit_buckets: false,
        }))
        .map_err(|e| {
            Error::Gpu(format!(
                "no GPU adapter found for backends {backends:?} ({e}). On a machine without a \
                 GPU install Mesa's software Vulkan driver (Debian/Ubuntu: apt-get install \
                 mesa-vulkan-drivers), or set PYVR_BACKEND"
            ))
        })?;
        let adapter_info = adapter.get_info();
        // Ask for what the adapter really has: the defaults cap 3-D textures at
        // 2048 and storage buffers at 128 MiB, well below lavapipe and real GPUs.
        let limits = adapter.limits();
        let wanted = wgpu::Features::TEXTURE_FORMAT_16BIT_NORM | wgpu::Features::FLOAT32_FILTERABLE;
        let features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("pyvr"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| Error::Gpu(format!("could not open the GPU device: {e}")))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        // The default handler panics; a panic must never reach Python.
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(GpuContext { device, queue, adapter_info, limits, features, uncaptured })
    }

    /// Hands queued uploads to the device and frees what finished work no
    /// longer needs, without waiting. wgpu keeps replaced textures and their
    /// staging memory until a submission that follows them completes; frames
    /// the native march renders submit nothing, so without this every table
    /// uploaded between them would stay.
    pub fn settle(&self) {
        self.queue.submit([]);
        // Only a non-blocking sweep: an error here would also show at the next frame.
        let _ = self.device.poll(wgpu::PollType::Poll);
    }

    /// Runs `f` inside validation and out-of-memory error scopes and turns
    /// what they catch into an error.
    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T, Error> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let v = pollster::block_on(val.pop());
        let m = pollster::block_on(oom.pop());
        if let Some(e) = v.or(m) {
            return Err(Error::Gpu(format!("{what} failed on the GPU: {e}")));
        }
        if let Ok(mut u) = self.uncaptured.lock() {
            if let Some(e) = u.drain(..).next() {
                return Err(Error::Gpu(format!("{what} failed on the GPU: {e}")));
            }
        }
        Ok(out)
    }

    /// A sampled texture filled with `data` (mip levels one after another),
    /// created inside error scopes; `what` names the step in errors. The view
    /// keeps the texture alive.
    #[allow(clippy::too_many_arguments)]
    pub fn texture_with_data(
        &self,
        what: &str,
        label: &str,
        size: wgpu::Extent3d,
        dimension: wgpu::TextureDimension,
        format: wgpu::TextureFormat,
        mip_level_count: u32,
        data: &[u8],
    ) -> Result<wgpu::TextureView, Error> {
        use wgpu::util::DeviceExt;
        self.scoped(what, || {
            self.device
                .create_texture_with_data(
                    &self.queue,
                    &wgpu::TextureDescriptor {
                        label: Some(label),
                        size,
                        mip_level_count,
                        sample_count: 1,
                        dimension,
                        format,
                        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                        view_formats: &[],
                    },
                    wgpu::util::TextureDataOrder::LayerMajor,
                    data,
                )
                .create_view(&Default::default())
        })
    }

    /// Largest storage buffer one binding can see: bounds the output image
    /// (16 bytes per pixel) and the per-pixel ray state.
    pub fn max_storage_bytes(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    pub fn describe(&self) -> String {
        let i = &self.adapter_info;
        format!("{} ({:?}, {:?}, driver {} {})", i.name, i.backend, i.device_type, i.driver, i.driver_info)
    }
}
