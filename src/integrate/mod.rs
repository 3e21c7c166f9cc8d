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

use crate::config::RenderConfig;
use crate::error::{try_vec, Error};
use crate::model::jitter_shift;
pub use crate::model::Order;
use crate::scene::{Bounds, ClipPlane};
use crate::scene::{Camera, Light};
use crate::transfer::ValueMap;
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
    /// ... and only on the kept side of each of these planes.
    pub planes: &'a [ClipPlane],
    /// Per pixel (row 0 at the bottom), where an opaque scene stops the
    /// ray: the world distance along it (infinity: nothing); None: no scene.
    pub depth_in: Option<&'a [f64]>,
    /// The largest difference between neighbouring voxels along each numpy
    /// axis ([`voxel_slopes`]), which refined pre-integrated segments need;
    /// None: measured per frame (or per ray by `integrate_ray`) when needed.
    pub slopes: Option<[f64; 3]>,
}

/// Along each numpy axis, the largest difference between the values of
/// neighbouring voxels (pairs with NaN left out): trilinear interpolation
/// changes by at most that per voxel moved along the axis.
pub fn voxel_slopes(volume: &VolumeView) -> [f64; 3] {
    let [n0, n1, n2] = volume.dims;
    let v = |i: usize, j: usize, k: usize| volume.voxels.value((i * n1 + j) * n2 + k);
    let mut out = [0.0f64; 3];
    for i in 0..n0 {
        for j in 0..n1 {
            for k in 0..n2 {
                let here = v(i, j, k);
                let next = [
                    (i + 1 < n0).then(|| v(i + 1, j, k)),
                    (j + 1 < n1).then(|| v(i, j + 1, k)),
                    (k + 1 < n2).then(|| v(i, j, k + 1)),
                ];
                for (a, n) in next.into_iter().enumerate() {
                    if let Some(d) = n.map(|n| (n - here).abs()).filter(|d| !d.is_nan()) {
                        out[a] = out[a].max(d);
                    }
                }
            }
        }
    }
    out
}

/// The frame with its slopes measured, where refined segments need them.
fn with_slopes<'a>(frame: &Frame<'a>) -> Frame<'a> {
    let mut f = *frame;
    if f.slopes.is_none() && f.config.pre_integrates() && f.config.refine > 0 {
        f.slopes = Some(voxel_slopes(&f.volume));
    }
    f
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

mod compositing;
mod lighting;
mod optics;
mod pick;
mod projections;
#[cfg(test)]
mod tests;

use compositing::integrate;
pub use lighting::light_transmittance;
pub use optics::{corrected_alpha, extinction, max_extinction, one_minus_exp_neg, SHADOW_TAU_MAX};
pub use pick::pick;
use projections::{isosurface, project};

/// Segments a chord of `len` needs when the grid starts `shift` steps
/// before its entry: `ceil(len / step - shift)`.
pub fn segments_needed(len: f64, step: f64, shift: f64) -> u64 {
    if len <= 0.0 {
        return 0;
    }
    let n = (len / step - shift).ceil();
    if n >= u64::MAX as f64 {
        u64::MAX
    } else {
        n as u64
    }
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
    fn new(frame: &Frame, origin: DVec3, dir: DVec3, shift: f64, limit: f64) -> Option<Ray> {
        let (t0, t1) = chord(frame, origin, dir)?;
        let t1 = t1.min(limit);
        if t0 > t1 {
            return None;
        }
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
        if self.n < self.needed {
            self.needed
        } else {
            0
        }
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

/// The part of the ray `origin + t dir` (t >= 0) that marches: inside the
/// marched box and on the kept side of every clip plane; None if none.
fn chord(frame: &Frame, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
    let inside = marched_box(frame)?.intersect(origin, dir)?;
    frame.planes.iter().try_fold(inside, |span, plane| plane.cut(origin, dir, span))
}

/// The value the transfer function sees at `p` (gradients use the raw field:
/// the map's positive scale leaves their direction unchanged).
fn value(frame: &Frame, p: DVec3) -> f64 {
    frame.value_map.apply(frame.volume.sample(frame.volume.bounds.to_unit(p)))
}

/// The ray, marched up to ray parameter `limit` (an opaque surface there).
fn trace(frame: &Frame, origin: DVec3, dir: DVec3, shift: f64, limit: f64) -> RayResult {
    let Some(ray) = Ray::new(frame, origin, dir, shift, limit) else {
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
    trace(&with_slopes(frame), origin, dir, 0.0, f64::INFINITY)
}

/// The same ray composited from the far end: `C = c_i + exp(-x_i) C`.
/// Equal to front-to-back when early termination does not stop the ray; a
/// check on both, since the two orders share no accumulation code.
pub fn integrate_ray_back_to_front(frame: &Frame, origin: DVec3, dir: DVec3) -> RayResult {
    let mut f = with_slopes(frame);
    f.config.order = Order::BackToFront;
    trace(&f, origin, dir, 0.0, f64::INFINITY)
}

/// A whole frame: premultiplied RGBA per pixel (row 0 at the bottom), the
/// ray parameter of each isosurface hit (infinity elsewhere), and the
/// largest step count a truncated ray needed (0 when none was cut short).
pub struct Image {
    pub rgba: Vec<[f64; 4]>,
    pub depth: Vec<f64>,
    pub truncated_needed: u64,
}

pub fn render(frame: &Frame) -> Result<(Vec<[f64; 4]>, u64), Error> {
    render_image(frame).map(|im| (im.rgba, im.truncated_needed))
}

pub fn render_ordered(frame: &Frame, order: Order) -> Result<(Vec<[f64; 4]>, u64), Error> {
    let mut f = *frame;
    f.config.order = order;
    render(&f)
}

pub fn render_image(frame: &Frame) -> Result<Image, Error> {
    render_image_interruptible(frame, &mut |_| false)
}

/// `render_image`, calling `stop(rows finished)` about every 50 ms from the
/// calling thread while worker threads (one per core) take rows in turn;
/// `stop` returning true ends the frame with `Error::Interrupted` after the
/// rows in progress.
pub fn render_image_interruptible(frame: &Frame, stop: &mut dyn FnMut(usize) -> bool) -> Result<Image, Error> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    use std::sync::Mutex;
    let basis = frame.camera.basis(frame.width, frame.height)?;
    let measured = with_slopes(frame);
    let frame = &measured;
    let (w, h) = (frame.width as usize, frame.height as usize);
    let pixels = w.checked_mul(h).ok_or_else(|| Error::InvalidInput(format!("image {w}x{h} is too large")))?;
    // Per-ray results, then the image and depth made from them: ask for all
    // of it up front, so a frame too large for memory fails before starting.
    let need = pixels.checked_mul(2 * std::mem::size_of::<RayResult>());
    let mut probe: Vec<u8> = Vec::new();
    if need.is_none_or(|n| probe.try_reserve_exact(n).is_err()) {
        return Err(Error::OutOfMemory(format!(
            "a {w}x{h} float64 image needs about {} bytes of memory, which could not be allocated",
            pixels as u128 * 2 * std::mem::size_of::<RayResult>() as u128
        )));
    }
    drop(probe);
    // Workers fill rows as they take them: nothing image-sized is touched
    // before the work starts, so a Ctrl-C is answered at once.
    let threads = crate::cores::cores().min(h.max(1));
    let cfg = frame.config;
    let next_row = AtomicUsize::new(0);
    let cancelled = AtomicBool::new(false);
    let rows_done = AtomicUsize::new(0);
    let rows: Vec<Mutex<Vec<RayResult>>> = (0..h).map(|_| Mutex::new(Vec::new())).collect();
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|s| {
        for _ in 0..threads {
            let done = done_tx.clone();
            let (rows, next_row, cancelled, rows_done) = (&rows, &next_row, &cancelled, &rows_done);
            s.spawn(move || {
                loop {
                    let row = next_row.fetch_add(1, Ordering::Relaxed);
                    if row >= h || cancelled.load(Ordering::Relaxed) {
                        break;
                    }
                    let results: Vec<RayResult> = (0..w as u32)
                        .map(|col| {
                            let row = row as u32;
                            let shift = if cfg.jitter { jitter_shift(col, row, cfg.jitter_seed) as f64 } else { 0.0 };
                            let (origin, dir) = basis.ray(col, row, frame.width, frame.height);
                            let limit = frame.depth_in.map_or(f64::INFINITY, |d| d[row as usize * w + col as usize]);
                            trace(frame, origin, dir, shift, limit)
                        })
                        .collect();
                    *rows[row].lock().unwrap_or_else(|p| p.into_inner()) = results;
                    rows_done.fetch_add(1, Ordering::Relaxed);
                }
                let _ = done.send(());
            });
        }
        drop(done_tx);
        let mut finished = 0;
        while finished < threads {
            match done_rx.recv_timeout(std::time::Duration::from_millis(50)) {
                Ok(()) => finished += 1,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if !cancelled.load(Ordering::Relaxed) && stop(rows_done.load(Ordering::Relaxed)) {
                        cancelled.store(true, Ordering::Relaxed);
                    }
                }
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
            }
        }
    });
    if cancelled.load(Ordering::Relaxed) {
        return Err(Error::Interrupted);
    }
    let mut image = Image {
        rgba: try_vec(pixels, [0.0; 4], "the float64 image")?,
        depth: try_vec(pixels, f64::INFINITY, "the float64 depth image")?,
        truncated_needed: 0,
    };
    for (y, row) in rows.into_iter().enumerate() {
        for (x, r) in row.into_inner().unwrap_or_else(|p| p.into_inner()).into_iter().enumerate() {
            image.rgba[y * w + x] = r.rgba;
            image.depth[y * w + x] = r.depth;
            image.truncated_needed = image.truncated_needed.max(r.truncated_needed);
        }
    }
    Ok(image)
}
