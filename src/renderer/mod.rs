//! A renderer: a scene's state and the engines that render it (`device`),
//! its resources (`resources`), and in `frame` its frame, where one place
//! decides which engine renders it. Resources live as long as the renderer
//! and are replaced only when their input changes: a camera, light or
//! config change rewrites one uniform block and nothing else.

use crate::config::{OpacityCorrection, RenderConfig};
use crate::error::Error;
use crate::gpu::context::{GpuContext, ProcessSlot};
use crate::gpu::pipeline::Pipelines;
use crate::model::Model;
use crate::occupancy::{segment_ranges, uniform_radius, SegmentRanges};
use crate::plan::{Params, MAX_CLIP_PLANES};
use crate::scene::{Bounds, ClipPlane};
use crate::transfer::ValueMap;
use crate::volume::{Precision, VolumeView};
use device::{Caps, Device, EngineChoice};
use resources::{readback_buffer, CpuCopy, Fixed, OccSource, Occupancy, Output, RayState, Tables, VolumeGpu};
use std::sync::Arc;

/// Leaping over empty cells makes every sample's loop heavier: it pays only
/// when enough of the volume is empty: with a fifth of the cells empty, the
/// leaps save few samples and slow every other one (benches/scene_content.py).
const SKIP_MIN_EMPTY: f64 = 0.25;

/// Looking up every visible sample's cell for a uniform run pays only where
/// enough visible cells are uniform. The share is SKIP_MIN_EMPTY's, not
/// tuned (benches/uniform_runs.py measures what runs save).
const LEAP_MIN_UNIFORM: f64 = 0.25;

/// Seconds one pass of a long frame should take: about how long a Ctrl-C
/// waits. Each pass costs every ray a state load and store and the device
/// an idle moment, which at this length adds about 1% to a long frame.
const PASS_SECONDS: f64 = 1.0;

/// Planned samples per second assumed before a frame has been timed: a
/// software renderer's order of magnitude (GPUs are faster, and measured
/// at their first long frame).
const INITIAL_SAMPLES_PER_SECOND: f64 = 1e8;

/// Bytes of the frame statistics: the largest step count a truncated ray
/// needed, and the samples taken (two words).
const STATS_BYTES: u64 = 12;

/// Occupancy grids kept besides the current one: the plain and
/// pre-integrated grids of a table, and one for the isosurface. A grid
/// costs two bytes per 8^3 voxels.
const SPARE_GRIDS: usize = 2;

/// What one frame did, for tests and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Largest step count a ray needed when `max_steps` cut it short; 0 if none.
    pub truncated_needed: u32,
    /// Bytes written to the GPU for this frame (uniforms only, unless a
    /// volume, LUT or image size changed since the last frame).
    pub uploaded_bytes: u64,
    /// Dispatches the frame took (rays longer than one pass need several).
    pub passes: u32,
    /// Samples the frame took over all rays (skipped empty space not counted).
    pub samples: u64,
    /// The native CPU march (`crate::cpu`) rendered it, not the shader.
    pub native: bool,
}

/// Counters over the renderer's life.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counters {
    pub frames: u64,
    pub volume_uploads: u64,
    pub lut_uploads: u64,
    pub uploaded_bytes: u64,
}

/// The buffers every frame writes.
struct FrameBuffers {
    uniform: wgpu::Buffer,
    stats: wgpu::Buffer,
    stats_readback: wgpu::Buffer,
    output: Output,
    ray_state: RayState,
}

/// The shader engine's own objects, made where a device opened.
struct Shader {
    pipelines: Arc<Pipelines>,
    frame: FrameBuffers,
    fixed: Fixed,
}

impl Shader {
    fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Shader, Error> {
        let pipelines = shared_pipelines(ctx)?;
        let device = &ctx.device;
        let (uniform, stats, stats_readback) = ctx.scoped("allocating renderer buffers", || {
            use wgpu::BufferUsages as U;
            (
                buffer(device, "params", std::mem::size_of::<Params>() as u64, U::UNIFORM | U::COPY_DST),
                buffer(device, "stats", STATS_BYTES, U::STORAGE | U::COPY_SRC | U::COPY_DST),
                readback_buffer(device, "stats readback", STATS_BYTES),
            )
        })?;
        let frame = FrameBuffers {
            uniform,
            stats,
            stats_readback,
            output: Output::new(ctx, width, height)?,
            ray_state: RayState::new(ctx, 1)?,
        };
        Ok(Shader { pipelines, frame, fixed: Fixed::new(ctx)? })
    }
}

/// A renderer: the engine-neutral state of a scene (volume, tables, empty
/// cells, value map, crop box) and the engines that render its frames.
pub struct Renderer {
    dev: Device,
    /// None where no device opened: every frame is the native march's.
    shader: Option<Shader>,
    width: u32,
    height: u32,
    volume: Option<VolumeGpu>,
    tables: Tables,
    occupancy: Occupancy,
    /// Grids of the loaded volume built for other sources, most recent
    /// first (at most SPARE_GRIDS): frames that alternate between plain and
    /// pre-integrated segments, or between models, switch grids instead of
    /// rebuilding one each frame. Emptied whenever the volume, the table or
    /// the value map changes, and empty while bricks are loaded (their
    /// grids are their own: none is kept then).
    spare_grids: Vec<Occupancy>,
    /// Sampled value -> table domain.
    value_map: ValueMap,
    /// Crop box in world coordinates (None: the whole volume).
    clip: Option<Bounds>,
    /// Half-spaces rays march in, world coordinates (at most MAX_CLIP_PLANES).
    planes: Vec<ClipPlane>,
    /// An opaque scene's depth per pixel, row 0 at the bottom: the world
    /// distance along each pixel's ray where it stops (infinity: nothing).
    depth_in: Option<Vec<f32>>,
    /// `depth_in` in the frame plan's units, filled per frame.
    depth_texels: Vec<f32>,
    /// The shader's copy of `depth_texels` (made once per image size) and
    /// its number, which bind groups are keyed on.
    depth_texture: Option<(wgpu::Texture, wgpu::TextureView, u64)>,
    depth_textures_made: u64,
    /// Leap over empty cells (on by default; off to measure what it saves).
    pub skip_empty: bool,
    /// With `skip_empty`: composite runs through uniform cells as one segment.
    pub uniform_runs: bool,
    /// Interpolate in the shader even when the format could be filtered
    /// (the path used without FLOAT32_FILTERABLE); for tests and comparisons.
    pub shader_filtering: bool,
    /// Frames the native CPU march covers are rendered by it where the
    /// adapter is a CPU (`crate::cpu`); off: always the shader. On unless
    /// the environment sets PYVR_NATIVE_MARCH=0.
    pub native_march: bool,
    /// The bind group and what it was made for.
    bind_group: Option<(wgpu::BindGroup, BindKey)>,
    /// The last frame was an isosurface: its depth is in the ray state, or
    /// in `native_depth` where the native march rendered it.
    depth_ready: bool,
    native_depth: Option<Vec<f32>>,
    /// World length of the shader's length unit in that frame.
    depth_unit: f64,
    /// Planned samples per second of the last long frame: sizes passes for time.
    samples_per_second: f64,
    /// The process that made the device objects (see `check_process`).
    pid: u32,
    pending_upload: u64,
    pub counters: Counters,
    /// A volume in bricks (then `volume` is None).
    bricks: Option<bricked::Bricks>,
    brick_frame: Option<BrickFrame>,
}

mod bricked;
pub mod device;
mod frame;
pub mod resources;

pub use bricked::BrickFrame;

/// What a bind group was made for: the volume's filtering, and the value
/// map and kind (maximum: true) of the projection bounds bound where the
/// occupancy grid is, if any.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BindKey {
    hw_filter: bool,
    projection: Option<(ValueMap, bool)>,
    /// The depth texture's number (None: the fixed one).
    depth: Option<u64>,
}

/// Pixels a dispatch covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Rect {
    x: u32,
    y: u32,
    width: u32,
    height: u32,
}

/// Where a dispatch stands in its frame: the first one starts every ray,
/// the last one hands the image to the readback buffer.
#[derive(Clone, Copy, Debug)]
struct Ends {
    first: bool,
    last: bool,
}

static PIPELINES: ProcessSlot<Result<Arc<Pipelines>, Error>> = ProcessSlot::new();

fn shared_pipelines(ctx: &GpuContext) -> Result<Arc<Pipelines>, Error> {
    PIPELINES.get_or_make(|| Pipelines::new(ctx).map(Arc::new))
}

fn buffer(device: &wgpu::Device, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
}

impl Renderer {
    pub fn new(width: u32, height: u32) -> Result<Renderer, Error> {
        Self::with_engines(width, height, EngineChoice::from_env()?)
    }

    /// A renderer of the engines `choice` asks for (`Device::open`).
    pub fn with_engines(width: u32, height: u32, choice: EngineChoice) -> Result<Renderer, Error> {
        let dev = Device::open(choice)?;
        Self::check_size(&dev.caps, width, height)?;
        let shader = dev.gpu.as_deref().map(|ctx| Shader::new(ctx, width, height)).transpose()?;
        Ok(Renderer {
            dev,
            shader,
            width,
            height,
            volume: None,
            tables: Tables::new(),
            occupancy: Occupancy::new(),
            spare_grids: Vec::new(),
            value_map: ValueMap::IDENTITY,
            clip: None,
            planes: Vec::new(),
            depth_in: None,
            depth_texels: Vec::new(),
            depth_texture: None,
            depth_textures_made: 0,
            skip_empty: true,
            uniform_runs: true,
            shader_filtering: false,
            // PYVR_NATIVE_MARCH=0 keeps every frame on the shader (the test
            // suite runs once so, to test the shader's path on a CPU too).
            native_march: std::env::var("PYVR_NATIVE_MARCH").map_or(true, |v| v != "0"),
            bind_group: None,
            depth_ready: false,
            native_depth: None,
            depth_unit: 1.0,
            samples_per_second: INITIAL_SAMPLES_PER_SECOND,
            pid: std::process::id(),
            pending_upload: 0,
            counters: Counters::default(),
            bricks: None,
            brick_frame: None,
        })
    }

    /// The renderer's GPU objects belong to the process that made them: in
    /// a child made by fork() they are copies whose driver threads did not
    /// survive, and using them would wait forever.
    pub fn check_process(&self) -> Result<(), Error> {
        if std::process::id() == self.pid {
            return Ok(());
        }
        Err(Error::Gpu(
            "this renderer was created in the parent of a fork(), and its GPU device cannot be used in the \
             child: create the renderer in the child (pyvr.VolumeRenderer does this by itself), or start \
             worker processes with the 'spawn' or 'forkserver' method of multiprocessing"
                .into(),
        ))
    }

    /// True when the renderer was made in another process (before a fork).
    pub fn is_foreign(&self) -> bool {
        std::process::id() != self.pid
    }

    /// Samples one pass of a long frame may take (about PASS_SECONDS).
    fn pass_samples(&self) -> u64 {
        (self.samples_per_second * PASS_SECONDS).clamp(1e6, 1e13) as u64
    }

    /// Keeps the device's speed (planned samples per second) from frames
    /// long enough to time.
    fn measure_speed(&mut self, samples: u64, elapsed: std::time::Duration) {
        let secs = elapsed.as_secs_f64();
        if samples >= 1 << 20 && secs > 0.01 {
            self.samples_per_second = samples as f64 / secs;
        }
    }

    /// The engines and the limits storage follows.
    pub fn device(&self) -> &Device {
        &self.dev
    }

    /// Which engine renders frames it covers: "native" where the native
    /// march does (no device, or a CPU adapter), else "shader".
    pub fn engine(&self) -> &'static str {
        if self.native_march && self.dev.caps.native {
            "native"
        } else {
            "shader"
        }
    }

    fn ctx(&self) -> &GpuContext {
        self.dev.ctx()
    }

    fn shader(&self) -> &Shader {
        self.shader.as_ref().expect("only frames on the shader reach its objects")
    }

    fn shader_mut(&mut self) -> &mut Shader {
        self.shader.as_mut().expect("only frames on the shader reach its objects")
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Bytes the current volume (and normals) occupy on the GPU.
    pub fn volume_bytes(&self) -> u64 {
        self.volume.as_ref().map_or(0, |v| v.bytes) + self.resident_brick_bytes()
    }

    /// Whether the current volume's texture is made: not while the native
    /// march's copy stands in for it (no frame on the shader yet).
    pub fn volume_texture(&self) -> bool {
        self.volume.as_ref().is_some_and(|v| v.view.is_some())
    }

    /// How the current volume is stored: its texel format, and where the
    /// normals are ("" without a volume).
    pub fn volume_storage(&self) -> String {
        self.volume.as_ref().map_or(String::new(), |v| v.storage())
    }

    pub fn cached_variants(&self) -> usize {
        self.shader.as_ref().map_or(0, |s| s.pipelines.cached_variants())
    }

    /// Checks an image size against the device's limits.
    pub fn check_size(caps: &Caps, width: u32, height: u32) -> Result<(), Error> {
        if width == 0 || height == 0 {
            return Err(Error::InvalidInput(format!("width and height must be positive, got {width}x{height}")));
        }
        let bytes = (width as u64 * height as u64).saturating_mul(16);
        let limit = caps.max_storage;
        if bytes > limit {
            return Err(Error::DeviceLimit(format!(
                "image {width}x{height} needs {bytes} bytes of output, over this device's limit of {limit} \
                 bytes (at most {} pixels)",
                limit / 16
            )));
        }
        let groups = caps.max_side;
        if width as u64 > groups || height as u64 > groups {
            return Err(Error::DeviceLimit(format!(
                "image {width}x{height} exceeds this device's limit of {groups} pixels per side"
            )));
        }
        Ok(())
    }

    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), Error> {
        self.check_process()?;
        Self::check_size(&self.dev.caps, width, height)?;
        if (width, height) == (self.width, self.height) {
            return Ok(());
        }
        if let Some(ctx) = self.dev.gpu.clone() {
            self.shader_mut().frame.output = Output::new(&ctx, width, height)?;
        }
        self.width = width;
        self.height = height;
        self.bind_group = None;
        Ok(())
    }

    /// Uploads a volume (and its normals), replacing the previous one, with
    /// float data stored exactly.
    pub fn set_volume(&mut self, vol: &VolumeView) -> Result<(), Error> {
        self.set_volume_with_precision(vol, Precision::Float32)
    }

    /// Uploads a volume, storing float data at `precision`.
    pub fn set_volume_with_precision(&mut self, vol: &VolumeView, precision: Precision) -> Result<(), Error> {
        self.check_process()?;
        // (Alone, the native march's texels are the only copy.)
        let copy = if self.shader.is_none() { CpuCopy::Always } else { CpuCopy::IfRoom };
        let volume = VolumeGpu::upload(&self.dev, vol, precision, copy)?;
        let total = volume.uploaded();
        self.volume = Some(volume);
        self.bricks = None;
        self.brick_frame = None;
        self.bind_group = None;
        self.occupancy.source = None;
        self.spare_grids.clear();
        if !self.tables.rows.is_empty() {
            self.update_occupancy(self.table_source(None))?;
        }
        self.pending_upload += total;
        self.counters.volume_uploads += 1;
        Ok(())
    }

    /// Replaces the loaded volume's texture by one holding its values with
    /// their gradients (`VolumeGpu::with_gradients`), so that gradient-shaded
    /// frames fetch once a sample. `vol` must be the volume loaded, stored
    /// as float32 values or integer codes alone (no normals, not bricked,
    /// finite). Returns whether it did; false leaves everything as it was.
    pub fn pack_gradients(&mut self, vol: &VolumeView) -> Result<bool, Error> {
        self.check_process()?;
        let values_alone = [wgpu::TextureFormat::R32Float, wgpu::TextureFormat::R8Unorm, wgpu::TextureFormat::R16Unorm];
        let plain = matches!(&self.volume, Some(v) if values_alone.contains(&v.format)
            && !v.normals_apart && !v.normals_in_volume && v.dims == vol.dims && v.bounds == vol.bounds);
        if !plain || self.bricks.is_some() || vol.normals.is_some() {
            return Ok(false);
        }
        let grid = &self.volume.as_ref().expect("checked above").grid;
        let Some(volume) = VolumeGpu::with_gradients(&self.dev, vol, grid)? else {
            return Ok(false);
        };
        self.pending_upload += volume.uploaded();
        self.volume = Some(volume);
        self.bind_group = None;
        Ok(true)
    }

    /// Uploads an RGBA lookup table (entries at scalars `m / (M - 1)`).
    pub fn set_lut(&mut self, lut: &[[f32; 4]]) -> Result<(), Error> {
        self.check_process()?;
        let bytes = self.tables.upload_lut(&self.dev, lut)?;
        self.bind_group = None;
        self.spare_grids.clear();
        if self.volume.is_some() {
            self.update_occupancy(self.table_source(self.occupancy.source))?;
        }
        self.pending_upload += bytes;
        self.counters.lut_uploads += 1;
        if let Some(ctx) = self.dev.gpu.as_deref() {
            ctx.settle();
        }
        Ok(())
    }

    /// Maps sampled values to the table's [0, 1] (a value range in data
    /// units). Recomputes which cells are empty when it changes.
    pub fn set_value_map(&mut self, map: ValueMap) -> Result<(), Error> {
        if map != self.value_map {
            self.value_map = map;
            let last = self.occupancy.source.take();
            self.spare_grids.clear();
            self.invalidate_brick_occupancy();
            if self.volume.is_some() && !self.tables.rows.is_empty() {
                self.update_occupancy(self.table_source(last))?;
            }
        }
        Ok(())
    }

    /// Rays march only inside `clip` (world coordinates) from the next frame
    /// on; None marches the whole volume. Nothing is uploaded.
    pub fn set_clip(&mut self, clip: Option<Bounds>) {
        self.clip = clip;
    }

    /// From the next frame on, each pixel's ray stops where an opaque scene
    /// is: `depth` holds, row 0 at the bottom, the world distance along
    /// each pixel's ray (from the camera, or its plane for parallel rays)
    /// to the scene's surface, infinity where there is none; None: no
    /// scene. Shadow rays are not stopped.
    pub fn set_depth_in(&mut self, depth: Option<Vec<f32>>) -> Result<(), Error> {
        if let Some(d) = &depth {
            let pixels = self.width as usize * self.height as usize;
            if d.len() != pixels {
                return Err(Error::InvalidInput(format!(
                    "the depth image must have {}x{} values, got {}",
                    self.width,
                    self.height,
                    d.len()
                )));
            }
            if let Some(bad) = d.iter().find(|v| !(**v >= 0.0)) {
                return Err(Error::InvalidInput(format!(
                    "depths must be distances >= 0 (infinity where nothing is), got {bad}"
                )));
            }
        }
        self.depth_in = depth;
        Ok(())
    }
}

/// `params` with the frame's depth image `depth_in`, when there is one:
/// its distances in the plan's units into `texels`, for either engine.
/// (Fields apart, so that a bricked frame can call it while it reads its bricks.)
fn with_depth_in(depth_in: &Option<Vec<f32>>, texels: &mut Vec<f32>, mut params: Params, bounds: &Bounds) -> Params {
    if let Some(d) = depth_in {
        let s = (1.0 / crate::plan::world_unit(bounds)) as f32;
        texels.clear();
        texels.extend(d.iter().map(|v| v * s));
        params.depth_in = 1;
    }
    params
}

impl Renderer {
    /// Rays and shadow rays march only on the kept side of every plane from
    /// the next frame on (none: no planes). Nothing is uploaded.
    pub fn set_clip_planes(&mut self, planes: &[ClipPlane]) -> Result<(), Error> {
        if planes.len() > MAX_CLIP_PLANES {
            return Err(Error::InvalidInput(format!("at most {MAX_CLIP_PLANES} clip planes, got {}", planes.len())));
        }
        self.planes = planes.to_vec();
        Ok(())
    }

    /// Which occupancy cells the current table can make visible (or, for
    /// the isosurface, can reach the iso value).
    fn update_occupancy(&mut self, source: OccSource) -> Result<(), Error> {
        if self.volume.is_none() {
            return Ok(());
        }
        if self.occupancy.source == Some(source) {
            return Ok(());
        }
        if let Some(k) = self.spare_grids.iter().position(|o| o.source == Some(source)) {
            let found = self.spare_grids.remove(k);
            let last = std::mem::replace(&mut self.occupancy, found);
            self.keep_spare(last);
            self.bind_group = None;
            return Ok(());
        }
        let last = std::mem::replace(&mut self.occupancy, Occupancy::new());
        if self.bricks.is_none() {
            self.keep_spare(last);
        }
        let vol = self.volume.as_ref().expect("checked above");
        let (occ, uniform) = match source {
            OccSource::Lut { ranges, form, .. } => {
                let grid = vol.grid.for_segments(ranges);
                let occ = grid.majorants(&self.tables.rows, self.value_map, form);
                // Over the same ranges as the majorants: a segment centred in
                // a uniform cell is uniform whole. Keys over ranges that
                // ignore NaN would be wrong where a sample is NaN.
                let uniform = (!vol.grid.has_nan).then(|| {
                    let keys = grid.uniform_keys(&self.tables.rows, self.value_map, &occ);
                    uniform_radius(&keys, grid.dims)
                });
                (occ, uniform)
            }
            OccSource::Below(bits) => (vol.grid.occupancy_reaching(f64::from_bits(bits), self.value_map), None),
        };
        self.pending_upload += self.occupancy.upload(&self.dev, &vol.grid, &occ, uniform.as_deref(), source)?;
        self.bind_group = None;
        Ok(())
    }

    /// Keeps a grid the renderer moves away from among the spares.
    fn keep_spare(&mut self, grid: Occupancy) {
        if grid.source.is_some() {
            self.spare_grids.insert(0, grid);
            self.spare_grids.truncate(SPARE_GRIDS);
        }
    }

    /// The table's cells, built when the table, value map or volume changes,
    /// over the segment ranges of `last` (the grid the last frame used), so
    /// that a session of unbiased frames builds one grid per table change, not
    /// two; a new volume starts from the cells' own ranges.
    fn table_source(&self, last: Option<OccSource>) -> OccSource {
        let (ranges, form) = match last {
            Some(OccSource::Lut { ranges, form, .. }) => (ranges, form),
            _ => (SegmentRanges::Plain, OpacityCorrection::Exponential),
        };
        OccSource::Lut { version: self.tables.version, ranges, form }
    }

    /// What decides a frame's empty cells: the iso value, or the table over
    /// each cell's range; for unbiased frames with per-cell rates, over the
    /// range of the segments centred in the cell (a segment's points are
    /// drawn at its midpoint cell's rate). Unbiased leaps, decided at points,
    /// and pre-integrated ones, over segments that lie in a cube whole
    /// (compositing.wgsl `whole_segments`), need only the cells' own ranges.
    pub(super) fn occupancy_source(&self, cfg: &RenderConfig) -> OccSource {
        if cfg.model == Model::Isosurface {
            return OccSource::Below(cfg.iso_value.to_bits());
        }
        let ranges = match &self.volume {
            Some(vol) if cfg.unbiased && self.cell_rates(cfg) => {
                let extent = vol.bounds.extent().to_array();
                segment_ranges(cfg.step_size, std::array::from_fn(|a| extent[a] / vol.dims[a] as f64))
            }
            _ => SegmentRanges::Plain,
        };
        OccSource::Lut { version: self.tables.version, ranges, form: cfg.opacity_correction }
    }

    /// Fraction of occupancy cells the current transfer function leaves empty.
    pub fn empty_fraction(&self) -> f64 {
        self.occupancy.empty_fraction
    }

    /// Fraction of the occupied cells that are uniform (`Occupancy::uniform_fraction`).
    pub fn uniform_fraction(&self) -> f64 {
        self.occupancy.uniform_fraction
    }
}
