//! The native CPU march against the shader on the same adapter: the
//! benchmark scene's balanced frame (a 256^3 double sphere with unit
//! normals, 512x512, linear(0, 0.1) opacity, ambient 0.2 + diffuse 0.8 from
//! a directional light, empty-space skipping on), its volume stored as
//! float32 and as 16-bit fixed point, rendered by the shader (lavapipe on a
//! machine without a GPU) and by the native march (src/cpu) in turn. Both
//! take the same samples, and the native image must match the shader's
//! within 0.25 level, so the timings compare the same work. Prints ms,
//! samples and ns per sample.
//!
//! Run: `cargo bench --bench native_march -- [size] [n]` (default 512 256);
//! `benches/native_march.py` runs it and writes the docs table.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::volume::{Precision, VolumeView, Voxels};
use std::time::Instant;

/// Median of 3 timed runs after a warm-up.
fn timed<T>(mut run: impl FnMut() -> T) -> (T, f64) {
    let mut out = run();
    let mut ms = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        out = run();
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    (out, ms[1])
}

fn main() {
    // `cargo bench` adds `--bench`; only the numbers are ours.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let size: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(512);
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(256);
    // pyvr's double_sphere and its normals (central differences).
    let c = |a: usize| -1.0 + 2.0 * a as f64 / (n - 1) as f64;
    let value = |i: usize, j: usize, k: usize| {
        let (x, y, z) = (c(i), c(j), c(k));
        let r1 = ((x - 0.3).powi(2) + y * y + z * z).sqrt();
        let r2 = ((x + 0.3).powi(2) + y * y + z * z).sqrt();
        (-(4.0 * r1).powi(2)).exp().max((-(4.0 * r2).powi(2)).exp()) as f32
    };
    let mut data = Vec::with_capacity(n * n * n);
    let mut normals = Vec::with_capacity(3 * n * n * n);
    let at = |i: usize, j: usize, k: usize, a: usize, s: isize| {
        let mut q = [i as isize, j as isize, k as isize];
        q[a] = (q[a] + s).clamp(0, n as isize - 1);
        value(q[0] as usize, q[1] as usize, q[2] as usize)
    };
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                data.push(value(i, j, k));
                normals.extend((0..3).map(|a| at(i, j, k, a, 1) - at(i, j, k, a, -1)));
            }
        }
    }
    let bounds = Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).expect("a valid box");
    let vol = VolumeView::new([n, n, n], Voxels::F32(&data), Some(&normals), bounds).expect("a valid volume");
    let lut: Vec<[f32; 4]> = (0..256)
        .map(|i| {
            let s = i as f32 / 255.0;
            [s, 0.5 * s, 1.0 - s, 0.1 * s]
        })
        .collect();
    let camera = Camera {
        position: DVec3::new(1.8371, 1.8371, 1.5),
        target: DVec3::ZERO,
        up: DVec3::Z,
        fov_y: std::f64::consts::FRAC_PI_4,
        view_height: None,
    };
    let light = Light::default();
    let cfg = RenderConfig::default();

    let mut gpu = Renderer::new(size, size).expect("a device");
    gpu.set_lut(&lut).expect("table");
    let device = gpu.device().describe();
    println!(
        "{size}x{size}, {n}^3 double sphere with normals, balanced, {} threads; {device}",
        std::thread::available_parallelism().map_or(1, |t| t.get())
    );
    println!(
        "{:9} {:16} {:>9} {:>10} {:>10} {:>22} {:>22}",
        "storage", "engine", "ms", "samples M", "ns/sample", "shader's ns over this", "max diff vs shader"
    );
    let mut rows = Vec::new();
    for (name, precision) in [("float32", Precision::Float32), ("fixed16", Precision::Fixed16)] {
        gpu.set_volume_with_precision(&vol, precision).expect("upload");
        gpu.native_march = false;
        let ((shader_img, shader), shader_ms) = timed(|| gpu.render(&camera, &light, &cfg).expect("a frame"));
        assert!(!shader.native);
        gpu.native_march = true;
        let ((img, stats), ms) = timed(|| gpu.render(&camera, &light, &cfg).expect("a frame"));
        let shader_ns = shader_ms * 1e6 / shader.samples as f64;
        let mut row = |engine: &str, ms: f64, samples: u64, diff: String| {
            let ns = ms * 1e6 / samples as f64;
            println!(
                "{name:9} {engine:16} {ms:9.1} {:10.2} {ns:10.2} {:>21.2}x {diff:>22}",
                samples as f64 / 1e6,
                shader_ns / ns
            );
            rows.push(format!(
                "[\"{name}\", \"{engine}\", {ms:.1}, {:.2}, {ns:.2}, {:.2}, {diff}]",
                samples as f64 / 1e6,
                shader_ns / ns
            ));
        };
        row("shader", shader_ms, shader.samples, "\"-\"".into());
        if !stats.native {
            println!("the native march renders only where the adapter is a CPU");
            continue;
        }
        let diff = img.iter().zip(&shader_img).map(|(a, b)| (a - b).abs() * 255.0).fold(0f32, f32::max);
        assert!(diff <= 0.25, "{name}: the native frame differs from the shader's by {diff} levels: not the same rule");
        row(&format!("native ({})", pyvr_core::cpu::lanes().name()), ms, stats.samples, format!("{diff:.4}"));
    }
    if let Some(path) = std::env::var_os("NATIVE_MARCH_JSON") {
        let device = device.replace('\\', "/").replace('"', "'");
        let json = format!("{{\"device\": \"{device}\", \"rows\": [{}]}}\n", rows.join(", "));
        std::fs::write(&path, json).expect("writing the rows");
    }
}
