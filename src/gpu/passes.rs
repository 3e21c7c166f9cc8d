//! How a frame's rays are split into dispatches: a pure function of the
//! config, the volume's box and the camera, tested without a GPU.
//!
//! Drivers cap loop trip counts (lavapipe stops loops after 65535
//! iterations, nested ones included) and GPU watchdogs stop long
//! dispatches, so long rays are marched over several passes, their state
//! kept per pixel in between.

use crate::config::RenderConfig;
use crate::error::Error;
use crate::model::Model;
use crate::scene::Bounds;
use glam::DVec3;

/// Steps one dispatch marches at most. Below lavapipe's 65535-iteration loop
/// cap, and short enough that a pass stays far from GPU watchdog timeouts.
pub const PASS_STEPS: u32 = 16384;
/// Loop iterations one invocation may run in one dispatch, shadow rays'
/// included.
pub const PASS_ITERATIONS: u64 = 60_000;
/// Longest shadow ray, in steps, single scattering accepts.
pub const MAX_SHADOW_STEPS: u64 = 30_000;
/// Fewest steps a pass split for time marches.
pub const MIN_PASS_STEPS: u64 = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassPlan {
    /// Dispatches the frame takes.
    pub passes: u32,
    /// Steps each pass marches.
    pub pass_steps: u32,
    /// An upper bound on any ray's step count (after max_steps).
    pub max_steps_needed: u64,
    /// Rays keep 16 bytes of state per pixel (between passes, or the
    /// isosurface's depth).
    pub per_pixel_state: bool,
    /// Samples the frame would take if every ray ran `max_steps_needed`
    /// steps (shadow rays included): the unit passes are sized in.
    pub planned_samples: u64,
}

/// The passes for `pixels` rays from `camera` through `bounds` at `cfg`.
/// `shadow_rays`: single scattering with a light, where every step may march
/// a shadow ray across the box. `points_per_step`: the mean number of
/// samples a step takes (1, or an unbiased frame's Poisson points at its
/// largest rate). A frame of more than twice `pass_samples` samples is
/// split into passes of about `pass_samples` each, so that the
/// caller regains control (to stop on Ctrl-C) every pass; shorter frames
/// keep one pass. Samples here are planned ones (`planned_samples`), an
/// upper bound on those the rays take.
pub fn plan(
    cfg: &RenderConfig,
    bounds: &Bounds,
    camera: DVec3,
    shadow_rays: bool,
    points_per_step: f64,
    pixels: u64,
    pass_samples: u64,
) -> Result<PassPlan, Error> {
    let max_steps = cfg.max_steps.clamp(0, u32::MAX as i64) as u64;
    let longest = bounds.max_chord_from(camera);
    let max_n = cfg.steps_for_length(longest).saturating_add(2).min(max_steps);
    let mut pass_steps = PASS_STEPS as u64;
    // Samples one step of one ray takes, its shadow ray's included.
    let mut samples_per_step = 1u64;
    if shadow_rays {
        let diagonal = bounds.extent().length();
        let shadow = (diagonal / cfg.shadow_step()).ceil() + 1.0;
        if !(shadow <= MAX_SHADOW_STEPS as f64) {
            return Err(Error::InvalidInput(format!(
                "shadow rays of up to {shadow} steps exceed the limit of {MAX_SHADOW_STEPS}: \
                 shadow_step_size must be at least {:.3e} for these bounds",
                diagonal / MAX_SHADOW_STEPS as f64
            )));
        }
        samples_per_step = shadow as u64 + 1;
        pass_steps = (PASS_ITERATIONS / samples_per_step).clamp(1, PASS_STEPS as u64);
    } else if cfg.pre_integrates() && cfg.refine > 0 {
        // A refined segment is marched once more per sample it takes: the
        // loop's trip count is bounded as if every segment were (the
        // time a pass takes is sized by samples, and few segments are).
        pass_steps = (PASS_ITERATIONS / (cfg.refine as u64 + 1)).clamp(1, PASS_STEPS as u64);
    } else if points_per_step > 1.0 {
        // Loop iterations: the points (a Poisson count, 1.5x its mean covers
        // its spread over a pass) and one more per step that moves on.
        samples_per_step = (1.5 * points_per_step).ceil().min(1e6) as u64 + 1;
        pass_steps = (PASS_ITERATIONS / samples_per_step).clamp(1, PASS_STEPS as u64);
    }
    let per_step = pixels.max(1).saturating_mul(samples_per_step);
    if per_step.saturating_mul(max_n) > pass_samples.saturating_mul(2) {
        pass_steps = (pass_samples / per_step).clamp(MIN_PASS_STEPS.min(pass_steps), pass_steps);
    }
    let passes = max_n.div_ceil(pass_steps).max(1);
    if passes > u32::MAX as u64 {
        return Err(Error::InvalidInput(format!("rays of {max_n} steps need too many passes; use a larger step_size")));
    }
    Ok(PassPlan {
        passes: passes as u32,
        pass_steps: pass_steps as u32,
        max_steps_needed: max_n,
        per_pixel_state: passes > 1 || cfg.model == Model::Isosurface,
        planned_samples: per_step.saturating_mul(max_n),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ANY: u64 = u64::MAX / 4;

    fn cube() -> Bounds {
        Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap()
    }

    #[test]
    fn short_rays_take_one_pass() {
        let cfg = RenderConfig::default();
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 1.0, 1, ANY).unwrap();
        assert_eq!((p.passes, p.pass_steps, p.per_pixel_state), (1, PASS_STEPS, false));
        // The longest chord from (3, 0, 0) is under 2*sqrt(3): 347 steps of 0.01, plus 2.
        assert!(p.max_steps_needed <= 349 && p.max_steps_needed > 200);
    }

    #[test]
    fn long_rays_take_several_passes_with_state() {
        let cfg = RenderConfig { step_size: 1e-4, max_steps: 100_000, ..RenderConfig::default() };
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 1.0, 1, ANY).unwrap();
        assert_eq!(p.passes as u64, p.max_steps_needed.div_ceil(PASS_STEPS as u64));
        assert!(p.passes >= 2 && p.per_pixel_state);
        // max_steps bounds the work whatever the box.
        let capped = RenderConfig { max_steps: 10, ..cfg };
        assert_eq!(plan(&capped, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 1.0, 1, ANY).unwrap().max_steps_needed, 10);
    }

    #[test]
    fn shadow_rays_shorten_passes_and_have_a_limit() {
        let cfg = RenderConfig { model: Model::SingleScattering, shadow_step_size: 0.01, ..RenderConfig::default() };
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), true, 1.0, 1, ANY).unwrap();
        let shadow = (cube().extent().length() / 0.01).ceil() as u64 + 1;
        assert_eq!(p.pass_steps as u64, PASS_ITERATIONS / (shadow + 1));
        let tiny = RenderConfig { shadow_step_size: 1e-6, ..cfg };
        let err = plan(&tiny, &cube(), DVec3::new(3.0, 0.0, 0.0), true, 1.0, 1, ANY).unwrap_err();
        assert!(matches!(err, Error::InvalidInput(ref m) if m.contains("shadow_step_size must be at least")), "{err}");
    }

    #[test]
    fn dense_poisson_points_shorten_passes() {
        let cfg = RenderConfig { step_size: 1e-4, max_steps: 100_000, unbiased: true, ..RenderConfig::default() };
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 16.0, 1, ANY).unwrap();
        // 24 points and one move per step: the loop stays under lavapipe's cap.
        assert_eq!(p.pass_steps as u64, PASS_ITERATIONS / 25);
        assert!(p.pass_steps as u64 * 25 < 65_535);
        let sparse = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 1.0, 1, ANY).unwrap();
        assert_eq!(sparse.pass_steps, PASS_STEPS);
    }

    #[test]
    fn long_frames_are_split_for_time_and_short_ones_are_not() {
        let cfg = RenderConfig { step_size: 1e-3, max_steps: 100_000, ..RenderConfig::default() };
        let far = DVec3::new(3.0, 0.0, 0.0);
        // 2^16 pixels, about 3.5k steps each: 2.3e8 samples against a budget of 2^22.
        let p = plan(&cfg, &cube(), far, false, 1.0, 1 << 16, 1 << 22).unwrap();
        assert_eq!(p.pass_steps, 64);
        assert_eq!(p.passes as u64, p.max_steps_needed.div_ceil(64));
        // The same frame within twice the budget keeps one pass.
        let one = plan(&cfg, &cube(), far, false, 1.0, 1 << 16, 1 << 30).unwrap();
        assert_eq!(one.passes, 1);
        // Passes never go below MIN_PASS_STEPS, however many pixels.
        let huge = plan(&cfg, &cube(), far, false, 1.0, 1 << 40, 1 << 22).unwrap();
        assert_eq!(huge.pass_steps as u64, MIN_PASS_STEPS);
    }

    #[test]
    fn isosurface_keeps_depth_state() {
        let cfg = RenderConfig { model: Model::Isosurface, ..RenderConfig::default() };
        assert!(plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false, 1.0, 1, ANY).unwrap().per_pixel_state);
    }
}
