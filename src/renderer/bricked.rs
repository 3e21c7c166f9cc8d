//! Frames of a bricked volume (src/bricks.rs): one dispatch per brick in
//! front-to-back order (back to front when the config marches that way),
//! each marching only its own segments of every ray and leaving the ray's
//! state for the next, then one dispatch that finishes the rays still open.
//! Rays carry their state across bricks exactly as across the passes of a
//! long frame, so early termination, jitter, pre-integration and both orders
//! give the single-texture image. Bricks may be resident or streamed in by
//! the caller between dispatches (`set_brick`, `evict_brick`); a brick no
//! sample of which can show is never dispatched.
//!
//! With `keep_state` a frame's rays end with their raw state (premultiplied
//! colour and optical depth, or a projection's running value) instead of a
//! pixel: a partial image for compositing with other bricks' (sort-last).

use super::frame::native_params;
use super::{Ends, FrameStats, Rect, Renderer, STATS_BYTES};
use crate::bricks::BrickGrid;
use crate::config::RenderConfig;
use crate::cpu::RayStates;
use crate::error::{try_vec, Error};
use crate::gpu::passes::PassPlan;
use crate::gpu::pipeline::{marches_back_to_front, Variant};
use crate::model::Model;
use crate::occupancy::{MinMaxGrid, SegmentRanges};
use crate::output::{Format, Target};
use crate::plan::params::{world_unit, FrameInputs, Params};
use crate::renderer::resources::{CpuCopy, OccSource, Occupancy, RayState, VolumeGpu};
use crate::scene::{Bounds, Camera, Light, RayBasis};
use crate::volume::{Precision, VolumeView};
use glam::DVec3;

/// The pixels whose rays can cross `b`: the bounding rectangle of its
/// corners' projections, a pixel wider on each side for rounding; None
/// (every pixel) when a corner is not in front of the eye (perspective).
fn screen_rect(basis: &RayBasis, b: &Bounds, width: u32, height: u32) -> Option<Rect> {
    let (r2, u2) = (basis.right.length_squared(), basis.up.length_squared());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        let v = c - basis.origin;
        // Parallel rays: a point's pixel does not depend on its depth.
        let z = if basis.orthographic { 1.0 } else { v.dot(basis.forward) };
        if !basis.orthographic && !(z > 1e-9 * v.length()) {
            return None;
        }
        // Pixel coordinates of the ray through c (pixel i's centre at i + 1/2).
        let px = (v.dot(basis.right) / (z * r2) + 1.0) * 0.5 * width as f64;
        let py = (v.dot(basis.up) / (z * u2) + 1.0) * 0.5 * height as f64;
        (x0, x1, y0, y1) = (x0.min(px), x1.max(px), y0.min(py), y1.max(py));
    }
    let lo = |v: f64, n: u32| (v.floor() - 1.0).clamp(0.0, n as f64) as u32;
    let hi = |v: f64, n: u32| (v.ceil() + 1.0).clamp(0.0, n as f64) as u32;
    let (x, y) = (lo(x0, width), lo(y0, height));
    Some(Rect { x, y, width: hi(x1, width).saturating_sub(x), height: hi(y1, height).saturating_sub(y) })
}

/// Brick `index`'s core box in world coordinates.
fn core_box(grid: &BrickGrid, bounds: &Bounds, index: usize) -> Bounds {
    let core = grid.core_range(index);
    let at = |a: usize, v: usize| v as f64 / grid.dims[a] as f64;
    let lo = DVec3::new(at(0, core[0][0]), at(1, core[1][0]), at(2, core[2][0]));
    let hi = DVec3::new(at(0, core[0][1]), at(1, core[1][1]), at(2, core[2][1]));
    Bounds { min: bounds.min + lo * bounds.extent(), max: bounds.min + hi * bounds.extent() }
}

/// One brick: its texture while resident, and always its value ranges.
struct BrickSlot {
    volume: Option<VolumeGpu>,
    grid: Option<MinMaxGrid>,
    occupancy: Occupancy,
    /// Whether any cell can show under the source of the last frame that asked.
    shows: Option<(OccSource, bool)>,
}

/// The bricked volume: its layout, box and bricks.
pub(super) struct Bricks {
    grid: BrickGrid,
    bounds: Bounds,
    slots: Vec<BrickSlot>,
}

/// A bricked frame between `begin_bricks` and `end_bricks`.
pub struct BrickFrame {
    camera: Camera,
    light: Light,
    cfg: RenderConfig,
    params: Params,
    /// Passes dispatched so far (bricks marched, natively).
    dispatched: u32,
    /// What the native march's bricks took.
    samples: u64,
    truncated_needed: u32,
    /// The last brick's pipeline and bindings: the closing dispatch reuses them.
    last: Option<(Variant, wgpu::BindGroup)>,
    /// The rays' states where the native march renders the frame
    /// (`native_bricks`), which then never reaches the shader.
    native: Option<RayStates>,
}

impl Renderer {
    /// Replaces the volume by an empty bricked one of shape `dims` in
    /// `bounds`, in bricks of `core` voxels with `ghost` voxels around each.
    pub fn set_brick_layout(
        &mut self,
        dims: [usize; 3],
        bounds: Bounds,
        core: [usize; 3],
        ghost: usize,
    ) -> Result<(), Error> {
        self.check_process()?;
        let grid = BrickGrid::new(dims, core, ghost)?;
        let slots = (0..grid.len())
            .map(|_| BrickSlot { volume: None, grid: None, occupancy: Occupancy::new(), shows: None })
            .collect();
        self.volume = None;
        self.bind_group = None;
        self.occupancy = Occupancy::new();
        self.spare_grids.clear();
        self.brick_frame = None;
        self.bricks = Some(Bricks { grid, bounds, slots });
        Ok(())
    }

    /// The layout of the bricked volume, if one is loaded.
    pub fn brick_grid(&self) -> Option<BrickGrid> {
        self.bricks.as_ref().map(|b| b.grid)
    }

    fn slot(&mut self, index: usize) -> Result<(&mut BrickSlot, BrickGrid, Bounds), Error> {
        let b = self.bricks.as_mut().ok_or_else(|| Error::InvalidInput("no bricked volume is loaded".into()))?;
        let n = b.slots.len();
        let slot = b.slots.get_mut(index).ok_or_else(|| {
            Error::InvalidInput(format!("brick index {index} is out of range: the volume has {n} bricks"))
        })?;
        Ok((slot, b.grid, b.bounds))
    }

    /// Uploads brick `index`: `vol` holds its padded voxels (its bounds are
    /// not used).
    pub fn set_brick(&mut self, index: usize, vol: &VolumeView, precision: Precision) -> Result<(), Error> {
        self.check_process()?;
        let dev = self.dev.clone();
        // Kept for the native march where it may render the bricks (`native_bricks`).
        let copy = if self.native_march || self.shader.is_none() { CpuCopy::Always } else { CpuCopy::No };
        let (slot, grid, bounds) = self.slot(index)?;
        let padded = grid.padded_range(index);
        let want = padded.map(|[lo, hi]| hi - lo);
        if vol.dims != want {
            return Err(Error::InvalidInput(format!(
                "brick {index} must hold voxels {padded:?} (shape {want:?}), got shape {:?}",
                vol.dims
            )));
        }
        if precision == Precision::Fixed16 {
            // Each brick would code its own range, and a voxel shared by two
            // bricks would read differently in each.
            return Err(Error::InvalidInput(
                "precision 'fixed16' is for volumes in one texture: store bricks as 'float32' or 'float16'".into(),
            ));
        }
        let mut gpu = VolumeGpu::upload(&dev, vol, precision, copy)?;
        // Passes are planned over the brick's own box.
        gpu.bounds = core_box(&grid, &bounds, index);
        let bytes = gpu.uploaded();
        slot.grid = Some(gpu.grid.clone());
        slot.shows = None;
        slot.volume = Some(gpu);
        slot.occupancy = Occupancy::new();
        self.pending_upload += bytes;
        self.counters.volume_uploads += 1;
        Ok(())
    }

    /// Frees brick `index`'s texture; its value ranges stay, so a frame
    /// still knows whether it must be streamed in again.
    pub fn evict_brick(&mut self, index: usize) -> Result<(), Error> {
        let (slot, _, _) = self.slot(index)?;
        slot.volume = None;
        slot.occupancy = Occupancy::new();
        Ok(())
    }

    /// Bytes the resident bricks occupy on the device.
    pub fn resident_brick_bytes(&self) -> u64 {
        self.bricks.as_ref().map_or(0, |b| b.slots.iter().filter_map(|s| s.volume.as_ref()).map(|v| v.bytes).sum())
    }

    /// A new value map changes which cells every brick leaves empty.
    pub(super) fn invalidate_brick_occupancy(&mut self) {
        if let Some(b) = self.bricks.as_mut() {
            for s in &mut b.slots {
                s.occupancy.source = None;
                s.shows = None;
            }
        }
    }

    /// Waits for the device to finish everything submitted, which frees the
    /// textures of evicted bricks: a frame streaming bricks faster than the
    /// device renders them would otherwise hold them all at once.
    pub fn wait_idle(&self) -> Result<(), Error> {
        self.check_process()?;
        // Uploads wait in the queue for a submit: flush them first.
        let Some(ctx) = self.dev.gpu.as_deref() else {
            return Ok(());
        };
        ctx.queue.submit([]);
        ctx.device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map(drop)
            .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))
    }

    pub fn brick_resident(&self, index: usize) -> bool {
        self.bricks.as_ref().and_then(|b| b.slots.get(index)).is_some_and(|s| s.volume.is_some())
    }

    /// Starts a bricked frame and returns the bricks it needs, in the order
    /// they must be rendered: bricks once loaded whose values cannot show
    /// under the transfer function (or cannot reach the iso value) are left
    /// out. `keep_state`: end with a partial image.
    pub fn begin_bricks(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        keep_state: bool,
    ) -> Result<Vec<usize>, Error> {
        self.check_process()?;
        self.brick_frame = None;
        let Some(b) = self.bricks.as_ref() else {
            return Err(Error::InvalidInput("no bricked volume is loaded".into()));
        };
        if self.tables.lut.is_none() {
            return Err(Error::InvalidInput("no transfer function set: call set_transfer_functions() first".into()));
        }
        cfg.validate()?;
        if cfg.model == Model::SingleScattering {
            return Err(Error::InvalidInput(
                "the single_scattering model's shadow rays cross the whole volume, which a bricked volume never \
                 holds at once: use another model, or a volume that fits in one texture"
                    .into(),
            ));
        }
        let basis = camera.basis(self.width, self.height)?;
        let inputs = FrameInputs {
            bounds: b.bounds,
            dims: b.grid.dims,
            width: self.width,
            height: self.height,
            lut_size: self.tables.lut.as_ref().map_or(1, |(_, n)| *n),
            value_map: self.value_map,
            clip: self.clip,
            planes: &self.planes,
            max_extinction: self.max_extinction(cfg),
        };
        let params = Params { keep_state: keep_state as u32, ..Params::new(&inputs, &basis, light, cfg) };
        let params = super::with_depth_in(&self.depth_in, &mut self.depth_texels, params, &b.bounds);
        // The eye in continuous voxel coordinates.
        let dims = DVec3::new(b.grid.dims[0] as f64, b.grid.dims[1] as f64, b.grid.dims[2] as f64);
        let eye = (camera.ordering_eye(&b.bounds) - b.bounds.min) / b.bounds.extent() * dims;
        // (Bricks loaded while the native march was off keep no texels for it.)
        let native =
            self.native_bricks(cfg) && b.slots.iter().all(|s| s.volume.as_ref().is_none_or(|v| v.cpu.is_some()));
        let mut order = b.grid.front_to_back(eye);
        // (The native march takes back-to-front frames front to back, the
        // same sum, but for unbiased ones, whose points it draws from the far end.)
        if marches_back_to_front(cfg) && (!native || cfg.unbiased) {
            order.reverse();
        }
        // Whether anything in a brick can show, kept per table (or iso value)
        // so that a frame does not redo every brick's cells.
        let source = match cfg.model {
            Model::Isosurface => Some(OccSource::Below(cfg.iso_value.to_bits())),
            // (The cells' own ranges: a brick whose values, ghosts included,
            // all have opacity 0 holds only empty segments, pre-integrated too.)
            m if m.skips_transparent() && self.skip_empty => Some(OccSource::Lut {
                version: self.tables.version,
                ranges: SegmentRanges::Plain,
                form: cfg.opacity_correction,
            }),
            _ => None,
        };
        let (rows, map) = (&self.tables.rows, self.value_map);
        let b = self.bricks.as_mut().expect("checked above");
        let mut needed = vec![true; b.slots.len()];
        if let Some(source) = source {
            for (slot, need) in b.slots.iter_mut().zip(&mut needed) {
                // A brick never read may hold anything.
                let Some(g) = &slot.grid else { continue };
                *need = match slot.shows {
                    Some((s, shows)) if s == source => shows,
                    _ => {
                        let shows = match source {
                            OccSource::Below(_) => g.occupancy_reaching(cfg.iso_value, map).contains(&1),
                            OccSource::Lut { .. } => g.occupancy(rows, map).contains(&1),
                        };
                        slot.shows = Some((source, shows));
                        shows
                    }
                };
            }
        }
        let b = self.bricks.as_ref().expect("checked above");
        // Bricks outside the crop box or the view are never read.
        let (width, height) = (self.width, self.height);
        let seen = |i: usize| {
            let core = core_box(&b.grid, &b.bounds, i);
            let cropped = self.clip.map_or(Some(core), |c| core.intersection(&c));
            cropped.is_some_and(|c| screen_rect(&basis, &c, width, height).is_none_or(|r| r.width > 0 && r.height > 0))
        };
        let order: Vec<usize> = order.into_iter().filter(|&i| needed[i] && seen(i)).collect();
        let pixels = self.width as u64 * self.height as u64;
        let states = if native { Some(RayStates::new(self.width as usize, self.height as usize)?) } else { None };
        if !native && self.shader().frame.ray_state.pixels < pixels {
            let limit = self.dev.caps.max_storage;
            if pixels * 16 > limit {
                return Err(Error::DeviceLimit(format!(
                    "bricked frames keep 16 bytes per pixel: {}x{} is over this device's limit of {limit} bytes",
                    self.width, self.height
                )));
            }
            let state = RayState::new(self.ctx(), pixels)?;
            self.shader_mut().frame.ray_state = state;
            self.bind_group = None;
        }
        self.depth_ready = false;
        self.native_depth = None;
        self.brick_frame = Some(BrickFrame {
            camera: *camera,
            light: *light,
            cfg: *cfg,
            params,
            dispatched: 0,
            samples: 0,
            truncated_needed: 0,
            last: None,
            native: states,
        });
        Ok(order)
    }

    /// Marches every ray's segments inside brick `index` (which must be
    /// resident), asking `stop` between passes.
    pub fn render_brick(&mut self, index: usize, stop: &mut dyn FnMut() -> bool) -> Result<(), Error> {
        self.check_process()?;
        let frame = self.brick_frame.take().ok_or_else(|| Error::InvalidInput("no bricked frame was begun".into()))?;
        let (slot, grid, bounds) = self.slot(index)?;
        if slot.volume.is_none() {
            self.brick_frame = Some(frame);
            return Err(Error::InvalidInput(format!("brick {index} is not loaded: call set_brick() first")));
        }
        // The brick becomes the renderer's volume for the dispatch. Its
        // bindings are made afresh: a table or buffer may have changed
        // since it was last drawn.
        let mut volume = slot.volume.take();
        let mut occupancy = std::mem::replace(&mut slot.occupancy, Occupancy::new());
        std::mem::swap(&mut self.volume, &mut volume);
        std::mem::swap(&mut self.occupancy, &mut occupancy);
        self.bind_group = None;
        let mut frame = frame;
        let result = self.dispatch_brick(&mut frame, &grid, &bounds, index, stop);
        std::mem::swap(&mut self.volume, &mut volume);
        std::mem::swap(&mut self.occupancy, &mut occupancy);
        self.bind_group = None;
        let (slot, _, _) = self.slot(index)?;
        (slot.volume, slot.occupancy) = (volume, occupancy);
        self.brick_frame = Some(frame);
        result
    }

    fn dispatch_brick(
        &mut self,
        frame: &mut BrickFrame,
        grid: &BrickGrid,
        bounds: &Bounds,
        index: usize,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<(), Error> {
        let cfg = frame.cfg;
        self.update_occupancy(self.occupancy_source(&cfg))?;
        let (variant, plan) = self.prepare(&frame.camera, &frame.light, &cfg)?;
        if let Some(states) = frame.native.as_mut() {
            let vol = self.volume.as_ref().expect("swapped in");
            if vol.cpu.is_none() {
                return Err(Error::OutOfMemory(format!(
                    "brick {index}'s texels could not be kept in memory for the native march"
                )));
            }
            let mut params =
                frame.params.for_brick(bounds, grid, index).with_slopes(vol.grid.slopes, self.value_map.scale);
            if let Some(cells) = self.occupancy.occupied.filter(|_| cfg.model != Model::Isosurface) {
                // Rays march only the window of the brick's occupied cells
                // (the isosurface's leaps keep its bracket's lower end).
                params = params.with_occupied(cells, vol.grid.dims);
            }
            let params = native_params(&params);
            let native = self.native_frame(&variant, &params);
            let s = crate::cpu::render_brick(&native, states, stop).map_err(|_| Error::Interrupted)?;
            frame.samples += s.samples;
            frame.truncated_needed = frame.truncated_needed.max(s.truncated_needed);
            frame.dispatched += 1;
            return Ok(());
        }
        self.bind(&variant)?;
        let bind_group = self.bind_group.as_ref().expect("bound above").0.clone();
        let slopes = self.volume.as_ref().expect("swapped in").grid.slopes;
        let params = frame.params.for_brick(bounds, grid, index).with_slopes(slopes, self.value_map.scale);
        let ends = Ends { first: frame.dispatched == 0, last: false };
        let core = self.volume.as_ref().expect("swapped in").bounds;
        let rect = screen_rect(&frame.camera.basis(self.width, self.height)?, &core, self.width, self.height);
        if rect.is_some_and(|r| r.width == 0 || r.height == 0) && !ends.first {
            // The brick is off screen.
            return Ok(());
        }
        self.dispatch(variant, &bind_group, params, plan, ends, rect, stop)?;
        frame.dispatched += plan.passes;
        frame.last = Some((variant, bind_group));
        Ok(())
    }

    /// Finishes the bricked frame into `out` (width * height * 4 floats,
    /// row 0 at the bottom): premultiplied RGBA, or with `keep_state` each
    /// ray's state (colour, optical depth) or (value, 1 if any sample, -, -).
    pub fn end_bricks(&mut self, out: &mut [f32]) -> Result<FrameStats, Error> {
        self.check_process()?;
        let (w, h) = self.whole_frame(out.len(), "output slice")?;
        let frame = self.brick_frame.take().ok_or_else(|| Error::InvalidInput("no bricked frame was begun".into()))?;
        let bounds = self.bricks.as_ref().expect("a frame was begun").bounds;
        if let Some(states) = &frame.native {
            // The closing pass: every ray ends from its state.
            let model = frame.cfg.model;
            // (The isosurface's partial image is its pixels, as the shader's.)
            let keep = frame.params.keep_state == 1 && frame.cfg.model != Model::Isosurface;
            let target = Target::floats(out, w, h, Format::PREMULTIPLIED);
            let mut px = Vec::with_capacity(w);
            for (row, pixels) in states.states().chunks(w).enumerate() {
                px.clear();
                if !keep {
                    px.extend((0..w).map(|x| states.pixel(row * w + x, model, self.tables.march_rows())));
                }
                // SAFETY: one thread writes the image, row by row.
                unsafe { target.put(row, 0, if keep { pixels } else { &px }) };
            }
            self.depth_ready = frame.cfg.model == Model::Isosurface;
            if self.depth_ready {
                self.depth_unit = world_unit(&bounds);
                let mut depth = try_vec(w * h, f32::INFINITY, "the depth image")?;
                for (i, d) in depth.iter_mut().enumerate() {
                    *d = states.depth(i);
                }
                self.native_depth = Some(depth);
            }
            let stats = FrameStats {
                truncated_needed: frame.truncated_needed,
                uploaded_bytes: 0,
                passes: frame.dispatched,
                samples: frame.samples,
                native: true,
            };
            return Ok(self.finish_frame(stats, 0));
        }
        let Some((variant, bind_group)) = frame.last else {
            // No brick could show anything.
            out.fill(0.0);
            return Ok(self.finish_frame(FrameStats::default(), 0));
        };
        let params = Params { resolve: 1, ..frame.params };
        let one = PassPlan { passes: 1, pass_steps: 1, max_steps_needed: 0, per_pixel_state: true, planned_samples: 0 };
        self.dispatch(variant, &bind_group, params, one, Ends { first: false, last: true }, None, &mut || false)?;
        let (truncated_needed, samples) = self.read_image(&mut Target::floats(out, w, h, Format::PREMULTIPLIED))?;
        self.depth_ready = frame.cfg.model == Model::Isosurface;
        self.depth_unit = world_unit(&bounds);
        let uniforms = (frame.dispatched as u64 + 1) * frame.params.used_bytes().len() as u64 + STATS_BYTES;
        let stats =
            FrameStats { truncated_needed, uploaded_bytes: 0, passes: frame.dispatched + 1, samples, native: false };
        Ok(self.finish_frame(stats, uniforms))
    }
}
