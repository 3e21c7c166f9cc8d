//! What a pixel shows, as a point on its ray, by each model's own
//! definition: where the accumulated opacity first reaches a threshold
//! (the integrating models), the sample that sets the pixel (maximum and
//! minimum projections; the average's largest sample), or the surface hit
//! (isosurface). The marching rules are the integrator's.

use super::optics::extinction;
use super::projections::isosurface;
use super::{chord, segments_needed, value, Frame, Ray};
use crate::model::Model;
use crate::transfer::eval_lut;
use glam::DVec3;

/// The ray parameter of what the ray `origin + t dir` (unit `dir`) shows,
/// or None where it shows nothing (it misses the box, every sample is
/// empty, or its opacity never reaches `threshold`, which is in (0, 1]).
/// An opaque scene at ray parameter `limit` stops the ray there (nothing
/// behind it is picked; infinity: none).
pub fn pick(frame: &Frame, origin: DVec3, dir: DVec3, threshold: f64, limit: f64) -> Option<f64> {
    let (t0, t1) = chord(frame, origin, dir)?;
    let t1 = t1.min(limit);
    if t0 > t1 {
        return None;
    }
    let cfg = &frame.config;
    let needed = segments_needed(t1 - t0, cfg.step_size, 0.0);
    let n = needed.min(cfg.max_steps.max(0) as u64);
    let ray = Ray { origin, dir, t0, t1, shift: 0.0, n, needed };
    match cfg.model {
        m if m.integrates() => opacity_crossing(frame, &ray, threshold),
        m if m.projects() => extremum(frame, &ray),
        _ => {
            let hit = isosurface(frame, &ray).depth;
            hit.is_finite().then_some(hit)
        }
    }
}

/// Where `1 - exp(-Σ x)` first reaches `threshold`: within the segment
/// that crosses it, the point where its own share of optical depth does
/// (a segment's extinction is uniform by the midpoint rule, so the
/// transmittance falls exponentially along it).
fn opacity_crossing(frame: &Frame, ray: &Ray, threshold: f64) -> Option<f64> {
    let cfg = &frame.config;
    // Optical depth at which 1 - exp(-tau) = threshold.
    let goal = -(1.0 - threshold).ln();
    let mut tau = 0.0;
    for i in 0..ray.n {
        let (lo, len) = ray.span(cfg.step_size, i);
        if len <= 0.0 {
            continue;
        }
        let v = value(frame, ray.at(lo + 0.5 * len));
        if v.is_nan() {
            continue;
        }
        let x = extinction(eval_lut(frame.lut, v)[3], cfg.opacity_correction) * (len / cfg.reference_step_size);
        if !(x > 0.0) {
            continue;
        }
        if tau + x >= goal {
            let within = ((goal - tau) / x).clamp(0.0, 1.0);
            return Some(ray.t0 + lo + within * len);
        }
        tau += x;
    }
    None
}

/// The midpoint of the segment whose sample sets a projection's pixel:
/// the first largest (MIP, average) or smallest (MinIP) value.
fn extremum(frame: &Frame, ray: &Ray) -> Option<f64> {
    let cfg = &frame.config;
    let lowest = cfg.model == Model::MinIp;
    let mut best: Option<(f64, f64)> = None;
    for i in 0..ray.n {
        let (lo, len) = ray.span(cfg.step_size, i);
        if len <= 0.0 {
            continue;
        }
        let at = lo + 0.5 * len;
        let v = value(frame, ray.at(at));
        if v.is_nan() {
            continue;
        }
        let better = match best {
            None => true,
            Some((b, _)) => (lowest && v < b) || (!lowest && v > b),
        };
        if better {
            best = Some((v, at));
        }
    }
    best.map(|(_, at)| ray.t0 + at)
}
