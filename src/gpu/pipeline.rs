//! The ray-marching shader and its specialised variants. One WGSL source;
//! each scene feature that changes the inner loop is an override constant, so
//! a frame only runs the code its scene needs. Variants compile on first use
//! and stay cached for the life of the process.

use super::context::{GpuContext, GpuError};
use crate::config::OpacityCorrection;
use crate::scene::{LightKind, Shading};
use std::collections::HashMap;
use std::sync::Mutex;

pub const SHADER_SOURCE: &str = include_str!("../../shaders/raymarch.wgsl");
pub const WORKGROUP: u32 = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub shading: Shading,
    pub point_light: bool,
    pub early_termination: bool,
    pub correction: OpacityCorrection,
}

impl Variant {
    pub fn new(shading: Shading, light: LightKind, early: bool, correction: OpacityCorrection) -> Self {
        Variant {
            shading,
            // The light's kind only matters when a diffuse term is computed.
            point_light: shading != Shading::AmbientOnly && light == LightKind::Point,
            early_termination: early,
            correction,
        }
    }

    fn constants(&self) -> [(&'static str, f64); 4] {
        let shading = match self.shading {
            Shading::AmbientOnly => 0.0,
            Shading::Normals => 1.0,
            Shading::Gradient => 2.0,
        };
        [
            ("SHADING", shading),
            ("POINT_LIGHT", self.point_light as u32 as f64),
            ("EARLY_TERMINATION", self.early_termination as u32 as f64),
            ("POWER_CORRECTION", (self.correction == OpacityCorrection::Power) as u32 as f64),
        ]
    }
}

pub struct Pipelines {
    module: wgpu::ShaderModule,
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
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

fn texture3d(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        // Unfilterable accepts every float-readable format (R8Unorm, R16Unorm,
        // R32Float, Rgba16Float): filtering is done in the shader.
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    }
}

impl Pipelines {
    pub fn new(ctx: &GpuContext) -> Result<Pipelines, GpuError> {
        let device = &ctx.device;
        ctx.scoped("compiling the ray-marching shader", || {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("raymarch.wgsl"),
                source: wgpu::ShaderSource::Wgsl(SHADER_SOURCE.into()),
            });
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("raymarch"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    texture3d(1),
                    texture3d(2),
                    storage(3, true),
                    storage(4, false),
                    storage(5, false),
                ],
            });
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("raymarch"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            Pipelines { module, layout, pipeline_layout, cache: Mutex::new(HashMap::new()) }
        })
    }

    pub fn get(&self, ctx: &GpuContext, v: Variant) -> Result<wgpu::ComputePipeline, GpuError> {
        let mut cache = self.cache.lock().map_err(|_| GpuError("pipeline cache poisoned".into()))?;
        if let Some(p) = cache.get(&v) {
            return Ok(p.clone());
        }
        let constants = v.constants();
        let p = ctx.scoped("building a ray-marching pipeline", || {
            ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("raymarch"),
                layout: Some(&self.pipeline_layout),
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
