//! The wgpu path against the f64 integrator on the same scenes and steps.
//! Tolerance: the GPU computes in f32 (positions, weights, exp), the oracle
//! in f64; over a few hundred steps the difference stays far below one 8-bit
//! level, so we ask for max 1.5/255 on premultiplied RGBA and mean 0.2/255.

use glam::DVec3;
use pyvr_core::config::{OpacityCorrection, RenderConfig};
use pyvr_core::gpu::GpuRenderer;
use pyvr_core::integrate::{render, Frame};
use pyvr_core::scene::{Bounds, Camera, Light, LightKind};
use pyvr_core::volume::{VolumeView, Voxels};

fn blob(dims: [usize; 3]) -> Vec<f32> {
    let mut v = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for i in 0..dims[0] {
        for j in 0..dims[1] {
            for k in 0..dims[2] {
                let x = (i as f64 + 0.5) / dims[0] as f64 - 0.45;
                let y = (j as f64 + 0.5) / dims[1] as f64 - 0.55;
                let z = (k as f64 + 0.5) / dims[2] as f64 - 0.5;
                v.push((-(x * x + y * y + z * z) * 12.0).exp() as f32);
            }
        }
    }
    v
}

fn ramp_lut() -> Vec<[f32; 4]> {
    (0..64)
        .map(|i| {
            let s = i as f32 / 63.0;
            [s, 1.0 - s, 0.5, 0.6 * s]
        })
        .collect()
}

fn compare(frame: &Frame, label: &str) {
    for shader_filtering in [false, true] {
        compare_path(frame, &format!("{label} (shader filtering: {shader_filtering})"), shader_filtering);
    }
}

fn compare_path(frame: &Frame, label: &str, shader_filtering: bool) {
    let mut gpu = GpuRenderer::new(frame.width, frame.height).expect("GPU");
    gpu.shader_filtering = shader_filtering;
    gpu.set_volume(&frame.volume).unwrap();
    gpu.set_lut(frame.lut).unwrap();
    let (img, stats) = gpu.render(&frame.camera, &frame.light, &frame.config).unwrap();
    let (oracle, needed) = render(frame).unwrap();
    assert_eq!(stats.truncated_needed as u64, needed, "{label}: truncation report");
    let mut max = 0.0f64;
    let mut sum = 0.0f64;
    for (g, o) in img.chunks_exact(4).zip(oracle.iter()) {
        for c in 0..4 {
            let d = (g[c] as f64 - o[c]).abs();
            max = max.max(d);
            sum += d;
        }
    }
    let mean = sum / img.len() as f64;
    assert!(max * 255.0 < 1.5, "{label}: max diff {} levels", max * 255.0);
    assert!(mean * 255.0 < 0.2, "{label}: mean diff {} levels", mean * 255.0);
    assert!(oracle.iter().any(|p| p[3] > 0.3), "{label}: scene shows something");
}

fn base_frame<'a>(vol: VolumeView<'a>, lut: &'a [[f32; 4]]) -> Frame<'a> {
    Frame {
        volume: vol,
        lut,
        camera: Camera { position: DVec3::new(1.8, 1.5, 1.2), target: DVec3::ZERO, up: DVec3::Z, fov_y: 0.8 },
        light: Light::default(),
        config: RenderConfig::default(),
        width: 40,
        height: 32,
    }
}

#[test]
fn gradient_shaded_non_cubic_anisotropic() {
    let dims = [12, 20, 9];
    let data = blob(dims);
    let lut = ramp_lut();
    let b = Bounds::new(DVec3::new(-0.6, -0.5, -0.3), DVec3::new(0.6, 0.7, 0.3)).unwrap();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, b).unwrap();
    compare(&base_frame(vol, &lut), "gradient");
}

#[test]
fn normals_point_light_power_form_truncated() {
    let dims = [10, 10, 10];
    let data = blob(dims);
    let normals: Vec<f32> = (0..1000).flat_map(|i| {
        let a = i as f32 * 0.37;
        [a.sin(), a.cos(), 0.3]
    }).collect();
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::F32(&data), Some(&normals), Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.light = Light { position: DVec3::new(0.0, 2.0, 0.5), kind: LightKind::Point, ..Light::default() };
    f.config = RenderConfig { step_size: 0.02, max_steps: 30, opacity_correction: OpacityCorrection::Power, ..RenderConfig::default() };
    compare(&f, "normals+point");
}

#[test]
fn camera_inside_axis_aligned_u8_ambient() {
    let dims = [8, 8, 8];
    let data: Vec<u8> = blob(dims).iter().map(|v| (v * 255.0) as u8).collect();
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::U8(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.camera = Camera { position: DVec3::new(0.1, 0.0, 0.0), target: DVec3::new(-1.0, 0.0, 0.0), up: DVec3::Z, fov_y: 1.2 };
    f.light = Light { diffuse: 0.0, ambient: 0.7, ..Light::default() };
    f.config = RenderConfig { early_ray_termination: false, opacity_threshold: 1.0, step_size: 0.005, max_steps: 2000, ..RenderConfig::default() };
    compare(&f, "inside");
}

#[test]
fn camera_only_rerender_uploads_only_uniforms() {
    let dims = [8, 8, 8];
    let data = blob(dims);
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
    let f = base_frame(vol, &lut);
    let mut gpu = GpuRenderer::new(16, 16).unwrap();
    gpu.set_volume(&f.volume).unwrap();
    gpu.set_lut(f.lut).unwrap();
    let (_, first) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
    assert!(first.uploaded_bytes >= 512 * 4);
    let cam = Camera { position: DVec3::new(-2.0, 0.3, 0.1), ..f.camera };
    let (_, second) = gpu.render(&cam, &f.light, &f.config).unwrap();
    assert!(second.uploaded_bytes <= 256, "camera-only frame uploaded {} bytes", second.uploaded_bytes);
}
