//! Light at a point: shadow rays and surface shading.

use super::optics::{extinction, SHADOW_TAU_MAX};
use super::{chord, segments_needed, value, Frame};
use crate::model::{phase_4pi, Model};
use crate::scene::Shading;
use crate::transfer::eval_lut;
use glam::DVec3;

/// Light that reaches `p` from the light source through the volume:
/// `exp(-∫ σ ds / ref)` along the shadow ray, midpoint rule with the
/// shadow step, up to where it leaves the (cropped, clipped) box, or at the
/// point light if nearer.
pub fn light_transmittance(frame: &Frame, p: DVec3) -> f64 {
    let light = &frame.light;
    let Some(travel) = light.direction_at(p) else {
        return 1.0;
    };
    let to_light = -travel;
    let mut reach = f64::INFINITY;
    if light.kind == crate::scene::LightKind::Point {
        reach = (light.position - p).length();
    }
    let Some((_, exit)) = chord(frame, p, to_light) else {
        return 1.0;
    };
    let len = exit.min(reach);
    let cfg = &frame.config;
    let h = cfg.shadow_step();
    let n = segments_needed(len, h, 0.0);
    let mut tau = 0.0;
    for j in 0..n {
        let s0 = j as f64 * h;
        let seg = h.min(len - s0);
        if seg <= 0.0 {
            break;
        }
        let v = value(frame, p + to_light * (s0 + 0.5 * seg));
        if v.is_nan() {
            continue;
        }
        tau += extinction(eval_lut(frame.lut, v)[3], cfg.opacity_correction) * (seg / cfg.reference_step_size);
        if tau > SHADOW_TAU_MAX {
            break;
        }
    }
    (-tau).exp()
}

/// What a model needs to light a sample at `p`.
pub(super) fn intensity(frame: &Frame, shading: Shading, p: DVec3, dir: DVec3) -> f64 {
    let light = &frame.light;
    match frame.config.model {
        Model::SingleScattering => {
            if light.diffuse == 0.0 {
                return light.ambient;
            }
            match light.direction_at(p) {
                Some(l) => {
                    let phase = phase_4pi(frame.config.anisotropy, l.dot(-dir));
                    light.ambient + light.diffuse * phase * light_transmittance(frame, p)
                }
                None => light.ambient,
            }
        }
        _ => {
            let q = frame.volume.bounds.to_unit(p);
            let normal = match shading {
                Shading::AmbientOnly => None,
                Shading::Normals => frame.volume.normal(q),
                Shading::Gradient => frame.volume.gradient_normal(q),
            };
            light.intensity(normal, p)
        }
    }
}
