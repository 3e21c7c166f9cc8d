//! The native engine: the shader's march on the CPU, for machines with no
//! GPU adapter or only a CPU one. Its code runs eight rays in the lanes of
//! AVX2 registers where the CPU has AVX2, FMA and F16C, and otherwise the
//! same code on eight lanes of portable Rust (`lanes`, `portable`).
//!
//! There wgpu runs the shader on lavapipe, whose 8-wide code gathers each
//! texel channel by channel and pays for every branch any lane takes. This
//! march runs the same rule (shaders/main.wgsl, compositing.wgsl,
//! skipping.wgsl: the same segments, lookups, light, partial sums, leaps
//! and early termination) with eight rays in the lanes of AVX2 registers on
//! every core, reading each 16-bit fixed-point texel (value and normal) in
//! one 64-bit gather. It covers the frames most CPU-only users render:
//! emission–absorption (plain, pre-integrated or refined), single
//! scattering (shadow rays from every sample), absorption and
//! emission (either marching order: back-to-front frames are marched front
//! to back, the same sum), either opacity correction, no
//! light or a directional or point one lighting from normals (or
//! gradients) held in the texels or stored apart from them, or from
//! central differences of the values, with or without jitter, skipping
//! and uniform runs, the maximum, minimum and average intensity
//! projections (`projection`), the
//! isosurface (`isosurface`) and unbiased frames (`tracking`), from a
//! volume held in one texture
//! (float32, float16 or 16-bit fixed-point texels, or 8- and 16-bit codes);
//! and a bricked volume's integrals, projections and isosurface brick after brick
//! (`render_brick`), each ray's state kept in memory between bricks.
//! Everything else stays on the GPU path, whose images these match
//! (tests/test_native_march.py, tests/test_bricks.py).

#[cfg(target_arch = "x86_64")]
mod cells;
mod clear;
#[cfg(target_arch = "x86_64")]
mod codes;
#[cfg(target_arch = "x86_64")]
mod compositing;
mod dispatch;
mod footprint;
mod frame;
#[cfg(target_arch = "x86_64")]
mod isosurface;
mod lanes;
#[cfg(target_arch = "x86_64")]
mod lighting;
#[cfg(target_arch = "x86_64")]
mod ops;
#[cfg(target_arch = "x86_64")]
mod projection;
#[cfg(target_arch = "x86_64")]
mod rays8;
#[cfg(target_arch = "x86_64")]
mod sampling;
#[cfg(target_arch = "x86_64")]
mod tracking;

use crate::occupancy::BLOCK;
#[cfg(test)]
pub(crate) use dispatch::avx2_available;
use dispatch::march_row;
pub use dispatch::{lanes, Lanes};
pub use frame::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Whether this machine runs the native march: every machine does, with
/// AVX2 or on the portable path (`lanes`).
pub fn available() -> bool {
    true
}

/// The frame was stopped by the caller.
#[derive(Debug)]
pub struct Interrupted;

/// Pixels a side of the tiles handed to the cores in turn: eight rays of a
/// row share a register, and a tile's rows, marched one after another on
/// one core, find the voxels the row before read in that core's caches.
const TILE: usize = 8;

/// An image's pointer, shared by the workers, each of which writes only
/// the pixels of the tiles it takes.
struct Shared<T>(*mut T);
unsafe impl<T> Sync for Shared<T> {}

impl<T: Copy> Shared<T> {
    /// # Safety
    /// `i` must lie in the image, and no other thread may write pixel `i`.
    unsafe fn write(&self, i: usize, v: T) {
        unsafe { *self.0.add(i) = v };
    }

    /// # Safety
    /// As for `write`.
    unsafe fn read(&self, i: usize) -> T {
        unsafe { *self.0.add(i) }
    }
}

/// The checks every frame of the march passes before its workers start.
fn check(frame: &Frame) {
    let p = frame.params;
    assert!(p.max_steps <= MAX_STEPS, "the native march takes at most {MAX_STEPS} steps a ray");
    if let Some((codes, dims)) = frame.cells {
        assert!(codes.len() >= dims.iter().product::<usize>() + 3, "occupancy codes need 3 bytes of padding");
    }
    if let Some(majorants) = frame.majorants {
        let cells = frame.cells.map(|(_, dims)| dims.iter().product::<usize>());
        assert!(cells.is_some_and(|n| majorants.len() >= n + 3), "majorant codes need 3 bytes of padding");
    }
    if frame.unbiased {
        let models = [Model::EmissionAbsorption, Model::Absorption, Model::Emission];
        assert!(models.contains(&frame.model) && frame.preint.is_none(), "unbiased frames' models");
    }
    if let Some(t) = frame.preint {
        let rows = crate::preintegrate::wrapped_rows(p.lut_size as usize, t.side);
        let fits = t.side >= 2 && t.rows == rows && t.texels.len() >= t.side * (t.side + 3 * rows);
        assert!(fits, "pre-integration table");
        assert_eq!(frame.model, Model::EmissionAbsorption, "pre-integration tables are emission-absorption's");
        assert!(frame.refine <= 16, "refine");
    }
    let texels = frame.volume.dims.iter().product();
    assert!(frame.volume.texels.padded(texels), "texels and their padding");
    assert!(frame.volume.normals.as_ref().is_none_or(|n| n.len() >= texels), "a normal a texel");
}

/// Renders the frame into `out` (width x height, each pixel written in its
/// format as its row is marched) on every core, and an isosurface's hit
/// distances into `depth` (one a pixel, row 0 at the bottom; infinity on a
/// miss), where given. With `blank` (`out` holds what missed pixels would
/// be, and `depth` infinities, already) the pixels outside
/// the box's footprint are not written. The calling
/// thread asks `stop` about every 10 ms while the workers march (each ray
/// checks for a stop every 1024 steps), so a frame of any length can be
/// interrupted.
pub fn render(
    frame: &Frame,
    out: &crate::output::Target,
    mut depth: Option<&mut [f32]>,
    blank: bool,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Stats, Interrupted> {
    let p = frame.params;
    let (w, h) = (p.width as usize, p.height as usize);
    assert_eq!(out.size(), (w, h), "output size");
    if let Some(d) = &depth {
        assert_eq!(d.len(), w * h, "depth size");
    }
    check(frame);
    let clear = clear::Clear::new(frame.lut, frame.preint.map(|t| (&t.texels[..], t.side)));
    let seen = footprint::footprint(p);
    let depth_image = depth.as_mut().map(|d| Shared(d.as_mut_ptr()));
    on_every_core(w, h, stop, |(cols, rows), halt| {
        let mut stats = Stats::default();
        // Rays that miss the box leave their pixels transparent (and take
        // no samples). The whole tile is asked first, once, rather than
        // each of its rows (a small box in a large frame misses most tiles).
        let tile_misses = seen.is_some_and(|fp| fp.misses(cols, rows));
        if tile_misses && blank {
            return stats;
        }
        for row in rows.0..rows.1 {
            let misses = tile_misses || seen.is_some_and(|fp| fp.misses(cols, (row, row + 1)));
            if misses && blank {
                continue;
            }
            let mut rgba = [[0f32; 4]; TILE];
            let mut dist = [f32::INFINITY; TILE];
            if !misses {
                let s = march_row(frame, &clear, cols.0 as u32, row as u32, &mut rgba, &mut dist, halt, None);
                stats.samples += s.samples;
                stats.truncated_needed = stats.truncated_needed.max(s.truncated_needed);
            }
            let n = cols.1 - cols.0;
            // SAFETY: each pixel lies in one tile, taken by one worker.
            unsafe { out.put(row, cols.0, &rgba[..n]) };
            if let Some(d) = &depth_image {
                for (l, &dist) in dist.iter().enumerate().take(n) {
                    // SAFETY: as for the image.
                    unsafe { d.write(row * w + cols.0 + l, dist) };
                }
            }
        }
        stats
    })
}

/// The rays of a bricked frame between its bricks (main.wgsl's ray state),
/// row 0 at the bottom: each pixel's premultiplied colour and optical depth
/// so far, and whether its ray has stopped.
pub struct RayStates {
    width: usize,
    height: usize,
    state: Vec<[f32; 4]>,
    /// Bit l of entry row * ceil(width / 8) + col / 8: pixel col = 8 (col / 8) + l has stopped.
    stopped: Vec<u8>,
}

impl RayStates {
    /// Rays that have crossed nothing yet.
    pub fn new(width: usize, height: usize) -> Result<RayStates, crate::error::Error> {
        let state = crate::error::try_vec(width * height, [0f32; 4], "the bricked frame's ray states")?;
        let stopped = vec![0u8; width.div_ceil(TILE) * height];
        Ok(RayStates { width, height, state, stopped })
    }

    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Each pixel's (premultiplied colour, optical depth).
    pub fn states(&self) -> &[[f32; 4]] {
        &self.state
    }

    /// Whether pixel i's ray has stopped.
    fn stopped(&self, i: usize) -> bool {
        let (col, row) = (i % self.width, i / self.width);
        self.stopped[row * self.width.div_ceil(TILE) + col / TILE] & (1 << (col % TILE)) != 0
    }

    /// An isosurface's hit distance of pixel i (infinity on a miss).
    pub fn depth(&self, i: usize) -> f32 {
        if self.stopped(i) {
            self.state[i][3]
        } else {
            f32::INFINITY
        }
    }

    /// Pixel i's premultiplied (colour, alpha) under `model` and the
    /// transfer function's table `lut`, as the march ends a ray: alpha
    /// 1 - e^-tau (none for the emission model's glow), or a projection's
    /// value through the table.
    pub fn pixel(&self, i: usize, model: Model, lut: &[[f32; 4]]) -> [f32; 4] {
        let [r, g, b, tau] = self.state[i];
        let value = match model {
            Model::Isosurface if self.depth(i).is_finite() => return [r, g, b, 1.0],
            Model::Isosurface => return [0.0; 4],
            Model::Average if g > 0.0 => r / g,
            Model::Mip | Model::MinIp if g > 0.0 => r,
            m if m.projects() => return [0.0; 4],
            Model::Emission => return [r, g, b, 0.0],
            // 1 - e^-tau in f64, for the small depths of faint rays.
            _ => return [r, g, b, crate::integrate::one_minus_exp_neg(tau as f64) as f32],
        };
        let c = crate::transfer::eval_lut(lut, value as f64).map(|c| c as f32);
        [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]]
    }
}

/// Marches every ray's segments inside the brick whose texels `frame`
/// holds (`frame.params` is the brick's block: `bricked`, its core box and
/// texture coordinates) from the states the bricks before it left, on
/// every core, leaving theirs for the bricks after it; rays that stopped
/// are not marched again. Only the pixels whose rays can meet the brick
/// (its box within the crop's footprint) are visited. Covers
/// emission-absorption (plain, pre-integrated, refined or unbiased),
/// absorption and emission frames (marched front to back but for unbiased
/// ones, whose bricks come far to near for back-to-front frames), the
/// projections and the isosurface. Interrupted as `render`.
pub fn render_brick(
    frame: &Frame,
    states: &mut RayStates,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Stats, Interrupted> {
    let p = frame.params;
    let (w, h) = (p.width as usize, p.height as usize);
    assert_eq!(states.size(), (w, h), "ray states' size");
    assert!(p.bricked == 1, "a brick's block");
    let models = [Model::EmissionAbsorption, Model::Absorption, Model::Emission];
    let covered =
        frame.model.projects() || frame.model == Model::Isosurface || models.contains(&frame.model) && !frame.scatter;
    assert!(covered, "bricked frames' models");
    check(frame);
    let clear = clear::Clear::new(frame.lut, frame.preint.map(|t| (&t.texels[..], t.side)));
    // The footprint of the brick's core within the crop box.
    let mut clipped = *p;
    for a in 0..3 {
        clipped.clip_lo[a] = p.clip_lo[a].max(p.core_lo[a]);
        clipped.clip_hi[a] = p.clip_hi[a].min(p.core_hi[a]);
    }
    if (0..3).any(|a| !(clipped.clip_lo[a] <= clipped.clip_hi[a])) {
        return Ok(Stats::default());
    }
    let seen = footprint::footprint(&clipped);
    let state = Shared(states.state.as_mut_ptr());
    let stopped = Shared(states.stopped.as_mut_ptr());
    let tiles_x = w.div_ceil(TILE);
    on_every_core(w, h, stop, |(cols, rows), halt| {
        let mut stats = Stats::default();
        if seen.is_some_and(|fp| fp.misses(cols, rows)) {
            return stats;
        }
        let n = cols.1 - cols.0;
        for row in rows.0..rows.1 {
            let at = row * tiles_x + cols.0 / TILE;
            // SAFETY: each pixel (and each row of a tile's bits) lies in one
            // tile, taken by one worker.
            let mut bits = unsafe { stopped.read(at) };
            if bits == ((1u16 << n) - 1) as u8 || seen.is_some_and(|fp| fp.misses(cols, (row, row + 1))) {
                continue;
            }
            let mut rgba = [[0f32; 4]; TILE];
            for (l, px) in rgba.iter_mut().enumerate().take(n) {
                // SAFETY: as above.
                *px = unsafe { state.read(row * w + cols.0 + l) };
            }
            let mut dist = [f32::INFINITY; TILE];
            let s = march_row(frame, &clear, cols.0 as u32, row as u32, &mut rgba, &mut dist, halt, Some(&mut bits));
            stats.samples += s.samples;
            stats.truncated_needed = stats.truncated_needed.max(s.truncated_needed);
            for (l, &px) in rgba.iter().enumerate().take(n) {
                // SAFETY: as above.
                unsafe { state.write(row * w + cols.0 + l, px) };
            }
            // SAFETY: as above.
            unsafe { stopped.write(at, bits) };
        }
        stats
    })
}

/// Runs `tile` on every tile of a `w` x `h` frame (its columns and rows,
/// half-open), the tiles handed to the cores in turn, and adds up what
/// they took. The calling thread asks `stop` about every 10 ms; once it
/// says so, `halt` is set for the workers and no tile more is begun.
fn on_every_core(
    w: usize,
    h: usize,
    stop: &mut dyn FnMut() -> bool,
    tile: impl Fn(((usize, usize), (usize, usize)), &AtomicBool) -> Stats + Sync,
) -> Result<Stats, Interrupted> {
    let tiles_x = w.div_ceil(TILE);
    let tiles = tiles_x * h.div_ceil(TILE);
    let next = AtomicUsize::new(0);
    let halt = AtomicBool::new(false);
    let work = || -> Stats {
        let mut stats = Stats::default();
        loop {
            let t = next.fetch_add(1, Ordering::Relaxed);
            if t >= tiles || halt.load(Ordering::Relaxed) {
                return stats;
            }
            let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
            let s = tile(((x0, (x0 + TILE).min(w)), (y0, (y0 + TILE).min(h))), &halt);
            stats.samples += s.samples;
            stats.truncated_needed = stats.truncated_needed.max(s.truncated_needed);
        }
    };
    let threads = crate::cores::cores().min(tiles.max(1));
    let caller = std::thread::current();
    // Counted before each worker wakes the caller, so that a wake-up is
    // never missed (a thread's own finished flag is set only after it exits).
    let finished = AtomicUsize::new(0);
    let stats = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    set_flush_to_zero();
                    let stats = work();
                    finished.fetch_add(1, Ordering::Release);
                    caller.unpark();
                    stats
                })
            })
            .collect();
        while finished.load(Ordering::Acquire) < threads {
            if stop() {
                halt.store(true, Ordering::Relaxed);
            }
            std::thread::park_timeout(std::time::Duration::from_millis(10));
        }
        // A worker's panic goes on in this thread (the binding turns it into
        // an exception) rather than leaving its tiles unwritten.
        let joined = workers.into_iter().map(|t| t.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        joined.fold(Stats::default(), |a, b| Stats {
            samples: a.samples + b.samples,
            truncated_needed: a.truncated_needed.max(b.truncated_needed),
        })
    });
    if halt.load(Ordering::Relaxed) {
        return Err(Interrupted);
    }
    Ok(stats)
}

/// Sets flush-to-zero on this thread (a worker's own): a result that would
/// be subnormal is 0, so the march never makes one, and each operation
/// making or reading one would take a microcode assist of ~100 cycles
/// (`renderer::resources::cpu_copy` flushes the texels' own). Inputs are
/// read as they are
/// (no denormals-are-zero): a value map or step can be subnormal in an
/// extreme scene (a value range of 3e38, a box 6e37 across) and must not
/// read as 0. WGSL lets shaders flush subnormal results too.
fn set_flush_to_zero() {
    #[cfg(target_arch = "x86_64")]
    {
        const FTZ: u32 = 1 << 15;
        let mut csr = 0u32;
        // SAFETY: stmxcsr and ldmxcsr read and write MXCSR, which only
        // changes this thread's SSE/AVX rounding of subnormals.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack, preserves_flags));
            csr |= FTZ;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack, preserves_flags, readonly));
        }
    }
}

/// The most steps a ray of the native march takes: its lanes count steps
/// in 32-bit signed integers.
pub const MAX_STEPS: u32 = 1 << 30;

/// One pixel's ray as main.wgsl builds it: its chord through the (cropped)
/// box and clip planes, segment grid and step count, and the window of segments whose
/// midpoints (pre-integrated: any of whose points) may lie in occupied cells
/// (skipping.wgsl `occupied_window`).
/// The march builds eight at a time (`rays8`), held to this statement of
/// the rule, one ray at a time, by its test.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ray {
    pub o: [f32; 3],
    pub d: [f32; 3],
    pub t0: f32,
    pub chord: f32,
    pub shift: f32,
    pub n: u32,
    pub needed: u32,
    /// Segments [window.0, window.1) are marched.
    pub window: (u32, u32),
}

#[cfg(test)]
impl Ray {
    pub(crate) fn new(frame: &Frame, col: u32, row: u32) -> Option<Ray> {
        let p = frame.params;
        let (w, h) = (p.width as f32, p.height as f32);
        let ndc = [(2.0 * col as f32 + 1.0 - w) / w, (2.0 * row as f32 + 1.0 - h) / h];
        let across = |base: &[f32; 4], a: usize| base[a] + ndc[0] * p.cam_right[a] + ndc[1] * p.cam_up[a];
        let (o, d) = if p.orthographic == 1 {
            (std::array::from_fn(|a| across(&p.cam_pos, a)), std::array::from_fn(|a| p.cam_fwd[a]))
        } else {
            let d: [f32; 3] = std::array::from_fn(|a| across(&p.cam_fwd, a));
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            (std::array::from_fn(|a| p.cam_pos[a]), d.map(|c| c / l))
        };
        let (mut t0, mut t1) = (-3.0e38f32, 3.0e38f32);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < p.clip_lo[a] || o[a] > p.clip_hi[a] {
                    return None;
                }
            } else {
                let inv = 1.0 / d[a];
                let (ta, tb) = ((p.clip_lo[a] - o[a]) * inv, (p.clip_hi[a] - o[a]) * inv);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        for q in &p.clip_planes[..p.clip_count as usize] {
            let f0 = q[0] * o[0] + q[1] * o[1] + q[2] * o[2] + q[3];
            let slope = q[0] * d[0] + q[1] * d[1] + q[2] * d[2];
            if slope > 0.0 {
                t0 = t0.max(-f0 / slope);
            } else if slope < 0.0 {
                t1 = t1.min(-f0 / slope);
            } else if f0 < 0.0 {
                return None;
            }
        }
        if let Some(depth) = frame.depth_in {
            t1 = t1.min(depth[(row * p.width + col) as usize]);
        }
        if t0 > t1 || t1 <= 0.0 {
            return None;
        }
        let t0 = t0.max(0.0);
        let chord = t1 - t0;
        let shift = if frame.jitter { crate::model::jitter_shift(col, row, p.jitter_seed) } else { 0.0 };
        let needed = (chord / p.step_size - shift).ceil().min(4.0e9) as u32;
        let n = needed.min(p.max_steps);
        let mut ray = Ray { o, d, t0, chord, shift, n, needed, window: (0, n) };
        if p.bricked == 1 {
            ray.window = ray.brick_window(frame, t1);
            if frame.skip_empty && p.occupied_hi[3] == 1.0 {
                let (lo, hi) = ray.occupied_window(frame);
                let (lo, hi) = (ray.window.0.max(lo), ray.window.1.min(hi));
                ray.window = if lo < hi { (lo, hi) } else { (0, 0) };
            }
        } else if frame.skip_empty {
            ray.window = ray.occupied_window(frame);
        }
        Some(ray)
    }

    /// main.wgsl `brick_window`, and its (0, 0) where a brick holds none.
    fn brick_window(&self, frame: &Frame, t1: f32) -> (u32, u32) {
        let p = frame.params;
        let o = &self.o;
        let (mut a0, mut a1) = (self.t0, t1);
        for a in 0..3 {
            if self.d[a] == 0.0 {
                if o[a] < p.core_lo[a] || o[a] >= p.core_hi[a] {
                    return (0, 0);
                }
            } else {
                let inv = 1.0 / self.d[a];
                let (ta, tb) = ((p.core_lo[a] - o[a]) * inv, (p.core_hi[a] - o[a]) * inv);
                a0 = a0.max(ta.min(tb));
                a1 = a1.min(ta.max(tb));
            }
        }
        if !(a1 > a0) {
            return (0, 0);
        }
        let segment_at = |t: f32| ((t - self.t0) / p.step_size - self.shift - 0.5).ceil().clamp(0.0, 4.0e9) as u32;
        let lo = if a0 > self.t0 { segment_at(a0) } else { 0 };
        let hi = if a1 < t1 { segment_at(a1) } else { self.n };
        let (lo, hi) = (lo.min(self.n), hi.min(self.n));
        if hi <= lo {
            (0, 0)
        } else {
            (lo, hi)
        }
    }

    /// skipping.wgsl `occupied_window`, in numpy axis order.
    fn occupied_window(&self, frame: &Frame) -> (u32, u32) {
        let p = frame.params;
        if p.occupied_hi[3] != 1.0 {
            return (0, self.n);
        }
        let dims = frame.volume.dims;
        let mut a = 0f32;
        let mut b = self.chord;
        for k in 0..3 {
            // The block's boxes are in texture axis order: numpy axis k is texture axis 2 - k.
            let (lo, hi) = (p.occupied_lo[2 - k], p.occupied_hi[2 - k]);
            let tc = (self.o[k] + self.d[k] * self.t0) * p.tex_scale[k] + p.tex_offset[k];
            let u0 = tc * dims[k] as f32 - p.border as f32;
            let du = self.d[k] * p.tex_scale[k] * dims[k] as f32;
            if du == 0.0 {
                if u0 < lo || u0 > hi {
                    return (0, 0);
                }
            } else {
                let (ta, tb) = ((lo - u0) / du, (hi - u0) / du);
                a = a.max(ta.min(tb));
                b = b.min(ta.max(tb));
            }
        }
        if !(b >= a) {
            return (0, 0);
        }
        let h = p.step_size;
        let n = self.n as f32;
        // Steps from a segment's midpoint to the farthest of its points that count.
        let reach = if frame.preint.is_some() || frame.unbiased { 0.5 } else { 0.0 };
        let mut lo = (a / h - (0.5 + reach) - self.shift - 1e-3).ceil().clamp(0.0, n) as u32;
        let mut hi = ((b / h - (0.5 - reach) - self.shift + 1e-3).floor() + 1.0).clamp(0.0, n) as u32;
        if lo <= 1 {
            lo = 0;
        }
        if hi + 1 >= self.n {
            hi = self.n;
        }
        (lo, hi)
    }
}

/// Occupancy cells a side, in voxels (as the shader's CELL).
pub(crate) const CELL: f32 = BLOCK as f32;

/// Empty cubes a pre-integrated leap crosses at most (as the shader's CHAIN).
pub(crate) const CHAIN: usize = 4;

/// What the tests of the rays and the footprint build their frames from.
#[cfg(test)]
pub(crate) mod test_rays {
    use super::{CpuVolume, Frame, Model};
    use crate::plan::Params;

    /// A number in [lo, hi) from a counter.
    pub fn pick(k: &mut u32, lo: f32, hi: f32) -> f32 {
        *k += 1;
        lo + (hi - lo) * (crate::model::hash32(*k) >> 8) as f32 / 16_777_216.0
    }

    /// A plain emission–absorption frame of `params` (no table, cells, light,
    /// skipping or jitter; early termination on): the rays are all it holds.
    pub fn frame<'a>(params: &'a Params, volume: &'a CpuVolume) -> Frame<'a> {
        Frame {
            params,
            depth_in: None,
            volume,
            lut: &[],
            cells: None,
            skip_empty: false,
            lit: false,
            gradient: false,
            point_light: false,
            early_termination: true,
            jitter: false,
            uniform_runs: false,
            model: Model::EmissionAbsorption,
            preint: None,
            refine: 0,
            power: false,
            scatter: false,
            unbiased: false,
            back_to_front: false,
            majorants: None,
            bounds: None,
        }
    }
}
