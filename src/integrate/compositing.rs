//! Beer–Lambert models: optical depth summed along the ray, colour
//! composited front to back (or back to front), per segment or adaptively.

use super::lighting::intensity;
use super::optics::{extinction, one_minus_exp_neg};
use super::{value, Frame, Ray, RayResult};
use crate::model::{Model, Order};
use crate::preintegrate;
use crate::scene::Shading;
use crate::transfer::eval_lut;

/// One piece `[lo, lo + len]` of a ray (offsets from `t0`) by the midpoint
/// rule: its optical depth and the premultiplied colour it adds before
/// attenuation by what lies in front; `None` when empty (NaN, zero opacity).
/// `v` is the value at the midpoint, when already known.
fn midpoint_piece(
    frame: &Frame,
    shading: Shading,
    ray: &Ray,
    lo: f64,
    len: f64,
    v: Option<f64>,
) -> Option<(f64, [f64; 3])> {
    let cfg = &frame.config;
    let p = ray.at(lo + 0.5 * len);
    let v = v.unwrap_or_else(|| value(frame, p));
    if v.is_nan() {
        return None;
    }
    let rgba = eval_lut(frame.lut, v);
    let x = extinction(rgba[3], cfg.opacity_correction) * (len / cfg.reference_step_size);
    if !(x > 0.0) {
        return None;
    }
    if cfg.model == Model::Absorption {
        return Some((x, [0.0; 3]));
    }
    let w = match cfg.model {
        Model::Emission => x,
        _ => one_minus_exp_neg(x),
    };
    let light = intensity(frame, shading, p, ray.dir);
    Some((x, [w * rgba[0] * light, w * rgba[1] * light, w * rgba[2] * light]))
}

/// How much the transfer function varies over the values in `[a, b]`: the
/// range of extinction and of emitted colour (extinction times colour) over
/// the table entries there (values between entries are interpolated, so
/// they lie within that range).
fn tf_variation(frame: &Frame, a: f64, b: f64) -> f64 {
    let lut = frame.lut;
    let m = lut.len();
    if m < 2 {
        return 0.0;
    }
    let scale = (m - 1) as f64;
    let i0 = (a.clamp(0.0, 1.0) * scale).floor() as usize;
    let i1 = ((b.clamp(0.0, 1.0) * scale).ceil() as usize).min(m - 1);
    let form = frame.config.opacity_correction;
    let (mut lo, mut hi) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
    for e in &lut[i0..=i1] {
        let sigma = extinction(e[3] as f64, form).min(1e30);
        let q = [sigma, sigma * e[0] as f64, sigma * e[1] as f64, sigma * e[2] as f64];
        for k in 0..4 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    (0..4).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)
}

/// Most pieces one segment is cut into. Each halving is down to 2^-24 of a
/// step; this bounds the work a tiny tolerance can ask for (a smooth TF at
/// tolerance 1e-12 would otherwise cut every segment 2^24 times).
pub const MAX_PIECES: usize = 1 << 12;

/// Appends the pieces of `[lo, lo + len]` front to back, halving them level
/// by level where the TF varies too much across the values they span (see
/// `Frame`), until none does, the pieces are 2^-24 of the segment, or there
/// are MAX_PIECES of them.
#[allow(clippy::too_many_arguments)]
fn split(
    frame: &Frame,
    shading: Shading,
    ray: &Ray,
    lo: f64,
    len: f64,
    vf: f64,
    vb: f64,
    out: &mut Vec<(f64, [f64; 3])>,
) {
    // (start, length, front value, back value, midpoint value, final)
    let mut pieces = vec![(lo, len, vf, vb, value(frame, ray.at(lo + 0.5 * len)), false)];
    for depth in 0..=24 {
        let mut next = Vec::with_capacity(pieces.len() * 2);
        let mut count = pieces.len();
        let mut refined = false;
        for &(lo, len, vf, vb, vm, done) in &pieces {
            let vals = [vf, vm, vb];
            let finite = vals.iter().all(|v| !v.is_nan());
            let (a, b) = (
                vals.iter().cloned().fold(f64::INFINITY, f64::min),
                vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            );
            let coarse = done
                || !finite
                || depth >= 24
                || count >= MAX_PIECES
                || tf_variation(frame, a, b) * (len / frame.config.reference_step_size) <= frame.adaptive_tolerance;
            if coarse {
                next.push((lo, len, vf, vb, vm, true));
                continue;
            }
            let half = 0.5 * len;
            next.push((lo, half, vf, vm, value(frame, ray.at(lo + 0.25 * len)), false));
            next.push((lo + half, half, vm, vb, value(frame, ray.at(lo + 0.75 * len)), false));
            count += 1;
            refined = true;
        }
        pieces = next;
        if !refined {
            break;
        }
    }
    for (lo, len, _, _, vm, _) in pieces {
        if let Some(p) = midpoint_piece(frame, shading, ray, lo, len, Some(vm)) {
            out.push(p);
        }
    }
}

/// Whether a full pre-integrated segment of length `seg` from value `vf` to
/// `vb` is refined (`RenderConfig::refine`). Along the ray, trilinear
/// values change at most by the voxels' slopes times the voxels crossed per
/// unit length, `l`; so the segment's values lie within (vf + vb -/+ l seg)
/// / 2, and it is refined where the table's opacity changes, summed from
/// entry to entry over that range (the entries around it included), by
/// more than `REFINE_OPACITY_CHANGE`.
fn reaches_unseen_opacity(frame: &Frame, ray: &Ray, seg: f64, vf: f64, vb: f64) -> bool {
    // Measured once per frame before any ray (`with_slopes`); unmeasured,
    // the bound is no bound, and every segment near an opacity change is
    // refined (never a pass over the volume per segment).
    let slopes = frame.slopes.unwrap_or([f64::MAX; 3]);
    let ext = frame.volume.bounds.extent();
    let crossed = [ray.dir.x / ext.x, ray.dir.y / ext.y, ray.dir.z / ext.z];
    let l: f64 = (0..3).map(|a| slopes[a] * (crossed[a] * frame.volume.dims[a] as f64).abs()).sum::<f64>()
        * frame.value_map.scale;
    let (mid, reach) = (0.5 * (vf + vb), 0.5 * l * seg);
    let m = frame.lut.len();
    let entry = |v: f64| v.clamp(0.0, 1.0) * (m - 1) as f64;
    let (i0, i1) = (entry(mid - reach).floor() as usize, entry(mid + reach).ceil() as usize);
    let change: f64 = (i0..i1.min(m - 1)).map(|i| (frame.lut[i + 1][3] as f64 - frame.lut[i][3] as f64).abs()).sum();
    change > preintegrate::REFINE_OPACITY_CHANGE
}

/// Segment `i` of an integrating model as pieces (one, unless adaptive):
/// each piece's optical depth and the premultiplied colour it adds before
/// attenuation by what lies in front. Empty pieces are left out.
fn segment(frame: &Frame, shading: Shading, ray: &Ray, i: u64, out: &mut Vec<(f64, [f64; 3])>) {
    out.clear();
    let cfg = &frame.config;
    let (lo, seg) = ray.span(cfg.step_size, i);
    if seg <= 0.0 {
        return;
    }
    if cfg.pre_integrated && seg == cfg.step_size {
        let (vf, vb) = (value(frame, ray.at(lo)), value(frame, ray.at(lo + seg)));
        if vf.is_nan() || vb.is_nan() {
            return;
        }
        if cfg.refine > 0 && reaches_unseen_opacity(frame, ray, seg, vf, vb) {
            // One segment made of its pieces front to back along the ray,
            // as the shader composites it (early termination comes after
            // the whole segment).
            let piece = seg / cfg.refine as f64;
            let (mut x, mut c) = (0.0f64, [0.0f64; 3]);
            for j in 0..cfg.refine {
                if let Some((xj, add)) = midpoint_piece(frame, shading, ray, lo + j as f64 * piece, piece, None) {
                    let keep = (-x).exp();
                    for k in 0..3 {
                        c[k] += keep * add[k];
                    }
                    x += xj;
                }
            }
            if x > 0.0 {
                out.push((x, c));
            }
            return;
        }
        // Eight times the table's resolution: the exact ramp integral.
        let k = preintegrate::substeps_for(frame.lut.len(), vf, vb) * 8;
        let r = preintegrate::segment(frame.lut, vf, vb, seg / cfg.reference_step_size, cfg.opacity_correction, k);
        if r[3] > 0.0 {
            // The mean of the light at the two ends, where the values are read.
            let light = 0.5
                * (intensity(frame, shading, ray.at(lo), ray.dir)
                    + intensity(frame, shading, ray.at(lo + seg), ray.dir));
            out.push((r[3], [r[0] * light, r[1] * light, r[2] * light]));
        }
        return;
    }
    if frame.adaptive_tolerance > 0.0 {
        let (vf, vb) = (value(frame, ray.at(lo)), value(frame, ray.at(lo + seg)));
        split(frame, shading, ray, lo, seg, vf, vb, out);
        return;
    }
    if let Some(p) = midpoint_piece(frame, shading, ray, lo, seg, None) {
        out.push(p);
    }
}

pub(super) fn integrate(frame: &Frame, ray: &Ray) -> RayResult {
    let cfg = &frame.config;
    let shading = Shading::choose(&frame.light, frame.volume.normals.is_some());
    let model = cfg.model;
    let mut c = [0.0f64; 3];
    let mut tau = 0.0f64;
    let mut t = 1.0f64;
    let mut stopped_early = false;
    let mut pieces = Vec::with_capacity(4);
    if cfg.order == Order::BackToFront {
        // C = c_i + exp(-x_i) C from the far end; no early stop is possible.
        for i in (0..ray.n).rev() {
            segment(frame, shading, ray, i, &mut pieces);
            for &(x, add) in pieces.iter().rev() {
                let keep = if model == Model::Emission { 1.0 } else { (-x).exp() };
                for k in 0..3 {
                    c[k] = add[k] + keep * c[k];
                }
                tau += x;
            }
        }
        t = (-tau).exp();
    } else {
        'ray: for i in 0..ray.n {
            segment(frame, shading, ray, i, &mut pieces);
            for &(x, add) in &pieces {
                for k in 0..3 {
                    c[k] += t * add[k];
                }
                if model == Model::Emission {
                    continue;
                }
                // Transmittance from the summed optical depth, as the shader does.
                tau += x;
                t = (-tau).exp();
                if cfg.early_ray_termination && model.terminates_early() && 1.0 - t >= cfg.opacity_threshold {
                    stopped_early = true;
                    break 'ray;
                }
                // The shader's rule: past this nothing behind can show.
                if t < 1e-30 {
                    t = 0.0;
                    stopped_early = true;
                    break 'ray;
                }
            }
        }
    }
    let alpha = if model == Model::Emission { 0.0 } else { 1.0 - t };
    let truncated_needed = if stopped_early { 0 } else { ray.truncated() };
    RayResult { rgba: [c[0], c[1], c[2], alpha], truncated_needed, depth: f64::INFINITY }
}
