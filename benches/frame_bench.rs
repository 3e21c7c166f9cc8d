//! Times frames of a synthetic scene from Rust alone (no Python), for
//! profiling the shader: `cargo bench --bench frame_bench -- [size] [n]`.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::volume::{VolumeView, Voxels};
use std::time::Instant;

fn main() {
    // `cargo bench` adds `--bench`; only the numbers are ours.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let size: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(256);
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(128);
    let mut data = Vec::with_capacity(n * n * n);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let c = |a: usize| 2.0 * (a as f64 + 0.5) / n as f64 - 1.0;
                let (x, y, z) = (c(i), c(j), c(k));
                let r1 = ((x) * (x) + (y - 0.3) * (y - 0.3) + z * z).sqrt();
                let r2 = ((x) * (x) + (y + 0.3) * (y + 0.3) + z * z).sqrt();
                data.push(((-(4.0 * r1).powi(2)).exp().max((-(4.0 * r2).powi(2)).exp())) as f32);
            }
        }
    }
    let bounds = Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let vol = VolumeView::new([n, n, n], Voxels::F32(&data), None, bounds).unwrap();
    let lut: Vec<[f32; 4]> = (0..256)
        .map(|i| {
            let s = i as f32 / 255.0;
            [s, 0.5, 1.0 - s, 0.1 * s]
        })
        .collect();
    let mut r = Renderer::new(size, size).unwrap();
    r.set_volume(&vol).unwrap();
    r.set_lut(&lut).unwrap();
    let cam = Camera {
        position: DVec3::new(1.8371, 1.8371, 1.5),
        target: DVec3::ZERO,
        up: DVec3::Z,
        fov_y: std::f64::consts::FRAC_PI_4,
        view_height: None,
    };
    for (label, light) in [("ambient", Light { diffuse: 0.0, ..Light::default() }), ("gradient", Light::default())] {
        let cfg = RenderConfig::default();
        r.render(&cam, &light, &cfg).unwrap();
        let mut best = f64::MAX;
        for _ in 0..3 {
            let t = Instant::now();
            r.render(&cam, &light, &cfg).unwrap();
            best = best.min(t.elapsed().as_secs_f64());
        }
        println!("{label}: {:.1} ms ({size}x{size}, {n}^3, balanced)", best * 1e3);
    }
}
