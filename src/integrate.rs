//! The ray integral in plain f64: the oracle the GPU path is tested against,
//! and (with tiny steps) the converged image for accuracy measurements.
//!
//! Rule, shared with the shader: the ray's chord `[t0, t1]` through the box is
//! cut into segments of length `step`, the last one shorter (and, with
//! jitter, the first one too: the grid starts `shift` steps early, `shift`
//! in (-1, 0]); each segment is sampled at its midpoint and contributes with
//! its own length (Beer–Lambert opacity correction), front to back:
//! `C += T * a * I * rgb`, `T = exp(-Σ x)`. The other models of
//! [`crate::model::Model`] reuse the same segments.

use crate::config::{OpacityCorrection, RenderConfig};
use crate::model::{jitter_shift, phase_4pi, Model};
pub use crate::model::Order;
use crate::preintegrate;
use crate::scene::{Camera, Light, Shading};
use crate::scene::Bounds;
use crate::transfer::{eval_lut, ValueMap};
use crate::volume::VolumeView;
use glam::DVec3;

/// Everything one frame depends on.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    pub volume: VolumeView<'a>,
    /// RGBA entries at scalars `m / (M - 1)`.
    pub lut: &'a [[f32; 4]],
    pub camera: Camera,
    pub light: Light,
    pub config: RenderConfig,
    pub width: u32,
    pub height: u32,
    /// 0: each segment is one midpoint sample (the engine's rule). Above 0
    /// (converged references only): a segment is split in halves, down to
    /// 2^-24 of a step, while the transfer function varies across the values
    /// it spans by more than this, in optical depth or emitted colour per
    /// piece. Steps and peaks of the TF are then located instead of sampled.
    pub adaptive_tolerance: f64,
    /// Sampled value -> transfer-function domain (a value range in data units).
    pub value_map: ValueMap,
    /// Rays march only inside this box (a crop of the volume's), if given.
    pub clip: Option<Bounds>,
}

/// One ray's result: premultiplied colour and opacity, how many steps the
/// ray would have needed when `max_steps` cut it short (else 0), and for
/// the isosurface model the ray parameter of the hit (else infinity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayResult {
    pub rgba: [f64; 4],
    pub truncated_needed: u64,
    pub depth: f64,
}

impl Default for RayResult {
    fn default() -> Self {
        RayResult { rgba: [0.0; 4], truncated_needed: 0, depth: f64::INFINITY }
    }
}

/// Shadow rays stop once their optical depth passes this: the light left
/// (exp(-16) = 1.1e-7) is below what any output can show.
pub const SHADOW_TAU_MAX: f64 = 16.0;
/// Bisection steps that place an isosurface hit between two samples (to
/// 1/256 of their distance, then a secant step).
pub const ISO_BISECTIONS: u32 = 8;

/// `1 - exp(-x)` without cancellation for small `x`.
#[inline]
pub fn one_minus_exp_neg(x: f64) -> f64 {
    -(-x).exp_m1()
}

/// Extinction per reference step for transfer-function opacity `a`: `a`
/// itself (exponential form) or `-ln(1 - a)` (power form; infinite at 1).
#[inline]
pub fn extinction(a: f64, form: OpacityCorrection) -> f64 {
    if a <= 0.0 {
        return 0.0;
    }
    match form {
        OpacityCorrection::Exponential => a,
        OpacityCorrection::Power => {
            if a >= 1.0 {
                f64::INFINITY
            } else {
                -(-a).ln_1p()
            }
        }
    }
}

/// Opacity of a segment of length `len` for transfer-function opacity `a`.
#[inline]
pub fn corrected_alpha(a: f64, len_over_ref: f64, form: OpacityCorrection) -> f64 {
    let sigma = extinction(a, form);
    if sigma == 0.0 || len_over_ref <= 0.0 {
        return 0.0;
    }
    one_minus_exp_neg(sigma * len_over_ref)
}

/// Segments a chord of `len` needs when the grid starts `shift` steps
/// before its entry: `ceil(len / step - shift)`.
pub fn segments_needed(len: f64, step: f64, shift: f64) -> u64 {
    if len <= 0.0 {
        return 0;
    }
    let n = (len / step - shift).ceil();
    if n >= u64::MAX as f64 { u64::MAX } else { n as u64 }
}

/// One ray's chord and its segment grid.
struct Ray {
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
    shift: f64,
    /// Segments marched (at most `max_steps`) and segments needed.
    n: u64,
    needed: u64,
}

impl Ray {
    fn new(frame: &Frame, origin: DVec3, dir: DVec3, shift: f64) -> Option<Ray> {
        let (t0, t1) = marched_box(frame)?.intersect(origin, dir)?;
        let needed = segments_needed(t1 - t0, frame.config.step_size, shift);
        let n = needed.min(frame.config.max_steps.max(0) as u64);
        Some(Ray { origin, dir, t0, t1, shift, n, needed })
    }

    /// Segment `i`: its start as an offset from `t0`, and its length.
    fn span(&self, step: f64, i: u64) -> (f64, f64) {
        let a = i as f64 * step + self.shift * step;
        let len = self.t1 - self.t0;
        if a < 0.0 {
            (0.0, ((1.0 + self.shift) * step).min(len))
        } else {
            (a, step.min(len - a).max(0.0))
        }
    }

    fn at(&self, offset: f64) -> DVec3 {
        self.origin + self.dir * (self.t0 + offset)
    }

    fn truncated(&self) -> u64 {
        if self.n < self.needed { self.needed } else { 0 }
    }
}

/// The box rays march in: the volume's, cropped by the clip box if any
/// (None when the crop misses the volume). Shadow rays stop at it too.
fn marched_box(frame: &Frame) -> Option<Bounds> {
    match frame.clip {
        Some(c) => frame.volume.bounds.intersection(&c),
        None => Some(frame.volume.bounds),
    }
}

/// The value the transfer function sees at `p` (gradients use the raw field:
/// the map's positive scale leaves their direction unchanged).
fn value(frame: &Frame, p: DVec3) -> f64 {
    frame.value_map.apply(frame.volume.sample(frame.volume.bounds.to_unit(p)))
}

/// Light that reaches `p` from the light source through the volume:
/// `exp(-∫ σ ds / ref)` along the shadow ray, midpoint rule with the
/// shadow step, up to the (cropped) box exit (or the point light, if nearer).
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
    let Some((_, exit)) = marched_box(frame).and_then(|b| b.intersect(p, to_light)) else {
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
fn intensity(frame: &Frame, shading: Shading, p: DVec3, dir: DVec3) -> f64 {
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

/// One piece `[lo, lo + len]` of a ray (offsets from `t0`) by the midpoint
/// rule: its optical depth and the premultiplied colour it adds before
/// attenuation by what lies in front; `None` when empty (NaN, zero opacity).
/// `v` is the value at the midpoint, when already known.
fn midpoint_piece(frame: &Frame, shading: Shading, ray: &Ray, lo: f64, len: f64, v: Option<f64>) -> Option<(f64, [f64; 3])> {
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

/// Appends the pieces of `[lo, lo + len]` front to back, halving it where
/// the TF varies too much across the values it spans (see `Frame`).
#[allow(clippy::too_many_arguments)]
fn split(frame: &Frame, shading: Shading, ray: &Ray, lo: f64, len: f64, vf: f64, vb: f64, depth: u32, out: &mut Vec<(f64, [f64; 3])>) {
    let vm = value(frame, ray.at(lo + 0.5 * len));
    let vals = [vf, vm, vb];
    let finite = vals.iter().all(|v| !v.is_nan());
    let (a, b) = (vals.iter().cloned().fold(f64::INFINITY, f64::min), vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max));
    let coarse = !finite
        || depth >= 24
        || tf_variation(frame, a, b) * (len / frame.config.reference_step_size) <= frame.adaptive_tolerance;
    if coarse {
        if let Some(p) = midpoint_piece(frame, shading, ray, lo, len, Some(vm)) {
            out.push(p);
        }
        return;
    }
    let half = 0.5 * len;
    split(frame, shading, ray, lo, half, vf, vm, depth + 1, out);
    split(frame, shading, ray, lo + half, half, vm, vb, depth + 1, out);
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
        // Eight times the table's resolution: the exact ramp integral.
        let k = preintegrate::substeps_for(frame.lut.len(), vf, vb) * 8;
        let r = preintegrate::segment(frame.lut, vf, vb, seg / cfg.reference_step_size, cfg.opacity_correction, k);
        if r[3] > 0.0 {
            let light = intensity(frame, shading, ray.at(lo + 0.5 * seg), ray.dir);
            out.push((r[3], [r[0] * light, r[1] * light, r[2] * light]));
        }
        return;
    }
    if frame.adaptive_tolerance > 0.0 {
        let (vf, vb) = (value(frame, ray.at(lo)), value(frame, ray.at(lo + seg)));
        split(frame, shading, ray, lo, seg, vf, vb, 0, out);
        return;
    }
    if let Some(p) = midpoint_piece(frame, shading, ray, lo, seg, None) {
        out.push(p);
    }
}

fn integrate(frame: &Frame, ray: &Ray) -> RayResult {
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

/// The TF's premultiplied RGBA of a projected value.
fn projected(frame: &Frame, v: f64) -> [f64; 4] {
    let c = eval_lut(frame.lut, v);
    [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]]
}

fn project(frame: &Frame, ray: &Ray) -> RayResult {
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

fn isosurface(frame: &Frame, ray: &Ray) -> RayResult {
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

fn trace(frame: &Frame, origin: DVec3, dir: DVec3, shift: f64) -> RayResult {
    let Some(ray) = Ray::new(frame, origin, dir, shift) else {
        return RayResult::default();
    };
    match frame.config.model {
        m if m.integrates() => integrate(frame, &ray),
        m if m.projects() => project(frame, &ray),
        _ => isosurface(frame, &ray),
    }
}

/// One ray without jitter, in the config's model and order.
pub fn integrate_ray(frame: &Frame, origin: DVec3, dir: DVec3) -> RayResult {
    trace(frame, origin, dir, 0.0)
}

/// The same ray composited from the far end: `C = c_i + exp(-x_i) C`.
/// Equal to front-to-back when early termination does not stop the ray; a
/// check on both, since the two orders share no accumulation code.
pub fn integrate_ray_back_to_front(frame: &Frame, origin: DVec3, dir: DVec3) -> RayResult {
    let mut f = *frame;
    f.config.order = Order::BackToFront;
    trace(&f, origin, dir, 0.0)
}

/// A whole frame: premultiplied RGBA per pixel (row 0 at the bottom), the
/// ray parameter of each isosurface hit (infinity elsewhere), and the
/// largest step count a truncated ray needed (0 when none was cut short).
pub struct Image {
    pub rgba: Vec<[f64; 4]>,
    pub depth: Vec<f64>,
    pub truncated_needed: u64,
}

pub fn render(frame: &Frame) -> Result<(Vec<[f64; 4]>, u64), crate::scene::SceneError> {
    render_image(frame).map(|im| (im.rgba, im.truncated_needed))
}

pub fn render_ordered(frame: &Frame, order: Order) -> Result<(Vec<[f64; 4]>, u64), crate::scene::SceneError> {
    let mut f = *frame;
    f.config.order = order;
    render(&f)
}

pub fn render_image(frame: &Frame) -> Result<Image, crate::scene::SceneError> {
    let basis = frame.camera.basis(frame.width, frame.height)?;
    let (w, h) = (frame.width, frame.height);
    let mut out = vec![RayResult::default(); w as usize * h as usize];
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let rows_per = (h as usize).div_ceil(threads).max(1);
    let cfg = frame.config;
    std::thread::scope(|s| {
        for (chunk, pixels) in out.chunks_mut(rows_per * w as usize).enumerate() {
            s.spawn(move || {
                for (idx, px) in pixels.iter_mut().enumerate() {
                    let row = (chunk * rows_per + idx / w as usize) as u32;
                    let col = (idx % w as usize) as u32;
                    let shift = if cfg.jitter { jitter_shift(col, row, cfg.jitter_seed) as f64 } else { 0.0 };
                    *px = trace(frame, basis.origin, basis.direction(col, row, w, h), shift);
                }
            });
        }
    });
    Ok(Image {
        rgba: out.iter().map(|r| r.rgba).collect(),
        depth: out.iter().map(|r| r.depth).collect(),
        truncated_needed: out.iter().map(|r| r.truncated_needed).max().unwrap_or(0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Bounds, LightKind};
    use crate::volume::Voxels;

    fn constant_frame<'a>(data: &'a [f32], lut: &'a [[f32; 4]], cfg: RenderConfig) -> Frame<'a> {
        let vol = VolumeView::new([4, 4, 4], Voxels::F32(data), None, Bounds::default()).unwrap();
        Frame {
            volume: vol,
            lut,
            camera: Camera { position: DVec3::new(3.0, 0.0, 0.0), target: DVec3::ZERO, up: DVec3::Z, fov_y: 0.5 },
            light: Light { ambient: 1.0, diffuse: 0.0, kind: LightKind::Directional, ..Light::default() },
            config: cfg,
            width: 1,
            height: 1,
            adaptive_tolerance: 0.0,
            value_map: ValueMap::IDENTITY,
            clip: None,
        }
    }

    #[test]
    fn homogeneous_cube_matches_beer_lambert_at_every_step() {
        let data = [0.5f32; 64];
        let lut = [[0.8f32, 0.4, 0.2, 0.3], [0.8, 0.4, 0.2, 0.3]];
        for step in [0.05, 0.02, 0.01, 0.005, 0.001, 0.3, 0.77, 2.0] {
            let mut cfg = RenderConfig { step_size: step, max_steps: 100_000, early_ray_termination: false, ..RenderConfig::default() };
            cfg.opacity_threshold = 1.0;
            let f = constant_frame(&data, &lut, cfg);
            let r = integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), -DVec3::X);
            let expect = 1.0 - (-(0.3f32 as f64) * 1.0 / 0.01).exp();
            assert!((r.rgba[3] - expect).abs() < 1e-12, "step {step}: {} vs {expect}", r.rgba[3]);
            assert!((r.rgba[0] - 0.8f32 as f64 * expect).abs() < 1e-12);
            assert_eq!(r.truncated_needed, 0);
        }
    }

    #[test]
    fn power_form_matches_its_closed_form() {
        let data = [0.5f32; 64];
        let lut = [[1.0f32, 1.0, 1.0, 0.1]; 2];
        let mut cfg = RenderConfig { step_size: 0.003, max_steps: 100_000, early_ray_termination: false, ..RenderConfig::default() };
        cfg.opacity_correction = OpacityCorrection::Power;
        let f = constant_frame(&data, &lut, cfg);
        let r = integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), -DVec3::X);
        let expect = 1.0 - (1.0 - 0.1f32 as f64).powf(1.0 / 0.01);
        assert!((r.rgba[3] - expect).abs() < 1e-12);
    }

    #[test]
    fn truncation_and_early_termination_are_reported() {
        let data = [0.5f32; 64];
        let lut = [[1.0f32, 1.0, 1.0, 0.001]; 2];
        let cfg = RenderConfig { step_size: 0.1, max_steps: 3, ..RenderConfig::default() };
        let f = constant_frame(&data, &lut, cfg);
        let r = integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), -DVec3::X);
        assert_eq!(r.truncated_needed, 10);
        assert!((r.rgba[3] - (1.0 - (-0.001f32 as f64 * 30.0).exp())).abs() < 1e-12);
        let lut = [[1.0f32, 1.0, 1.0, 1.0]; 2];
        let f = constant_frame(&data, &lut, RenderConfig { max_steps: 3, step_size: 0.1, ..RenderConfig::default() });
        let r = integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), -DVec3::X);
        assert_eq!(r.truncated_needed, 0, "stopped by opacity, not by max_steps");
        assert!(r.rgba[3] >= 0.95);
    }

    #[test]
    fn back_to_front_equals_front_to_back() {
        let data: Vec<f32> = (0..64).map(|i| ((i * 37) % 64) as f32 / 63.0).collect();
        let lut: Vec<[f32; 4]> = (0..16).map(|i| [i as f32 / 15.0, 0.3, 1.0 - i as f32 / 15.0, 0.4 * i as f32 / 15.0]).collect();
        let cfg = RenderConfig { step_size: 0.013, early_ray_termination: false, ..RenderConfig::default() };
        let mut f = constant_frame(&data, &lut, cfg);
        f.light = Light::default();
        for dir in [DVec3::new(-1.0, 0.1, 0.05), DVec3::new(-1.0, -0.1, 0.12)] {
            let dir = dir.normalize();
            let a = integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), dir);
            let b = integrate_ray_back_to_front(&f, DVec3::new(3.0, 0.0, 0.0), dir);
            assert!(a.rgba[3] > 0.5, "{:?} {:?}", a, b);
            for k in 0..4 {
                assert!((a.rgba[k] - b.rgba[k]).abs() < 1e-12, "{k}: {} vs {}", a.rgba[k], b.rgba[k]);
            }
        }
    }

    #[test]
    fn midpoint_rule_converges_at_second_order() {
        // A smooth blob and a smooth TF; the error of one ray against h/64
        // must fall ~4x per halving (order 2). Sampling segment starts
        // instead (pyvr's rule) gives order 1 and fails this.
        let n = 16;
        let data: Vec<f32> = (0..n * n * n)
            .map(|idx| {
                let c = |a: usize| (a as f64 + 0.5) / n as f64 - 0.5;
                let (i, j, k) = (idx / (n * n), (idx / n) % n, idx % n);
                (-(c(i).powi(2) + (c(j) - 0.1).powi(2) + c(k).powi(2)) * 8.0).exp() as f32
            })
            .collect();
        let lut: Vec<[f32; 4]> = (0..256).map(|i| {
            let s = i as f32 / 255.0;
            [s, 1.0 - s, 0.5, 0.5 * s]
        }).collect();
        let vol = VolumeView::new([n, n, n], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let dir = DVec3::new(-1.0, 0.13, 0.07).normalize();
        let ray = |h: f64| {
            let cfg = RenderConfig { step_size: h, max_steps: 1 << 30, early_ray_termination: false, ..RenderConfig::default() };
            let f = Frame {
                volume: vol,
                lut: &lut,
                camera: Camera { position: DVec3::new(3.0, 0.0, 0.0), target: DVec3::ZERO, up: DVec3::Z, fov_y: 0.5 },
                light: Light { ambient: 1.0, diffuse: 0.0, ..Light::default() },
                config: cfg,
                width: 1,
                height: 1,
                adaptive_tolerance: 0.0,
                value_map: ValueMap::IDENTITY,
                clip: None,
            };
            integrate_ray(&f, DVec3::new(3.0, 0.0, 0.0), dir).rgba
        };
        let reference = ray(0.04 / 64.0);
        let err = |h: f64| {
            let r = ray(h);
            (0..4).map(|k| (r[k] - reference[k]).abs()).fold(0.0, f64::max)
        };
        let e: Vec<f64> = [0.04, 0.02, 0.01].iter().map(|&h| err(h)).collect();
        for w in e.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!((1.6..2.5).contains(&order), "observed order {order}, errors {e:?}");
        }
    }

    #[test]
    fn adaptive_splitting_locates_a_tf_step() {
        // A linear ramp v = q along x and a TF that jumps from 0 to a
        // between v = 0.5 and 0.501: the exact optical depth along the x
        // axis is a * (1 - 0.501 + 0.001 / 2) / ref. Midpoint sampling at a
        // coarse step misses where the jump is; splitting finds it.
        let n = 16;
        let data: Vec<f32> = (0..n * n * n).map(|idx| ((idx / (n * n)) as f32 + 0.5) / n as f32).collect();
        let m = 1001;
        let lut: Vec<[f32; 4]> = (0..m).map(|i| [1.0, 1.0, 1.0, if i > 500 { 0.02 } else { 0.0 }]).collect();
        let exact_tau = 0.02f32 as f64 * (1.0 - 0.501 + 0.0005) / 0.01;
        let cfg = RenderConfig { step_size: 0.3, early_ray_termination: false, ..RenderConfig::default() };
        let mut f = constant_frame(&data[..64], &lut, cfg);
        f.volume = VolumeView::new([n, n, n], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let alpha = |f: &Frame| integrate_ray(f, DVec3::new(3.0, 0.0, 0.0), -DVec3::X).rgba[3];
        let expect = 1.0 - (-exact_tau).exp();
        let coarse = (alpha(&f) - expect).abs();
        f.adaptive_tolerance = 1e-7;
        let fine = (alpha(&f) - expect).abs();
        assert!(coarse > 1e-2, "{coarse}");
        assert!(fine < 1e-6, "{fine}");
    }

    #[test]
    fn small_x_is_not_lost() {
        assert_eq!(one_minus_exp_neg(1e-20), 1e-20);
        assert!((one_minus_exp_neg(1e-8) - (1e-8 - 0.5e-16)).abs() < 1e-23);
        assert_eq!(corrected_alpha(0.0, 5.0, OpacityCorrection::Exponential), 0.0);
        assert_eq!(corrected_alpha(1.0, 0.5, OpacityCorrection::Power), 1.0);
    }
}
