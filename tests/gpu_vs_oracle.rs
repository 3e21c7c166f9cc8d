//! The wgpu path against the f64 integrator on the same scenes and steps.
//! Tolerance: the GPU computes in f32 (positions, weights, exp), the oracle
//! in f64; over a few hundred steps the difference stays far below one 8-bit
//! level, so we ask for max 1.5/255 on premultiplied RGBA and mean 0.2/255.

use glam::DVec3;
use pyvr_core::config::{OpacityCorrection, RenderConfig};
use pyvr_core::half::{f16_to_f32, f32_to_f16};
use pyvr_core::integrate::{render, Frame};
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light, LightKind};
use pyvr_core::transfer::ValueMap;
use pyvr_core::volume::{Precision, VolumeView, Voxels};

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
        let label = format!("{label} (shader filtering: {shader_filtering})");
        compare_path(frame, &label, shader_filtering, Precision::Float32, 1.5);
    }
}

/// Max and mean differences from the oracle, in levels, must stay under
/// `max_levels` and `max_levels / 7.5`.
fn compare_path(frame: &Frame, label: &str, shader_filtering: bool, precision: Precision, max_levels: f64) {
    let mut gpu = Renderer::new(frame.width, frame.height).expect("GPU");
    gpu.shader_filtering = shader_filtering;
    gpu.set_volume_with_precision(&frame.volume, precision).unwrap();
    gpu.set_lut(frame.lut).unwrap();
    gpu.set_value_map(frame.value_map).unwrap();
    gpu.set_clip(frame.clip);
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
    assert!(max * 255.0 < max_levels, "{label}: max diff {} levels", max * 255.0);
    assert!(mean * 255.0 < max_levels / 7.5, "{label}: mean diff {} levels", mean * 255.0);
    assert!(oracle.iter().any(|p| p.iter().any(|&c| c > 0.3)), "{label}: scene shows something");
}

fn base_frame<'a>(vol: VolumeView<'a>, lut: &'a [[f32; 4]]) -> Frame<'a> {
    Frame {
        volume: vol,
        lut,
        camera: Camera {
            position: DVec3::new(1.8, 1.5, 1.2),
            target: DVec3::ZERO,
            up: DVec3::Z,
            fov_y: 0.8,
            view_height: None,
        },
        light: Light::default(),
        config: RenderConfig::default(),
        width: 40,
        height: 32,
        adaptive_tolerance: 0.0,
        value_map: ValueMap::IDENTITY,
        clip: None,
        planes: &[],
        depth_in: None,
        slopes: None,
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
    // Refined pre-integrated segments: the slopes along anisotropic axes
    // decide which segments are refined, on both sides alike.
    let mut f = base_frame(vol, &lut);
    f.config = RenderConfig { pre_integrated: true, refine: 4, step_size: 0.05, ..RenderConfig::default() };
    compare(&f, "gradient, refined pre-integration");
}

/// A volume in data units (here -1000..3000, a CT's Hounsfield range) with
/// the value map that takes that range to the table's [0, 1]: the device
/// maps each sample as the oracle does, lit by gradients and as an isosurface.
#[test]
fn value_map_in_data_units() {
    let dims = [12, 20, 9];
    let data: Vec<f32> = blob(dims).iter().map(|v| v * 4000.0 - 1000.0).collect();
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.value_map = ValueMap::new(1.0 / 4000.0, 0.25).unwrap();
    compare(&f, "value map");
    f.config = RenderConfig { model: pyvr_core::model::Model::Isosurface, iso_value: 0.5, ..RenderConfig::default() };
    compare(&f, "value map, isosurface");
    // The refinement's reach is in the table's units: the map's scale too.
    f.config = RenderConfig { pre_integrated: true, refine: 4, step_size: 0.05, ..RenderConfig::default() };
    compare(&f, "value map, refined pre-integration");
    // u16 storage is read as value / 65535; 12-bit data spans 0..4095.
    let u16s: Vec<u16> = blob(dims).iter().map(|v| (v * 4095.0).round() as u16).collect();
    let vol = VolumeView::new(dims, Voxels::U16(&u16s), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.value_map = ValueMap::new(65535.0 / 4095.0, 0.0).unwrap();
    compare(&f, "value map, 12-bit in u16");
}

/// A crop box limits the camera rays and the shadow rays alike.
#[test]
fn clip_box_with_shadows() {
    let dims = [12, 20, 9];
    let data = blob(dims);
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.clip = Some(Bounds::new(DVec3::new(-0.5, -0.1, -0.5), DVec3::new(0.2, 0.5, 0.3)).unwrap());
    compare(&f, "clip");
    f.config = RenderConfig { model: pyvr_core::model::Model::SingleScattering, ..RenderConfig::default() };
    compare(&f, "clip, single scattering");
}

#[test]
fn normals_point_light_power_form_truncated() {
    let (data, normals, lut) = point_light_scene();
    compare(&point_light_frame(&data, &normals, &lut), "normals+point");
}

fn point_light_scene() -> (Vec<f32>, Vec<f32>, Vec<[f32; 4]>) {
    let normals: Vec<f32> = (0..1000)
        .flat_map(|i| {
            let a = i as f32 * 0.37;
            [a.sin(), a.cos(), 0.3]
        })
        .collect();
    (blob([10, 10, 10]), normals, ramp_lut())
}

fn point_light_frame<'a>(data: &'a [f32], normals: &'a [f32], lut: &'a [[f32; 4]]) -> Frame<'a> {
    let vol = VolumeView::new([10, 10, 10], Voxels::F32(data), Some(normals), Bounds::default()).unwrap();
    let mut f = base_frame(vol, lut);
    f.light = Light { position: DVec3::new(0.0, 2.0, 0.5), kind: LightKind::Point, ..Light::default() };
    f.config = RenderConfig {
        step_size: 0.02,
        max_steps: 30,
        opacity_correction: OpacityCorrection::Power,
        ..RenderConfig::default()
    };
    f
}

/// Float16 storage reads exactly the rounded values: against the oracle on
/// rounded data it is as close as float32 is on exact data. Against the
/// exact data the rounding itself shows (measured 2.1 levels here, where
/// the power form and a dense blob make the shared rounding add up).
#[test]
fn float16_storage_against_the_oracle() {
    let (data, normals, lut) = point_light_scene();
    let rounded: Vec<f32> = data.iter().map(|&v| f16_to_f32(f32_to_f16(v))).collect();
    let f = point_light_frame(&rounded, &normals, &lut);
    compare_path(&f, "float16 vs rounded data", false, Precision::Float16, 1.5);
    let f = point_light_frame(&data, &normals, &lut);
    compare_path(&f, "float16 vs exact data", false, Precision::Float16, 3.0);
}

#[test]
fn camera_inside_axis_aligned_u8_ambient() {
    let dims = [8, 8, 8];
    let data: Vec<u8> = blob(dims).iter().map(|v| (v * 255.0) as u8).collect();
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::U8(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.camera = Camera {
        position: DVec3::new(0.1, 0.0, 0.0),
        target: DVec3::new(-1.0, 0.0, 0.0),
        up: DVec3::Z,
        fov_y: 1.2,
        view_height: None,
    };
    f.light = Light { diffuse: 0.0, ambient: 0.7, ..Light::default() };
    f.config = RenderConfig {
        early_ray_termination: false,
        opacity_threshold: 1.0,
        step_size: 0.005,
        max_steps: 2000,
        ..RenderConfig::default()
    };
    compare(&f, "inside");
}

#[test]
fn camera_only_rerender_uploads_only_uniforms() {
    let dims = [8, 8, 8];
    let data = blob(dims);
    let lut = ramp_lut();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
    let f = base_frame(vol, &lut);
    let mut gpu = Renderer::new(16, 16).unwrap();
    gpu.set_volume(&f.volume).unwrap();
    gpu.set_lut(f.lut).unwrap();
    let (_, first) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
    let volume = 512 * 4;
    if gpu.device().gpu.is_none() {
        // The native engine alone uploads nothing, ever.
        assert_eq!(first.uploaded_bytes, 0);
    } else if first.native {
        // On a CPU adapter the volume's texture waits for a frame on the
        // shader, which counts it.
        assert!(first.uploaded_bytes < volume, "native frame uploaded {} bytes", first.uploaded_bytes);
        gpu.native_march = false;
        let (_, shader) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
        assert!(shader.uploaded_bytes >= volume, "first shader frame uploaded {} bytes", shader.uploaded_bytes);
    } else {
        assert!(first.uploaded_bytes >= volume);
    }
    let cam = Camera { position: DVec3::new(-2.0, 0.3, 0.1), ..f.camera };
    let (_, second) = gpu.render(&cam, &f.light, &f.config).unwrap();
    // The uniform block and the 12-byte statistics reset, nothing else.
    let block = std::mem::size_of::<pyvr_core::plan::Params>() as u64;
    assert!(second.uploaded_bytes <= block + 12, "camera-only frame uploaded {} bytes", second.uploaded_bytes);
}

/// Each model, order and option on the GPU against the f64 oracle, on a
/// scene with structure (off-centre blob, gradient lighting or shadows).
#[test]
fn every_model_and_option_matches_the_oracle() {
    use pyvr_core::model::{Model, Order};
    let dims = [14, 18, 12];
    let data = blob(dims);
    let ramp = ramp_lut();
    // Low values opaque (so a minimum shows); opacity rising fast (so an average of small values shows).
    let inverted: Vec<[f32; 4]> = ramp.iter().map(|e| [e[0], e[1], e[2], 1.0 - e[3]]).collect();
    let steep: Vec<[f32; 4]> = ramp.iter().map(|e| [e[0], e[1], e[2], (e[3] * 4.0).min(1.0)]).collect();
    let b = Bounds::new(DVec3::new(-0.6, -0.5, -0.4), DVec3::new(0.6, 0.7, 0.4)).unwrap();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, b).unwrap();
    let base = RenderConfig { step_size: 0.03, early_ray_termination: false, ..RenderConfig::default() };
    let lit = Light::default();
    let point = Light { position: DVec3::new(0.0, 0.3, 0.9), kind: LightKind::Point, ..Light::default() };
    let cases: Vec<(&str, RenderConfig, Light, &[[f32; 4]])> = vec![
        ("absorption", RenderConfig { model: Model::Absorption, ..base }, lit, &ramp),
        ("emission", RenderConfig { model: Model::Emission, ..base }, lit, &ramp),
        (
            "scattering directional hg",
            RenderConfig { model: Model::SingleScattering, anisotropy: 0.5, shadow_step_size: 0.05, ..base },
            lit,
            &ramp,
        ),
        ("scattering point", RenderConfig { model: Model::SingleScattering, ..base }, point, &ramp),
        ("mip", RenderConfig { model: Model::Mip, ..base }, lit, &ramp),
        ("minip", RenderConfig { model: Model::MinIp, ..base }, lit, &inverted),
        ("average", RenderConfig { model: Model::Average, ..base }, lit, &steep),
        ("back to front", RenderConfig { order: Order::BackToFront, ..base }, lit, &ramp),
        ("jitter", RenderConfig { jitter: true, jitter_seed: 5, ..base }, lit, &ramp),
        ("jitter back to front", RenderConfig { jitter: true, order: Order::BackToFront, ..base }, lit, &ramp),
        ("pre-integrated", RenderConfig { pre_integrated: true, step_size: 0.08, ..base }, lit, &ramp),
        (
            "pre-integrated btf",
            RenderConfig { pre_integrated: true, step_size: 0.08, order: Order::BackToFront, ..base },
            lit,
            &ramp,
        ),
    ];
    for (label, cfg, light, table) in cases {
        let mut f = base_frame(vol, table);
        f.config = cfg;
        f.light = light;
        compare_path(&f, label, false, Precision::Float32, 1.5);
    }
}

/// Skipping empty cells in both orders and with jitter: a TF that is zero
/// below 0.3 leaves most cells of the blob's volume empty.
#[test]
fn skipping_in_both_orders_matches_the_oracle() {
    use pyvr_core::model::{Model, Order};
    let dims = [40, 40, 40];
    let data = blob(dims);
    let lut: Vec<[f32; 4]> = (0..64)
        .map(|i| {
            let s = i as f32 / 63.0;
            [s, 1.0 - s, 0.5, if s < 0.3 { 0.0 } else { 0.8 * s }]
        })
        .collect();
    let vol = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
    let base = RenderConfig { step_size: 0.01, early_ray_termination: false, ..RenderConfig::default() };
    for (label, cfg) in [
        ("ftb", base),
        ("btf", RenderConfig { order: Order::BackToFront, ..base }),
        ("btf jitter", RenderConfig { order: Order::BackToFront, jitter: true, ..base }),
        ("ftb jitter", RenderConfig { jitter: true, jitter_seed: 9, ..base }),
        ("absorption", RenderConfig { model: Model::Absorption, ..base }),
    ] {
        let mut f = base_frame(vol, &lut);
        f.config = cfg;
        let mut gpu = Renderer::new(f.width, f.height).unwrap();
        gpu.set_volume(&f.volume).unwrap();
        gpu.set_lut(f.lut).unwrap();
        assert!(gpu.empty_fraction() > 0.5, "{label}: {}", gpu.empty_fraction());
        let (_, skipped) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
        gpu.skip_empty = false;
        let (_, full) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
        assert!(skipped.samples * 10 < full.samples * 7, "{label}: {} vs {} samples", skipped.samples, full.samples);
        compare_path(&f, label, false, Precision::Float32, 1.5);
    }
}

/// First-hit isosurface of a sphere's distance field: shading and the hit
/// distance against the oracle's 60-step bisection.
#[test]
fn isosurface_matches_the_oracle() {
    use pyvr_core::integrate::render_image;
    use pyvr_core::model::Model;
    let n = 64;
    let data: Vec<f32> = (0..n * n * n)
        .map(|idx| {
            let c = |a: usize| (a as f64 + 0.5) / n as f64 - 0.5;
            let (i, j, k) = (idx / (n * n), (idx / n) % n, idx % n);
            (0.5 - (c(i).powi(2) + c(j).powi(2) + c(k).powi(2)).sqrt()) as f32
        })
        .collect();
    let lut = ramp_lut();
    let vol = VolumeView::new([n, n, n], Voxels::F32(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.config = RenderConfig { model: Model::Isosurface, iso_value: 0.35, step_size: 0.05, ..RenderConfig::default() };
    compare_path(&f, "isosurface", false, Precision::Float32, 1.5);
    let mut gpu = Renderer::new(f.width, f.height).unwrap();
    gpu.set_volume(&f.volume).unwrap();
    gpu.set_lut(f.lut).unwrap();
    let (_, skipped) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
    assert!(gpu.empty_fraction() > 0.3, "cells below the iso value: {}", gpu.empty_fraction());
    let depth = gpu.depth().unwrap().expect("isosurface frame");
    gpu.skip_empty = false;
    let (_, full) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
    assert!(skipped.samples * 10 < full.samples * 6, "{} vs {}", skipped.samples, full.samples);
    assert_eq!(gpu.depth().unwrap().unwrap(), depth, "skipping changes no hit");
    let oracle = render_image(&f).unwrap();
    let mut hits = 0;
    for (g, o) in depth.iter().zip(oracle.depth.iter()) {
        if o.is_finite() {
            hits += 1;
            assert!(((*g as f64) - o).abs() < 1e-3 * f.config.step_size, "{g} vs {o}");
        } else {
            assert!(g.is_infinite());
        }
    }
    assert!(hits > 10, "{hits}");
}

#[test]
fn errors_say_whose_move_it_is() {
    use pyvr_core::error::Error;
    assert!(matches!(Renderer::new(0, 4), Err(Error::InvalidInput(_))));
    assert!(matches!(Renderer::new(1 << 30, 1 << 30), Err(Error::DeviceLimit(_))));
    let mut gpu = Renderer::new(4, 4).unwrap();
    let camera = Camera {
        position: DVec3::new(3.0, 0.0, 0.0),
        target: DVec3::ZERO,
        up: DVec3::Z,
        fov_y: 0.8,
        view_height: None,
    };
    let light =
        Light { position: DVec3::ONE, target: DVec3::ZERO, ambient: 0.2, diffuse: 0.8, kind: LightKind::Directional };
    let err = gpu.render(&camera, &light, &RenderConfig::default()).unwrap_err();
    assert!(matches!(err, Error::InvalidInput(ref m) if m.starts_with("no volume loaded")), "{err}");
    assert!(matches!(gpu.set_lut(&[]), Err(Error::InvalidInput(_))));
}

#[test]
fn a_stop_request_ends_a_long_frame_between_passes() {
    use pyvr_core::error::Error;
    let data = blob([16, 16, 16]);
    let lut = ramp_lut();
    let vol = VolumeView::new([16, 16, 16], Voxels::F32(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    // Rays of up to ~30,000 steps: two passes of at most 16384 or more.
    f.config =
        RenderConfig { step_size: 1e-4, max_steps: 100_000, early_ray_termination: false, ..RenderConfig::default() };
    let mut gpu = Renderer::new(f.width, f.height).unwrap();
    if gpu.device().gpu.is_none() {
        // Passes are the shader engine's, and no adapter opened.
        return;
    }
    // The shader's passes (the native march, which would take this lit
    // frame on a CPU adapter, asks every 10 ms while its workers run).
    gpu.native_march = false;
    gpu.set_volume(&f.volume).unwrap();
    gpu.set_lut(f.lut).unwrap();
    let mut asked = 0;
    let r = gpu.render_interruptible(&f.camera, &f.light, &f.config, &mut || {
        asked += 1;
        true
    });
    assert!(matches!(r, Err(Error::Interrupted)), "{r:?}");
    assert_eq!(asked, 1, "asked once, after the first pass finished");
    // The renderer goes on: the same frame, uninterrupted, has every pass.
    let (_, stats) = gpu.render(&f.camera, &f.light, &f.config).unwrap();
    assert!(stats.passes >= 2, "{}", stats.passes);
    let mut checks = 0;
    let (_, stats) = gpu
        .render_interruptible(&f.camera, &f.light, &f.config, &mut || {
            checks += 1;
            false
        })
        .unwrap();
    // (Pass sizes follow the device's measured speed, so count this frame's.)
    assert_eq!(checks, stats.passes - 1, "asked between every two passes");
}

#[test]
fn the_oracle_stops_when_asked() {
    use pyvr_core::error::Error;
    use pyvr_core::integrate::render_image_interruptible;
    let data = blob([16, 16, 16]);
    let lut = ramp_lut();
    let vol = VolumeView::new([16, 16, 16], Voxels::F32(&data), None, Bounds::default()).unwrap();
    let mut f = base_frame(vol, &lut);
    f.config =
        RenderConfig { step_size: 1e-5, max_steps: 1_000_000, early_ray_termination: false, ..RenderConfig::default() };
    f.width = 256;
    f.height = 256;
    let started = std::time::Instant::now();
    let r = render_image_interruptible(&f, &mut |_| true);
    assert!(matches!(r, Err(Error::Interrupted)), "stopped");
    // The whole frame takes minutes; stopping waits only for the rows in progress.
    assert!(started.elapsed().as_secs_f64() < 5.0, "{:?}", started.elapsed());
}
