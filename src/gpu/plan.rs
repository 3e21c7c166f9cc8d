//! How a frame's rays are split into dispatches: a pure function of the
//! config, the volume's box and the camera, tested without a GPU.
//!
//! Drivers cap loop trip counts (lavapipe stops loops after 65535
//! iterations, nested ones included) and GPU watchdogs stop long
//! dispatches, so long rays are marched over several passes, their state
//! kept per pixel in between.

use crate::error::Error;
use crate::config::RenderConfig;
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
}

/// The passes for rays from `camera` through `bounds` at `cfg`.
/// `shadow_rays`: single scattering with a light, where every step may march
/// a shadow ray across the box.
pub fn plan(cfg: &RenderConfig, bounds: &Bounds, camera: DVec3, shadow_rays: bool) -> Result<PassPlan, Error> {
    let max_steps = cfg.max_steps.clamp(0, u32::MAX as i64) as u64;
    let longest = bounds.max_chord_from(camera);
    let max_n = cfg.steps_for_length(longest).saturating_add(2).min(max_steps);
    let mut pass_steps = PASS_STEPS as u64;
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
        pass_steps = (PASS_ITERATIONS / (shadow as u64 + 1)).clamp(1, PASS_STEPS as u64);
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Bounds {
        Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap()
    }

    #[test]
    fn short_rays_take_one_pass() {
        let cfg = RenderConfig::default();
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false).unwrap();
        assert_eq!((p.passes, p.pass_steps, p.per_pixel_state), (1, PASS_STEPS, false));
        // The longest chord from (3, 0, 0) is under 2*sqrt(3): 347 steps of 0.01, plus 2.
        assert!(p.max_steps_needed <= 349 && p.max_steps_needed > 200);
    }

    #[test]
    fn long_rays_take_several_passes_with_state() {
        let cfg = RenderConfig { step_size: 1e-4, max_steps: 100_000, ..RenderConfig::default() };
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false).unwrap();
        assert_eq!(p.passes as u64, p.max_steps_needed.div_ceil(PASS_STEPS as u64));
        assert!(p.passes >= 2 && p.per_pixel_state);
        // max_steps bounds the work whatever the box.
        let capped = RenderConfig { max_steps: 10, ..cfg };
        assert_eq!(plan(&capped, &cube(), DVec3::new(3.0, 0.0, 0.0), false).unwrap().max_steps_needed, 10);
    }

    #[test]
    fn shadow_rays_shorten_passes_and_have_a_limit() {
        let cfg = RenderConfig { model: Model::SingleScattering, shadow_step_size: 0.01, ..RenderConfig::default() };
        let p = plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), true).unwrap();
        let shadow = (cube().extent().length() / 0.01).ceil() as u64 + 1;
        assert_eq!(p.pass_steps as u64, PASS_ITERATIONS / (shadow + 1));
        let tiny = RenderConfig { shadow_step_size: 1e-6, ..cfg };
        let err = plan(&tiny, &cube(), DVec3::new(3.0, 0.0, 0.0), true).unwrap_err();
        assert!(matches!(err, Error::InvalidInput(ref m) if m.contains("shadow_step_size must be at least")), "{err}");
    }

    #[test]
    fn isosurface_keeps_depth_state() {
        let cfg = RenderConfig { model: Model::Isosurface, ..RenderConfig::default() };
        assert!(plan(&cfg, &cube(), DVec3::new(3.0, 0.0, 0.0), false).unwrap().per_pixel_state);
    }
}
