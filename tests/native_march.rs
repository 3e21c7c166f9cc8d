//! The native CPU march (src/cpu) renders the shader's frame: where the
//! adapter is a CPU with AVX2, FMA and F16C, each storage it reads and each kind
//! of segment it takes, rendered both ways, agree within 0.25 level with
//! the same samples (tests/test_native_march.py covers the options and
//! scenes; this keeps `cargo test` on the native path too). Elsewhere the
//! renderer must never take it.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::model::Model;
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::volume::{Precision, VolumeView, Voxels};

/// A ball whose values fall from 1 at its centre, and its gradient.
fn ball(n: usize) -> (Vec<f32>, Vec<f32>) {
    let c = (n as f32 - 1.0) / 2.0;
    let mut values = Vec::with_capacity(n * n * n);
    let mut normals = Vec::with_capacity(3 * n * n * n);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = [i, j, k].map(|x| (x as f32 - c) / c);
                let r2 = p.iter().map(|x| x * x).sum::<f32>();
                values.push((-3.0 * r2).exp());
                normals.extend(p.map(|x| -x));
            }
        }
    }
    (values, normals)
}

#[test]
fn the_native_march_renders_the_shaders_frame() {
    let n = 28;
    let (values, normals) = ball(n);
    let bounds = Bounds::new(DVec3::new(-1.0, -0.8, -0.9), DVec3::new(1.0, 0.8, 0.9)).unwrap();
    let vol = VolumeView::new([n; 3], Voxels::F32(&values), Some(&normals), bounds).unwrap();
    let lut: Vec<[f32; 4]> = (0..128)
        .map(|m| {
            let x = m as f32 / 127.0;
            [x, 1.0 - x, 0.5, if x > 0.2 { 0.6 * (x - 0.2) } else { 0.0 }]
        })
        .collect();
    // Opaque at every value for the projections: the minimum along a ray
    // through the box is near 0.
    let opaque: Vec<[f32; 4]> = lut.iter().map(|&[r, g, b, a]| [r, g, b, 0.3 + a]).collect();
    let camera = Camera {
        position: DVec3::new(2.2, 1.4, 1.1),
        target: DVec3::ZERO,
        up: DVec3::Z,
        fov_y: 0.8,
        view_height: None,
    };
    let light = Light::default();
    let mut r = Renderer::new(40, 36).unwrap();
    if r.device().gpu.is_none() {
        // The comparison is with the shader engine, and no adapter opened.
        return;
    }
    let cpu_adapter = r.device().caps.native;
    let plain = RenderConfig::default();
    let configs = [
        plain,
        RenderConfig { pre_integrated: true, ..plain },
        RenderConfig { pre_integrated: true, refine: 8, step_size: 0.03, ..plain },
        RenderConfig { model: Model::Mip, ..plain },
        RenderConfig { model: Model::MinIp, ..plain },
        RenderConfig { model: Model::Average, ..plain },
        RenderConfig { model: Model::Isosurface, iso_value: 0.4, ..plain },
        // Ratio tracking's points, without the roulette early termination
        // becomes there (its number hashes a point's offset, which the two
        // engines' logarithms may round apart).
        RenderConfig { unbiased: true, early_ray_termination: false, ..plain },
    ];
    // The values as 8-bit codes at precision float32: their normals stored apart.
    let codes: Vec<u8> = values.iter().map(|v| (v * 255.0).round() as u8).collect();
    let coded = VolumeView::new([n; 3], Voxels::U8(&codes), Some(&normals), bounds).unwrap();
    let mut native_frames = 0;
    let storages = [
        (&vol, Precision::Float32),
        (&vol, Precision::Fixed16),
        (&vol, Precision::Float16),
        (&coded, Precision::Float32),
    ];
    for (vol, precision) in storages {
        r.set_volume_with_precision(vol, precision).unwrap();
        let precision = format!("{precision:?}{}", if std::ptr::eq(vol, &coded) { ", 8-bit codes" } else { "" });
        for cfg in &configs {
            r.set_lut(if cfg.model == Model::EmissionAbsorption { &lut } else { &opaque }).unwrap();
            r.native_march = false;
            let (shader, s) = r.render(&camera, &light, cfg).unwrap();
            assert!(!s.native);
            r.native_march = true;
            let (native, t) = r.render(&camera, &light, cfg).unwrap();
            if !t.native {
                assert!(
                    !(cpu_adapter && pyvr_core::cpu::available()),
                    "a CPU adapter with AVX2 must take the native march"
                );
                continue;
            }
            native_frames += 1;
            assert!(shader.iter().cloned().fold(0.0, f32::max) > 0.05, "the scene must show something");
            let diff = native.iter().zip(&shader).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max) * 255.0;
            assert!(diff < 0.25, "{precision}, {cfg:?}: {diff} levels");
            // Maximum and minimum projections leap cells whose bound lies
            // past their value so far: where the sampler filters 16-bit
            // texels its values round otherwise, which moves the leaps of
            // cells whose bound lies within that rounding.
            let within = if matches!(cfg.model, Model::Mip | Model::MinIp) { 1e-3 } else { 1e-4 };
            assert!(
                s.samples.abs_diff(t.samples) as f64 <= within * s.samples as f64 + 2.0,
                "{} vs {}",
                s.samples,
                t.samples
            );
        }
    }
    if cpu_adapter && pyvr_core::cpu::available() {
        assert_eq!(native_frames, 32);
    }
}
