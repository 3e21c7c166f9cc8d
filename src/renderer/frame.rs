//! A renderer's frame: check, plan, bind, dispatch, read back.

use super::{BindKey, Ends, FrameStats, Rect, Renderer, LEAP_MIN_UNIFORM, SKIP_MIN_EMPTY, STATS_BYTES};
use crate::config::{OpacityCorrection, RenderConfig};
use crate::error::{try_vec, Error};
use crate::gpu::bindings;
use crate::gpu::passes::{plan, PassPlan};
use crate::gpu::pipeline::{dispatch_groups, Layout, Variant};
use crate::gpu::readback::read_buffers;
use crate::integrate::max_extinction;
use crate::model::Model;
use crate::output::{Format, Image, Pixels, Target};
use crate::plan::params::{world_unit, FrameInputs, Params};
use crate::preintegrate;
use crate::renderer::resources::{readback_buffer, PreintKey, RayState};
use crate::scene::{Camera, Light, Shading};

impl Renderer {
    /// Renders into `out` (width * height * 4 floats: premultiplied RGBA,
    /// row 0 at the bottom).
    pub fn render_into(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        out: &mut [f32],
    ) -> Result<FrameStats, Error> {
        self.render_into_interruptible(camera, light, cfg, out, &mut || false)
    }

    /// `render_into`, asking `stop` between the passes of a long frame
    /// (passes are sized to about PASS_SECONDS each at this device's
    /// measured speed); `stop` returning true ends the frame with
    /// `Error::Interrupted` once the pass in flight is done.
    pub fn render_into_interruptible(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        out: &mut [f32],
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<FrameStats, Error> {
        let (w, h) = self.whole_frame(out.len(), "output slice")?;
        let mut target = Target::floats(out, w, h, Format::PREMULTIPLIED);
        self.render_frame(camera, light, cfg, &mut target, false, stop)
    }

    /// `render_into_interruptible` into `out`, the frame's size, in its
    /// format; `blank`: `out` holds what a pixel no ray colours is already,
    /// so the native march leaves the pixels whose rays miss the box
    /// unwritten (a large frame's pages it never touches then cost nothing).
    fn render_frame(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        out: &mut Target,
        blank: bool,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<FrameStats, Error> {
        self.check_process()?;
        assert_eq!(out.size(), (self.width as usize, self.height as usize), "the frame's size");
        self.check_ready(cfg)?;
        self.update_occupancy(self.occupancy_source(cfg))?;
        let params = self.params(camera, light, cfg)?;
        let bounds = self.volume.as_ref().expect("checked by check_ready").bounds;
        let params = super::with_depth_in(&self.depth_in, &mut self.depth_texels, params, &bounds);
        self.depth_ready = false;
        self.native_depth = None;
        if self.skip_empty && self.occupancy.empty_fraction == 1.0 && cfg.model.skips_transparent() {
            // Every sample of every ray would have opacity 0.
            if !blank {
                out.clear();
            }
            return Ok(self.finish_frame(FrameStats::default(), 0));
        }
        let (variant, passes) = self.prepare(camera, light, cfg)?;
        if self.native_covers(&variant, cfg) {
            return self.render_native(&variant, &params, out, blank, stop);
        }
        self.bind(&variant)?;
        let started = std::time::Instant::now();
        let bind_group = self.bind_group.as_ref().expect("bound above").0.clone();
        self.dispatch(variant, &bind_group, params, passes, Ends { first: true, last: true }, None, stop)?;
        let (truncated_needed, samples) = self.read_image(out)?;
        self.depth_ready = cfg.model == Model::Isosurface;
        self.depth_unit = world_unit(&self.volume.as_ref().expect("checked by check_ready").bounds);
        self.measure_speed(passes.planned_samples, started.elapsed());
        let uniforms = passes.passes as u64 * params.used_bytes().len() as u64 + STATS_BYTES;
        let stats = FrameStats { truncated_needed, uploaded_bytes: 0, passes: passes.passes, samples, native: false };
        Ok(self.finish_frame(stats, uniforms))
    }

    /// Whether the native CPU march renders this frame: the volume's texels
    /// are kept for it (the adapter is a CPU that runs it) and the frame is
    /// of the kind it covers (`crate::cpu`).
    fn native_covers(&self, variant: &Variant, cfg: &RenderConfig) -> bool {
        let Some(cpu) = self.volume.as_ref().and_then(|v| v.cpu.as_ref()) else {
            return false;
        };
        if self.shader.is_none() {
            // The only engine: it renders every frame.
            return true;
        }
        // The native march runs every model and option; what it may lack is
        // a volume's normals (kept with the texels only where it runs).
        // Projections take no light; single scattering reads no normals.
        let shading = variant.model.projects()
            || variant.model == Model::SingleScattering
            || variant.shading != Shading::Normals
            || cpu.has_normals();
        // Back-to-front frames (whose variant never stops early) are marched
        // front to back: the same segments and the same sum, rounded in
        // another order.
        self.native_march
            && shading
            && !(variant.cell_rates && self.occupancy.majorants.is_empty())
            && cfg.max_steps <= crate::cpu::MAX_STEPS as i64
    }

    fn render_native(
        &mut self,
        variant: &Variant,
        params: &Params,
        out: &Target,
        blank: bool,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<FrameStats, Error> {
        let params = native_params(params);
        let frame = self.native_frame(variant, &params);
        let iso = frame.model == Model::Isosurface;
        let pixels = self.width as usize * self.height as usize;
        let mut depth = if iso { Some(try_vec(pixels, f32::INFINITY, "the depth image")?) } else { None };
        // (The depth image starts at infinity, a miss's.)
        let s = crate::cpu::render(&frame, out, depth.as_deref_mut(), blank, stop).map_err(|_| Error::Interrupted)?;
        if iso {
            self.depth_unit = world_unit(&self.volume.as_ref().expect("checked by native_covers").bounds);
            self.depth_ready = true;
            self.native_depth = depth;
        }
        let stats = FrameStats {
            truncated_needed: s.truncated_needed,
            uploaded_bytes: 0,
            passes: 1,
            samples: s.samples,
            native: true,
        };
        Ok(self.finish_frame(stats, 0))
    }

    /// The native march's frame of the current volume (which keeps its
    /// texels for it) and tables under `variant`, from `native_params`.
    pub(super) fn native_frame<'a>(&'a self, variant: &Variant, params: &'a Params) -> crate::cpu::Frame<'a> {
        let vol = self.volume.as_ref().expect("the volume keeps its texels");
        let cpu = vol.cpu.as_ref().expect("the volume keeps its texels");
        let occ = &self.occupancy;
        let model = variant.model;
        let iso = model == Model::Isosurface;
        // Every value counts in a projection: no empty cells, no runs (maximum
        // and minimum ones leap by their cells' bounds instead).
        let cells = !occ.codes.is_empty() && !model.projects();
        crate::cpu::Frame {
            params,
            depth_in: (params.depth_in == 1).then_some(&self.depth_texels[..]),
            volume: cpu,
            lut: self.tables.march_rows(),
            cells: cells.then_some((&occ.codes[..], occ.dims)),
            skip_empty: variant.skip_empty && cells,
            // Single scattering's light comes from shadow rays, not normals.
            lit: variant.shading != Shading::AmbientOnly && !model.projects() && model != Model::SingleScattering,
            gradient: variant.shading == Shading::Gradient,
            point_light: variant.point_light,
            early_termination: variant.early_termination && !model.projects(),
            jitter: variant.jitter,
            uniform_runs: variant.uniform_cells && cells && !iso,
            model,
            // Unbiased frames track points, never segments (as the shader's
            // `march_tracking`, which takes no pre-integration table).
            preint: (variant.pre_integrated && !variant.unbiased).then_some(&self.tables.preint_texels),
            refine: if variant.pre_integrated && !variant.unbiased { variant.refine } else { 0 },
            power: variant.correction == OpacityCorrection::Power,
            scatter: model == Model::SingleScattering && variant.shading != Shading::AmbientOnly,
            unbiased: variant.unbiased,
            back_to_front: variant.unbiased && variant.back_to_front,
            majorants: (variant.unbiased && variant.cell_rates && cells).then_some(&occ.majorants[..]),
            bounds: (variant.skip_empty && variant.model.leaps_by_bounds())
                .then(|| vol.projection_bounds(self.value_map, model == Model::Mip)),
        }
    }

    /// Whether a bricked frame under `cfg` is marched natively, brick after
    /// brick: the adapter is a CPU that runs the march (whose bricks then
    /// keep their texels, `set_brick`), and the frame is emission-absorption
    /// (plain, pre-integrated, refined or unbiased), absorption or emission,
    /// a projection or the isosurface.
    pub(super) fn native_bricks(&self, cfg: &RenderConfig) -> bool {
        // (Single scattering's shadow rays would cross other bricks.)
        let covered = cfg.model != Model::SingleScattering;
        if self.shader.is_none() {
            return true;
        }
        self.native_march && self.dev.caps.native && covered && cfg.max_steps <= crate::cpu::MAX_STEPS as i64
    }

    /// Copies the last dispatch's image into `out`, in its format, on every
    /// core: the mapped readback memory is slow to read from one, and a large
    /// image's copy on one core took longer than a GPU's frame. Returns the
    /// frame's statistics (largest step
    /// count a truncated ray needed, samples).
    pub(super) fn read_image(&self, out: &mut Target) -> Result<(u32, u64), Error> {
        let f = &self.shader().frame;
        read_buffers(self.ctx(), &[&f.output.readback, &f.stats_readback], "the image", |data| {
            out.put_image(bytemuck::cast_slice(data[0]));
            let w: &[u32] = bytemuck::cast_slice(data[1]);
            (w[0], w[1] as u64 | (w[2] as u64) << 32)
        })
    }

    /// The frame's (width, height), where `len` values are its RGBA; else
    /// an error naming `what`.
    pub(super) fn whole_frame(&self, len: usize, what: &str) -> Result<(usize, usize), Error> {
        let (w, h) = (self.width as usize, self.height as usize);
        if len != w * h * 4 {
            return Err(Error::InvalidInput(format!(
                "{what} has {len} values, expected {} ({w} x {h} x 4)",
                w * h * 4
            )));
        }
        Ok((w, h))
    }

    fn check_ready(&self, cfg: &RenderConfig) -> Result<(), Error> {
        if self.volume.is_none() {
            return Err(Error::InvalidInput("no volume loaded: call load_volume() first".into()));
        }
        if self.tables.lut.is_none() {
            return Err(Error::InvalidInput("no transfer function set: call set_transfer_functions() first".into()));
        }
        cfg.validate()?;
        Ok(())
    }

    /// Counts the frame and what it uploaded (pending resources plus `uniforms`).
    pub(super) fn finish_frame(&mut self, stats: FrameStats, uniforms: u64) -> FrameStats {
        let uploaded = std::mem::take(&mut self.pending_upload) + uniforms;
        self.counters.frames += 1;
        self.counters.uploaded_bytes += uploaded;
        FrameStats { uploaded_bytes: uploaded, ..stats }
    }

    /// The transfer function's largest extinction per reference step.
    pub(super) fn max_extinction(&self, cfg: &RenderConfig) -> f64 {
        max_extinction(&self.tables.rows, cfg.opacity_correction)
    }

    /// Samples a step takes at most on average: 1, or an unbiased frame's
    /// Poisson points at its largest rate.
    fn points_per_step(&self, cfg: &RenderConfig) -> f64 {
        if !cfg.unbiased {
            return 1.0;
        }
        cfg.tracking_rate(self.max_extinction(cfg) / cfg.reference_step_size) * cfg.step_size
    }

    /// Whether an unbiased frame's segments take their cells' rates: cells
    /// can only lower a rate above the least one (a point a step).
    pub(super) fn cell_rates(&self, cfg: &RenderConfig) -> bool {
        self.points_per_step(cfg) > 1.001
    }

    fn params(&self, camera: &Camera, light: &Light, cfg: &RenderConfig) -> Result<Params, Error> {
        let vol = self.volume.as_ref().expect("checked by check_ready");
        let basis = camera.basis(self.width, self.height)?;
        let inputs = FrameInputs {
            bounds: vol.bounds,
            dims: vol.dims,
            width: self.width,
            height: self.height,
            lut_size: self.tables.lut.as_ref().map_or(1, |(_, n)| *n),
            value_map: self.value_map.after(vol.stored),
            clip: self.clip,
            planes: &self.planes,
            max_extinction: self.max_extinction(cfg),
        };
        let mut params = Params::new(&inputs, &basis, light, cfg).with_slopes(vol.grid.slopes, self.value_map.scale);
        if let Some(cells) = self.occupancy.occupied {
            params = params.with_occupied(cells, vol.grid.dims);
        }
        if vol.gradients {
            // The texture has a one-voxel border: the box maps to its inner texels.
            params.border = 1;
            for a in 0..3 {
                let n = vol.dims[a] as f32;
                params.tex_scale[a] *= n / (n + 2.0);
                params.tex_offset[a] = 1.0 / (n + 2.0);
            }
        }
        Ok(params)
    }

    /// Table entries apart that a pre-integrated segment's front and back
    /// values can lie (`preintegrate::table_reach`). Trilinear values change
    /// by at most the grid's slopes per voxel along each axis, so over a
    /// segment of length h in direction d (unit) by at most h sum_k a_k |d_k|
    /// <= h |a| (a_k: slope per world unit along axis k, in the transfer
    /// function's [0, 1]); a filtering unit whose weights are rounded to
    /// 1/256 may add up to sum_k a_k / 256 voxels' worth at each end. Bricked
    /// volumes, whose bricks are read one by one, take the whole table.
    fn preint_reach(&self, cfg: &RenderConfig) -> usize {
        let side = preintegrate::table_side(self.tables.rows.len());
        let Some(vol) = self.volume.as_ref().filter(|_| self.bricks.is_none()) else {
            return side - 1;
        };
        let extent = vol.bounds.extent().to_array();
        let per_voxel: [f64; 3] = std::array::from_fn(|k| vol.grid.slopes[k] as f64 * self.value_map.scale.abs());
        let per_unit: [f64; 3] = std::array::from_fn(|k| per_voxel[k] * vol.dims[k] as f64 / extent[k]);
        let along = per_unit.iter().map(|a| a * a).sum::<f64>().sqrt() * cfg.step_size;
        let rounding = 2.0 * per_voxel.iter().sum::<f64>() / 256.0;
        preintegrate::table_reach(along + rounding, side)
    }

    /// The shader variant and the passes this frame needs, with the ray
    /// state and pre-integration table they use.
    pub(super) fn prepare(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
    ) -> Result<(Variant, PassPlan), Error> {
        let vol = self.volume.as_ref().expect("checked by check_ready");
        let shading = Shading::choose(light, vol.normals_apart || vol.normals_in_volume);
        // PYVR_EXACT_FILTERING=1 interpolates every frame in the shader, as
        // RenderConfig.exact_filtering does one config's (read each frame:
        // the test suite sets it on GPUs to compare with the f64 oracle).
        let exact_env = std::env::var("PYVR_EXACT_FILTERING").is_ok_and(|v| v.trim() == "1");
        let hw_filter = vol.filterable && !(self.shader_filtering || cfg.exact_filtering || exact_env);
        let layout = Layout { hw_filter, normals_in_volume: vol.normals_in_volume };
        // Projections' leaps need no empty cells, only the cells' bounds.
        let skip = self.skip_empty && (cfg.model.leaps_by_bounds() || self.occupancy.empty_fraction >= SKIP_MIN_EMPTY);
        let mut variant = Variant::new(shading, light.kind, cfg, layout, skip);
        let shadow_rays = cfg.model == Model::SingleScattering && variant.shading != Shading::AmbientOnly;
        let pixels = self.width as u64 * self.height as u64;
        let points = self.points_per_step(cfg);
        variant.cell_rates = variant.unbiased && self.cell_rates(cfg);
        variant.uniform_cells = self.skip_empty
            && self.uniform_runs
            && variant.can_leap_uniform()
            && self.occupancy.uniform_fraction >= LEAP_MIN_UNIFORM;
        let passes = plan(cfg, &vol.bounds, camera.position, shadow_rays, points, pixels, self.pass_samples())?;
        let state_pixels = self.shader.as_ref().map_or(u64::MAX, |s| s.frame.ray_state.pixels);
        if passes.per_pixel_state && state_pixels < pixels {
            let limit = self.dev.caps.max_storage;
            if pixels * 16 > limit {
                return Err(Error::DeviceLimit(format!(
                    "rays of up to {} steps are marched in passes, which need 16 bytes per pixel: \
                     {}x{} is over this device's limit of {limit} bytes; use fewer pixels or fewer steps",
                    passes.max_steps_needed, self.width, self.height
                )));
            }
            let state = RayState::new(self.ctx(), pixels)?;
            self.shader_mut().frame.ray_state = state;
            self.bind_group = None;
        }
        if variant.pre_integrated {
            let key = PreintKey {
                lut_version: self.tables.version,
                len_over_ref: cfg.step_size / cfg.reference_step_size,
                form: cfg.opacity_correction,
                reach: self.preint_reach(cfg),
            };
            if self.tables.ensure_preint(key) {
                self.bind_group = None;
            }
        }
        Ok((variant, passes))
    }

    /// Writes this frame's depth texels into the depth texture (made at the
    /// image's size when there is none yet) and returns its number.
    fn upload_depth_in(&mut self) -> Result<u64, Error> {
        let (w, h) = (self.width, self.height);
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        if self.depth_texture.as_ref().is_none_or(|t| t.0.size() != size) {
            let ctx = self.ctx();
            let texture = ctx.scoped("allocating the depth texture", || {
                ctx.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("depth in"),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::R32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                })
            })?;
            let view = texture.create_view(&Default::default());
            self.depth_textures_made += 1;
            self.depth_texture = Some((texture, view, self.depth_textures_made));
        }
        let (texture, _, number) = self.depth_texture.as_ref().expect("made above");
        self.ctx().queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&self.depth_texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
            size,
        );
        self.pending_upload += 4 * w as u64 * h as u64;
        Ok(*number)
    }

    /// Makes the bind group unless the current one still holds every
    /// resource `variant` reads. A maximum or minimum projection that leaps
    /// reads its cells' bounds where the occupancy grid is bound.
    pub(super) fn bind(&mut self, variant: &Variant) -> Result<(), Error> {
        let hw_filter = variant.layout.hw_filter;
        let projection = (variant.skip_empty && variant.model.leaps_by_bounds())
            .then_some((self.value_map, variant.model == Model::Mip));
        let depth = if self.depth_in.is_some() { Some(self.upload_depth_in()?) } else { None };
        let key = BindKey { hw_filter, projection, depth };
        if self.bind_group.as_ref().is_some_and(|(_, k)| *k == key) {
            return Ok(());
        }
        self.pending_upload += self.tables.upload_preint(&self.dev)?;
        self.pending_upload += self.volume.as_mut().expect("checked by check_ready").ensure_textures(&self.dev)?;
        let occupancy = match projection {
            Some((map, upper)) => {
                let vol = self.volume.as_ref().expect("checked by check_ready");
                let (view, bytes) = vol.projection_view(&self.dev, map, upper)?;
                self.pending_upload += bytes;
                view
            }
            None => self
                .occupancy
                .view
                .clone()
                .ok_or_else(|| Error::Gpu("the occupancy grid is missing: load the volume again".into()))?,
        };
        let sh = self.shader();
        let preint = self.tables.preint.as_ref().and_then(|(v, _)| v.as_ref()).unwrap_or(&sh.fixed.no_preint);
        let vol = self.volume.as_ref().expect("checked by check_ready");
        let (lut, _) = self.tables.lut.as_ref().expect("checked by check_ready");
        let normals = vol.normals.as_ref().unwrap_or(&sh.fixed.no_normals);
        let view = wgpu::BindingResource::TextureView;
        let sampler = wgpu::BindingResource::Sampler;
        let f = &sh.frame;
        let entries = [
            (bindings::PARAMS, f.uniform.as_entire_binding()),
            (bindings::VOLUME, view(vol.view.as_ref().expect("made above"))),
            (bindings::NORMALS, view(normals)),
            (bindings::LUT, view(lut.as_ref().expect("uploaded with a device"))),
            (bindings::IMAGE, f.output.storage.as_entire_binding()),
            (bindings::STATS, f.stats.as_entire_binding()),
            (bindings::VOLUME_SAMPLER, sampler(&sh.fixed.volume_samplers[hw_filter as usize])),
            (bindings::LINEAR_SAMPLER, sampler(&sh.fixed.linear_sampler)),
            (bindings::RAY_STATE, f.ray_state.state.as_entire_binding()),
            (bindings::RAY_DONE, f.ray_state.done.as_entire_binding()),
            (bindings::OCCUPANCY, view(&occupancy)),
            (bindings::PREINT, view(preint)),
            (
                bindings::DEPTH_IN,
                view(self.depth_texture.as_ref().filter(|_| depth.is_some()).map_or(&sh.fixed.no_depth, |t| &t.1)),
            ),
        ]
        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource });
        let ctx = self.ctx();
        let group = ctx.scoped("binding frame resources", || {
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("raymarch"),
                layout: &sh.pipelines.layouts[hw_filter as usize].bind_group,
                entries: &entries,
            })
        })?;
        self.bind_group = Some((group, key));
        Ok(())
    }

    /// Submits a brick's (or the whole volume's) passes; the frame's first
    /// dispatch clears the statistics and its last copies the image and
    /// statistics to their readback buffers.
    pub(super) fn dispatch(
        &self,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        params: Params,
        plan: PassPlan,
        ends: Ends,
        rect: Option<Rect>,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<(), Error> {
        // The frame's first dispatch starts every ray: it covers the image.
        let rect = match rect {
            Some(r) if !ends.first => r,
            _ => Rect { x: 0, y: 0, width: self.width, height: self.height },
        };
        let sh = self.shader();
        let ctx = self.ctx();
        let pipeline = sh.pipelines.get(ctx, variant)?;
        let f = &sh.frame;
        if ends.first {
            ctx.queue.write_buffer(&f.stats, 0, &[0u8; STATS_BYTES as usize]);
        }
        let image_bytes = self.width as u64 * self.height as u64 * 16;
        let mut in_flight = None;
        for pass in 0..plan.passes {
            let first = ends.first && pass == 0;
            let last = ends.last && pass + 1 == plan.passes;
            let p = Params {
                pass_start: pass * plan.pass_steps,
                pass_steps: plan.pass_steps,
                first_pass: first as u32,
                last_pass: (pass + 1 == plan.passes) as u32,
                only_dispatch: (first && last) as u32,
                tile_x: rect.x,
                tile_y: rect.y,
                ..params
            };
            // Writes before a submit are ordered with it: each pass sees its own.
            ctx.queue.write_buffer(&f.uniform, 0, p.used_bytes());
            let submitted = ctx.scoped("rendering", || {
                let mut enc =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
                {
                    let mut cpass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("raymarch"),
                        timestamp_writes: None,
                    });
                    cpass.set_pipeline(&pipeline);
                    cpass.set_bind_group(0, bind_group, &[]);
                    let (gx, gy) = dispatch_groups(rect.width, rect.height);
                    cpass.dispatch_workgroups(gx, gy, 1);
                }
                if last {
                    enc.copy_buffer_to_buffer(&f.output.storage, 0, &f.output.readback, 0, image_bytes);
                    enc.copy_buffer_to_buffer(&f.stats, 0, &f.stats_readback, 0, STATS_BYTES);
                }
                ctx.queue.submit([enc.finish()])
            })?;
            // One pass stays queued while the one before finishes: the GPU
            // keeps busy, and the caller is asked about stopping every pass.
            if let Some(previous) = in_flight.replace(submitted) {
                ctx.device
                    .poll(wgpu::PollType::Wait { submission_index: Some(previous), timeout: None })
                    .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))?;
                if stop() {
                    return Err(Error::Interrupted);
                }
            }
        }
        Ok(())
    }

    /// Ray parameter (distance from the camera along each unit-length ray)
    /// of the last frame's isosurface hits, row 0 at the bottom; infinity
    /// where a ray found no surface. `None` unless the last frame was an
    /// isosurface.
    pub fn depth(&mut self) -> Result<Option<Vec<f32>>, Error> {
        self.check_process()?;
        if !self.depth_ready {
            return Ok(None);
        }
        let unit = self.depth_unit as f32;
        if let Some(d) = &self.native_depth {
            return Ok(Some(d.iter().map(|&t| t * unit).collect()));
        }
        let bytes = self.width as u64 * self.height as u64 * 16;
        let ctx = self.ctx();
        let staging =
            ctx.scoped("reading the depth image", || readback_buffer(&ctx.device, "depth readback", bytes))?;
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("depth") });
        enc.copy_buffer_to_buffer(&self.shader().frame.ray_state.state, 0, &staging, 0, bytes);
        ctx.queue.submit([enc.finish()]);
        read_buffers(ctx, &[&staging], "the depth", |data| {
            let v: &[[f32; 4]] = bytemuck::cast_slice(data[0]);
            // The shader measures in units of the box's longest side.
            Some(v.iter().map(|s| s[0] * unit).collect())
        })
    }

    pub fn render(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
    ) -> Result<(Vec<f32>, FrameStats), Error> {
        self.render_interruptible(camera, light, cfg, &mut || false)
    }

    /// `render`, asking `stop` between passes (see `render_into_interruptible`).
    pub fn render_interruptible(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<(Vec<f32>, FrameStats), Error> {
        let (image, stats) = self.render_image(camera, light, cfg, Format::PREMULTIPLIED, stop)?;
        match image.pixels {
            Pixels::Floats(v) => Ok((v, stats)),
            Pixels::Codes(_) => unreachable!("a float format"),
        }
    }

    /// `render_interruptible` into a new image in `format`.
    pub fn render_image(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        format: Format,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<(Image, FrameStats), Error> {
        let mut image = Image::zeroed(self.width as usize, self.height as usize, format)?;
        let mut target = image.target();
        let blank = target.blank_when_zeroed();
        let stats = self.render_frame(camera, light, cfg, &mut target, blank, stop)?;
        Ok((image, stats))
    }

    /// `render_interruptible`, adding the frame's premultiplied pixels to
    /// `sums` (width * height * 4 float64, row 0 at the bottom) instead of
    /// returning an image: frames averaged for progressive refinement.
    pub fn accumulate_interruptible(
        &mut self,
        camera: &Camera,
        light: &Light,
        cfg: &RenderConfig,
        sums: &mut [f64],
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<FrameStats, Error> {
        let (w, h) = self.whole_frame(sums.len(), "sums")?;
        self.render_frame(camera, light, cfg, &mut Target::sums(sums, w, h), true, stop)
    }
}

/// `params` for the native march: its workers flush subnormal results to
/// zero but read subnormal operands (crate::cpu), so the value map's scale
/// is joined here, on a thread that keeps it.
///
/// The march takes at most `cpu::MAX_STEPS` steps a ray: a ray that needs
/// more (a step 1e-9 of the box) is cut short there, and reported so.
pub(super) fn native_params(params: &Params) -> Params {
    let mut params = *params;
    params.max_steps = params.max_steps.min(crate::cpu::MAX_STEPS);
    params.value_scale = (params.value_prescale as f64 * params.value_scale as f64) as f32;
    params.value_prescale = 1.0;
    params
}
