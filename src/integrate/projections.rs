//! Projections of the sampled values (MIP, MinIP, average) and the isosurface.

use super::lighting::intensity;
use super::{value, Frame, Ray, RayResult};
use crate::model::Model;
use crate::scene::Shading;
use crate::transfer::eval_lut;

/// The TF's premultiplied RGBA of a projected value.
fn projected(frame: &Frame, v: f64) -> [f64; 4] {
    let c = eval_lut(frame.lut, v);
    [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]]
}

pub(super) fn project(frame: &Frame, ray: &Ray) -> RayResult {
    let cfg = &frame.config;
    let (mut best, mut sum, mut len) = (f64::NAN, 0.0, 0.0);
    for i in 0..ray.n {
        let (lo, seg) = ray.span(cfg.step_size, i);
        if seg <= 0.0 {
            continue;
        }
        let v = value(frame, ray.at(lo + 0.5 * seg));
        if v.is_nan() {
            continue;
        }
        match cfg.model {
            Model::Mip => best = if best >= v { best } else { v },
            Model::MinIp => best = if best <= v { best } else { v },
            _ => {
                sum += v * seg;
                len += seg;
            }
        }
    }
    if cfg.model == Model::Average && len > 0.0 {
        best = sum / len;
    }
    let rgba = if best.is_nan() { [0.0; 4] } else { projected(frame, best) };
    RayResult { rgba, truncated_needed: ray.truncated(), depth: f64::INFINITY }
}

/// Below the iso value: NaN counts as outside.
fn below(v: f64, iso: f64) -> bool {
    !(v >= iso)
}

pub(super) fn isosurface(frame: &Frame, ray: &Ray) -> RayResult {
    let cfg = &frame.config;
    let iso = cfg.iso_value;
    let miss = RayResult { truncated_needed: ray.truncated(), ..RayResult::default() };
    // Sample points: the entry, every segment's midpoint, the exit.
    let mut prev = 0.0;
    let mut hit = None;
    if !below(value(frame, ray.at(0.0)), iso) {
        hit = Some(0.0);
    }
    let mut i = 0;
    while hit.is_none() && i <= ray.n {
        let at = if i < ray.n {
            let (lo, seg) = ray.span(cfg.step_size, i);
            lo + 0.5 * seg
        } else if ray.n == ray.needed {
            ray.t1 - ray.t0
        } else {
            break;
        };
        i += 1;
        if !below(value(frame, ray.at(at)), iso) {
            // Bisection to the crossing of the interpolated field.
            let (mut lo, mut hi) = (prev, at);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if below(value(frame, ray.at(mid)), iso) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hit = Some(0.5 * (lo + hi));
        }
        prev = at;
    }
    let Some(off) = hit else {
        return miss;
    };
    let p = ray.at(off);
    let shading = if frame.light.diffuse == 0.0 {
        Shading::AmbientOnly
    } else if frame.volume.normals.is_some() {
        Shading::Normals
    } else {
        Shading::Gradient
    };
    let light = intensity(frame, shading, p, ray.dir);
    let c = eval_lut(frame.lut, iso);
    RayResult { rgba: [c[0] * light, c[1] * light, c[2] * light, 1.0], truncated_needed: 0, depth: ray.t0 + off }
}
