//! The ray-marching shader and its specialised variants. One WGSL source;
//! each scene feature that changes the inner loop is an override constant, so
//! a frame only runs the code its scene needs. Variants compile on first use
//! and stay cached for the life of the process.

use super::bindings;
use super::context::GpuContext;
use super::shader;
use crate::config::{OpacityCorrection, RenderConfig};
use crate::error::Error;
use crate::model::{Model, Order};
use crate::scene::{LightKind, Shading};
use std::collections::HashMap;
use std::sync::Mutex;

pub const WORKGROUP: u32 = 8;

/// Workgroups run in tiles of GROUP_TILE x GROUP_TILE (main.wgsl's
/// `group_origin`), not in image rows: rays marched close in time then
/// cross nearby voxels, and a CPU's caches (lavapipe) keep them.
pub const GROUP_TILE: u32 = 8;

/// The workgroups a dispatch over `width` x `height` pixels needs: whole
/// tiles (the extra workgroups find their pixels outside and return).
pub fn dispatch_groups(width: u32, height: u32) -> (u32, u32) {
    let side = |px: u32| px.div_ceil(WORKGROUP).div_ceil(GROUP_TILE) * GROUP_TILE;
    (side(width), side(height))
}

/// The most pixels per side a dispatch can cover on a device allowing
/// `max_groups` workgroups per dimension.
pub fn max_dispatch_side(max_groups: u32) -> u64 {
    (max_groups / GROUP_TILE * GROUP_TILE) as u64 * WORKGROUP as u64
}

/// How the volume is stored, as far as the shader cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Layout {
    /// The sampler filters the volume (its format is filterable).
    pub hw_filter: bool,
    /// Each texel holds (value, normal): one fetch per lit sample.
    pub normals_in_volume: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub shading: Shading,
    pub point_light: bool,
    pub early_termination: bool,
    pub correction: OpacityCorrection,
    pub layout: Layout,
    /// Leap over occupancy cells the transfer function leaves empty; in a
    /// maximum (minimum) projection, over cells whose values cannot pass a
    /// ray's maximum (minimum) so far.
    pub skip_empty: bool,
    pub model: Model,
    pub back_to_front: bool,
    pub jitter: bool,
    pub pre_integrated: bool,
    /// Midpoint samples a refined pre-integrated segment takes (0: none).
    pub refine: u32,
    /// Poisson points composited with opacity sigma / rate (ratio tracking).
    pub unbiased: bool,
    /// Unbiased segments take their occupancy cell's rate (set by the frame,
    /// where the transfer function's largest extinction tops a point a step).
    pub cell_rates: bool,
    /// Segments in a cube of uniform cells are composited as one (set by
    /// the frame, where enough cells are uniform).
    pub uniform_cells: bool,
    /// The transfer function's and the pre-integration table's lookups
    /// interpolate with f32 weights in the shader (`exact_filtering`).
    pub exact_tables: bool,
}

/// Whether rays march from the far end: only where the order changes the
/// arithmetic (absorption and emission sums do not depend on it).
pub fn marches_back_to_front(cfg: &RenderConfig) -> bool {
    cfg.order == Order::BackToFront
        && cfg.model.integrates()
        && !matches!(cfg.model, Model::Absorption | Model::Emission)
}

impl Variant {
    /// The variant a frame needs: only what its model, light and config use.
    /// `skip_empty` says the occupancy grid has empty cells worth skipping
    /// (for a maximum or minimum projection: that its rays may leap).
    pub fn new(shading: Shading, light: LightKind, cfg: &RenderConfig, layout: Layout, skip_empty: bool) -> Self {
        let model = cfg.model;
        let shading = match model {
            // Lit or not; scattering reads no normals (see the shader).
            Model::SingleScattering if shading != Shading::AmbientOnly => Shading::Normals,
            m if m.uses_light() => shading,
            _ => Shading::AmbientOnly,
        };
        let back_to_front = marches_back_to_front(cfg);
        Variant {
            // Which texture holds the normals only matters where they are read.
            layout: Layout { normals_in_volume: layout.normals_in_volume && shading == Shading::Normals, ..layout },
            skip_empty: skip_empty && (model.skips_cells() || model.leaps_by_bounds()),
            shading,
            // The light's kind only matters when a diffuse term is computed.
            point_light: shading != Shading::AmbientOnly && light == LightKind::Point,
            // Back to front cannot stop early; it is honoured by every model.
            early_termination: cfg.early_ray_termination && model.terminates_early() && cfg.order == Order::FrontToBack,
            correction: cfg.opacity_correction,
            model,
            back_to_front,
            jitter: cfg.jitter,
            pre_integrated: cfg.pre_integrates(),
            refine: if cfg.pre_integrates() { cfg.refine.clamp(0, u32::MAX as i64) as u32 } else { 0 },
            unbiased: cfg.unbiased && model.tracks(),
            cell_rates: false,
            uniform_cells: false,
            exact_tables: cfg.exact_filtering,
        }
    }

    /// Whether this variant may composite a cube of uniform cells as one
    /// segment and get the same image: segments (midpoint or pre-integrated)
    /// whose colour and extinction come from the table alone (no normals,
    /// no shadow rays).
    pub fn can_leap_uniform(&self) -> bool {
        // (Refined segments take samples inside a uniform cube too.)
        self.model.integrates() && self.shading == Shading::AmbientOnly && !self.unbiased && self.refine == 0
    }

    fn constants(&self) -> [(&'static str, f64); 17] {
        [
            ("SHADING", self.shading.code() as f64),
            ("POINT_LIGHT", self.point_light as u32 as f64),
            ("EARLY_TERMINATION", self.early_termination as u32 as f64),
            ("POWER_CORRECTION", (self.correction == OpacityCorrection::Power) as u32 as f64),
            ("HW_FILTER", self.layout.hw_filter as u32 as f64),
            ("NORMALS_IN_VOLUME", self.layout.normals_in_volume as u32 as f64),
            ("SKIP_EMPTY", self.skip_empty as u32 as f64),
            ("MODEL", self.model.code() as f64),
            ("BACK_TO_FRONT", self.back_to_front as u32 as f64),
            ("JITTER", self.jitter as u32 as f64),
            ("PRE_INTEGRATED", self.pre_integrated as u32 as f64),
            ("REFINE", self.refine as f64),
            ("UNBIASED", self.unbiased as u32 as f64),
            ("CELL_RATES", self.cell_rates as u32 as f64),
            ("UNIFORM_CELLS", self.uniform_cells as u32 as f64),
            ("EXACT_TABLES", self.exact_tables as u32 as f64),
            ("GROUP_TILE", GROUP_TILE as f64),
        ]
    }
}

/// Bind-group layouts differ only in whether the volume is filterable.
pub struct Layouts {
    pub bind_group: wgpu::BindGroupLayout,
    pipeline: wgpu::PipelineLayout,
}

pub struct Pipelines {
    module: wgpu::ShaderModule,
    /// Indexed by `hw_filter as usize`.
    pub layouts: [Layouts; 2],
    cache: Mutex<HashMap<Variant, wgpu::ComputePipeline>>,
}

fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn sampler(binding: u32, filtering: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Sampler(if filtering {
            wgpu::SamplerBindingType::Filtering
        } else {
            wgpu::SamplerBindingType::NonFiltering
        }),
        count: None,
    }
}

fn texture3d(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        // Unfilterable accepts every float-readable format; the shader then
        // interpolates by hand.
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

/// A 2-D float texture: filterable for the tables (the LUT, the
/// pre-integration table), unfilterable for R32Float read by textureLoad.
fn texture2d(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

impl Pipelines {
    pub fn new(ctx: &GpuContext) -> Result<Pipelines, Error> {
        let device = &ctx.device;
        ctx.scoped("compiling the ray-marching shader", || {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("raymarch"),
                source: wgpu::ShaderSource::Wgsl(shader::source().into()),
            });
            let make = |filterable: bool| {
                let bind_group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("raymarch"),
                    entries: &[
                        wgpu::BindGroupLayoutEntry {
                            binding: bindings::PARAMS,
                            visibility: wgpu::ShaderStages::COMPUTE,
                            ty: wgpu::BindingType::Buffer {
                                ty: wgpu::BufferBindingType::Uniform,
                                has_dynamic_offset: false,
                                min_binding_size: None,
                            },
                            count: None,
                        },
                        texture3d(bindings::VOLUME, filterable),
                        texture3d(bindings::NORMALS, true),
                        texture2d(bindings::LUT, true),
                        storage(bindings::IMAGE, false),
                        storage(bindings::STATS, false),
                        sampler(bindings::VOLUME_SAMPLER, filterable),
                        sampler(bindings::LINEAR_SAMPLER, true),
                        storage(bindings::RAY_STATE, false),
                        storage(bindings::RAY_DONE, false),
                        wgpu::BindGroupLayoutEntry {
                            binding: bindings::OCCUPANCY,
                            visibility: wgpu::ShaderStages::COMPUTE,
                            ty: wgpu::BindingType::Texture {
                                sample_type: wgpu::TextureSampleType::Uint,
                                view_dimension: wgpu::TextureViewDimension::D3,
                                multisampled: false,
                            },
                            count: None,
                        },
                        texture2d(bindings::PREINT, true),
                        texture2d(bindings::DEPTH_IN, false),
                    ],
                });
                let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("raymarch"),
                    bind_group_layouts: &[Some(&bind_group)],
                    immediate_size: 0,
                });
                Layouts { bind_group, pipeline }
            };
            let layouts = [make(false), make(true)];
            Pipelines { module, layouts, cache: Mutex::new(HashMap::new()) }
        })
    }

    pub fn get(&self, ctx: &GpuContext, v: Variant) -> Result<wgpu::ComputePipeline, Error> {
        let mut cache = self.cache.lock().map_err(|_| Error::Gpu("pipeline cache poisoned".into()))?;
        if let Some(p) = cache.get(&v) {
            return Ok(p.clone());
        }
        let constants = v.constants();
        let p = ctx.scoped("building a ray-marching pipeline", || {
            ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("raymarch"),
                layout: Some(&self.layouts[v.layout.hw_filter as usize].pipeline),
                module: &self.module,
                entry_point: Some("main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            })
        })?;
        cache.insert(v, p.clone());
        Ok(p)
    }

    pub fn cached_variants(&self) -> usize {
        self.cache.lock().map(|c| c.len()).unwrap_or(0)
    }
}
