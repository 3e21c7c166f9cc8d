//! A volume cut into small bricks renders the image of the whole volume: the
//! bricks' windows tile every ray, states carry across bricks, and ghost
//! voxels give the same samples near faces.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::model::{Model, Order};
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::volume::{Precision, VolumeView, Voxels};

fn field(d: [usize; 3]) -> Vec<f32> {
    let mut v = Vec::with_capacity(d[0] * d[1] * d[2]);
    for i in 0..d[0] {
        for j in 0..d[1] {
            for k in 0..d[2] {
                let p = [i, j, k].map(|x| x as f32);
                let r = ((p[0] - 9.0).powi(2) + (p[1] - 7.0).powi(2) + (p[2] - 11.0).powi(2)).sqrt();
                v.push((1.0 - r / 12.0).max(0.0) + 0.1 * (p[0] * 0.7).sin() * (p[2] * 0.5).cos());
            }
        }
    }
    v
}

fn lut() -> Vec<[f32; 4]> {
    (0..64)
        .map(|m| {
            let x = m as f32 / 63.0;
            [x, 0.5 + 0.5 * (6.0 * x).sin(), 1.0 - x, if x > 0.3 { (x - 0.3) * 0.8 } else { 0.0 }]
        })
        .collect()
}

fn padded(data: &[f32], d: [usize; 3], r: [[usize; 2]; 3]) -> Vec<f32> {
    let mut out = Vec::new();
    for i in r[0][0]..r[0][1] {
        for j in r[1][0]..r[1][1] {
            out.extend_from_slice(&data[(i * d[1] + j) * d[2] + r[2][0]..(i * d[1] + j) * d[2] + r[2][1]]);
        }
    }
    out
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn bricked_frames_equal_the_whole_volume() {
    let d = [18, 14, 22];
    let data = field(d);
    let bounds = Bounds::new(DVec3::new(-1.0, -0.8, -1.2), DVec3::new(1.0, 0.8, 1.2)).unwrap();
    let whole = VolumeView::new(d, Voxels::F32(&data), None, bounds).unwrap();
    let table = lut();
    let light = Light::default();
    let mut one = Renderer::new(48, 40).unwrap();
    one.set_volume(&whole).unwrap();
    one.set_lut(&table).unwrap();
    let mut bricked = Renderer::new(48, 40).unwrap();
    bricked.set_lut(&table).unwrap();
    let cameras = [
        Camera {
            position: DVec3::new(2.5, 1.5, 1.0),
            target: DVec3::ZERO,
            up: DVec3::Z,
            fov_y: 0.8,
            view_height: None,
        },
        // Inside the volume, in a middle brick.
        Camera {
            position: DVec3::new(0.05, -0.1, 0.2),
            target: DVec3::new(-1.0, 0.3, 0.1),
            up: DVec3::Z,
            fov_y: 1.2,
            view_height: None,
        },
    ];
    let base = RenderConfig { step_size: 0.03, ..RenderConfig::default() };
    let configs = [
        ("emission_absorption", base),
        ("back_to_front", RenderConfig { order: Order::BackToFront, ..base }),
        ("jitter + early stop", RenderConfig { jitter: true, opacity_threshold: 0.6, ..base }),
        ("pre-integrated", RenderConfig { pre_integrated: true, ..base }),
        ("mip", RenderConfig { model: Model::Mip, ..base }),
        ("average", RenderConfig { model: Model::Average, ..base }),
        ("isosurface", RenderConfig { model: Model::Isosurface, iso_value: 0.6, ..base }),
        ("emission", RenderConfig { model: Model::Emission, ..base }),
    ];
    for (core, ghost_extra) in [([5, 6, 7], 0), ([18, 14, 22], 0), ([18, 14, 11], 0), ([7, 14, 4], 1)] {
        let ghost =
            pyvr_core::bricks::BrickGrid::ghost_for(0.03, bounds.extent() / DVec3::new(18.0, 14.0, 22.0)) + ghost_extra;
        bricked.set_brick_layout(d, bounds, core, ghost).unwrap();
        let grid = bricked.brick_grid().unwrap();
        for b in 0..grid.len() {
            let r = grid.padded_range(b);
            let v = padded(&data, d, r);
            let dims = r.map(|[lo, hi]| hi - lo);
            bricked
                .set_brick(b, &VolumeView::new(dims, Voxels::F32(&v), None, bounds).unwrap(), Precision::Float32)
                .unwrap();
        }
        for cam in &cameras {
            for (name, cfg) in &configs {
                let (want, _) = one.render(cam, &light, cfg).unwrap();
                let order = bricked.begin_bricks(cam, &light, cfg, false).unwrap();
                assert!(!order.is_empty(), "{name}: {} bricks to render", order.len());
                for b in order {
                    bricked.render_brick(b, &mut || false).unwrap();
                }
                let mut got = vec![0.0; want.len()];
                bricked.end_bricks(&mut got).unwrap();
                let diff = max_diff(&want, &got);
                if diff > 1e-3 {
                    let bad: Vec<_> = (0..want.len() / 4)
                        .filter(|&p| max_diff(&want[p * 4..p * 4 + 4], &got[p * 4..p * 4 + 4]) > 1e-3)
                        .collect();
                    eprintln!(
                        "{name}: {} bad pixels, e.g. {:?}: want {:?} got {:?}",
                        bad.len(),
                        bad[0],
                        &want[bad[0] * 4..bad[0] * 4 + 4],
                        &got[bad[0] * 4..bad[0] * 4 + 4]
                    );
                }
                // 1e-4 of full scale: f32 rounding of texture coordinates only.
                // f32 rounding of texture coordinates only: far below a level (1/255).
                assert!(diff < 3e-4, "{name}, bricks {core:?}, camera {:?}: max diff {diff}", cam.position);
                if cfg.model == Model::Isosurface {
                    let hit = bricked.depth().unwrap().unwrap().iter().filter(|x| x.is_finite()).count();
                    assert!(hit > 100, "{name}: {hit} hits");
                }
            }
        }
    }
}
