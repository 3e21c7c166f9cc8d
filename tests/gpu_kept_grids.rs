//! The renderer keeps the occupancy grids of sources it switched away from
//! (plain and pre-integrated frames leap over grids of different ranges).
//! A new volume or value map with the table unchanged must drop them: a kept
//! grid of the old volume or map would leap over cells that now show.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::renderer::Renderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::transfer::ValueMap;
use pyvr_core::volume::{VolumeView, Voxels};

const N: usize = 40;

/// A ball of radius 6 voxels centred at `c`, 1 at its centre falling to 0.
fn ball(c: [f32; 3]) -> Vec<f32> {
    let mut v = Vec::with_capacity(N * N * N);
    for i in 0..N {
        for j in 0..N {
            for k in 0..N {
                let d = [i, j, k].iter().zip(c).map(|(&x, c)| (x as f32 - c).powi(2)).sum::<f32>().sqrt();
                v.push((1.0 - d / 6.0).max(0.0));
            }
        }
    }
    v
}

/// Opacity only between 0.4 and 0.6: a shell of the ball.
fn lut() -> Vec<[f32; 4]> {
    (0..64)
        .map(|m| {
            let x = m as f32 / 63.0;
            [x, 1.0 - x, 0.5, if (0.4..=0.6).contains(&x) { 0.8 } else { 0.0 }]
        })
        .collect()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn kept_grids_go_with_the_volume_and_the_value_map() {
    let bounds = Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let (a, b) = (ball([12.0, 20.0, 20.0]), ball([28.0, 20.0, 20.0]));
    fn view(d: &[f32], bounds: Bounds) -> VolumeView<'_> {
        VolumeView::new([N; 3], Voxels::F32(d), None, bounds).unwrap()
    }
    let cam = Camera {
        position: DVec3::new(0.4, 3.0, 0.3),
        target: DVec3::ZERO,
        up: DVec3::Z,
        fov_y: 0.8,
        view_height: None,
    };
    let light = Light::default();
    // Half a step is 0.8 voxels: pre-integrated segments leap over wider ranges.
    let plain = RenderConfig { step_size: 0.08, ..RenderConfig::default() };
    let pre = RenderConfig { pre_integrated: true, ..plain };
    let lifted = ValueMap { scale: 1.0, offset: 0.45 };
    let fresh = |d: &[f32], map: ValueMap, cfg: &RenderConfig| {
        let mut f = Renderer::new(32, 32).unwrap();
        f.set_volume(&view(d, bounds)).unwrap();
        f.set_lut(&lut()).unwrap();
        f.set_value_map(map).unwrap();
        f.render(&cam, &light, cfg).unwrap().0
    };
    let mut r = Renderer::new(32, 32).unwrap();
    r.set_volume(&view(&a, bounds)).unwrap();
    r.set_lut(&lut()).unwrap();
    for cfg in [plain, pre, plain] {
        r.render(&cam, &light, &cfg).unwrap();
    }
    // A new volume, the table kept: the balls sit apart, so the old
    // volume's grids would leave the new ball's cells empty.
    r.set_volume(&view(&b, bounds)).unwrap();
    for cfg in [pre, plain, pre] {
        let want = fresh(&b, ValueMap::IDENTITY, &cfg);
        assert!(want.iter().skip(3).step_by(4).fold(0.0f32, |m, &x| m.max(x)) > 0.3);
        let diff = max_diff(&r.render(&cam, &light, &cfg).unwrap().0, &want);
        assert!(diff < 1e-4, "after a new volume, pre-integrated {}: {diff}", cfg.pre_integrated);
    }
    // A new value map: values up to 0.15 show, the empty space around
    // the ball among them.
    r.set_value_map(lifted).unwrap();
    for cfg in [plain, pre, plain] {
        let want = fresh(&b, lifted, &cfg);
        let diff = max_diff(&r.render(&cam, &light, &cfg).unwrap().0, &want);
        assert!(diff < 1e-4, "after a new value map, pre-integrated {}: {diff}", cfg.pre_integrated);
    }
}
