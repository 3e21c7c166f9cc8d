//! Would a native CPU march beat lavapipe? The benchmark scene's balanced
//! frame (a 256^3 double sphere with unit normals, 512x512, linear(0, 0.1)
//! opacity, ambient 0.2 + diffuse 0.8 from a directional light) rendered by
//! the GPU path on whatever adapter wgpu picks (lavapipe on a machine
//! without a GPU) and by two native marches of the same rule on all cores:
//!
//! * `scalar`: one ray at a time, the texel's four channels as one vector;
//! * `avx2`: eight rays in the lanes of AVX2 registers, texels gathered.
//!
//! Each native image must match the GPU's within 0.05 level (the same f32
//! rule; only the order of sums and the exponential differ), so the
//! timings compare the same work. Prints ms, samples and ns per sample.
//! These marches cover only this frame's kind (emission-absorption, front
//! to back, no jitter, float32 texels with normals, no crop or value map);
//! they are measurements, not an engine.
//!
//! Run: `cargo bench --bench native_march -- [size] [n]` (default 512 256);
//! `benches/native_march.py` runs it and writes the docs table.

use glam::DVec3;
use pyvr_core::config::RenderConfig;
use pyvr_core::gpu::params::{FrameInputs, Params};
use pyvr_core::gpu::GpuRenderer;
use pyvr_core::scene::{Bounds, Camera, Light};
use pyvr_core::transfer::ValueMap;
use pyvr_core::volume::{VolumeView, Voxels};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// The frame as the shader sees it: texels (value, unit normal), numpy
/// axis order (axis 2 fastest), the table and the uniform block.
struct Frame {
    texels: Vec<[f32; 4]>,
    dims: [usize; 3],
    lut: Vec<[f32; 4]>,
    p: Params,
}

/// One ray's chord through the box, as in shaders/main.wgsl.
#[derive(Clone, Copy, Default)]
struct Chord {
    o: [f32; 3],
    d: [f32; 3],
    t0: f32,
    len: f32,
    n: u32,
}

fn chord(p: &Params, col: u32, row: u32) -> Option<Chord> {
    let ndc = [
        2.0 * (col as f32 + 0.5) / p.width as f32 - 1.0,
        2.0 * (row as f32 + 0.5) / p.height as f32 - 1.0,
    ];
    let mut d = [0f32; 3];
    for a in 0..3 {
        d[a] = p.cam_fwd[a] + ndc[0] * p.cam_right[a] + ndc[1] * p.cam_up[a];
    }
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d = d.map(|c| c / l);
    let o = [p.cam_pos[0], p.cam_pos[1], p.cam_pos[2]];
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
    if t0 > t1 || t1 <= 0.0 {
        return None;
    }
    let t0 = t0.max(0.0);
    let len = t1 - t0;
    let n = ((len / p.step_size).ceil() as u32).min(p.max_steps);
    Some(Chord { o, d, t0, len, n })
}

fn one_minus_exp_neg(x: f32) -> f32 {
    if x < 1e-3 {
        x * (1.0 - x * (0.5 - x * (1.0 / 6.0)))
    } else {
        1.0 - (-x).exp()
    }
}

/// Texture coordinates in voxel units (cell-centred) of world point q.
fn voxel_coords(f: &Frame, q: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|a| (q[a] * f.p.tex_scale[a] + f.p.tex_offset[a]) * f.dims[a] as f32 - 0.5)
}

/// The shader's ray, one at a time. Returns premultiplied RGBA and samples.
#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn march_scalar(f: &Frame, c: &Chord) -> ([f32; 4], u32) {
    let p = &f.p;
    let [d0, d1, d2] = f.dims;
    let hi = [d0 as i32 - 1, d1 as i32 - 1, d2 as i32 - 1];
    let m = f.lut.len();
    let (mut color, mut color_b, mut tau, mut tau_b, mut trans) = ([0f32; 3], [0f32; 3], 0f32, 0f32, 1f32);
    let mut taken = 0u32;
    let mut stopped = false;
    for i in 0..c.n {
        let a = i as f32 * p.step_size;
        let seg = p.step_size.min(c.len - a).max(0.0);
        let mid = a + 0.5 * seg;
        let q: [f32; 3] = std::array::from_fn(|k| c.o[k] + c.d[k] * (c.t0 + mid));
        let u = voxel_coords(f, q);
        let fl = u.map(f32::floor);
        let w: [f32; 3] = std::array::from_fn(|k| u[k] - fl[k]);
        let lo: [usize; 3] = std::array::from_fn(|k| (fl[k] as i32).clamp(0, hi[k]) as usize);
        let up: [usize; 3] = std::array::from_fn(|k| (fl[k] as i32 + 1).clamp(0, hi[k]) as usize);
        let at = |i0: usize, i1: usize, i2: usize| f.texels[(i0 * d1 + i1) * d2 + i2];
        let lerp = |x: [f32; 4], y: [f32; 4], t: f32| -> [f32; 4] { std::array::from_fn(|k| x[k] + (y[k] - x[k]) * t) };
        let row = |i0: usize, i1: usize| lerp(at(i0, i1, lo[2]), at(i0, i1, up[2]), w[2]);
        let plane = |i0: usize| lerp(row(i0, lo[1]), row(i0, up[1]), w[1]);
        let t = lerp(plane(lo[0]), plane(up[0]), w[0]);
        taken += 1;
        let v = t[0] * p.value_scale + p.value_offset;
        let xl = v.clamp(0.0, 1.0) * (m - 1) as f32;
        let k = (xl as usize).min(m - 2);
        let rgba = lerp(f.lut[k], f.lut[k + 1], xl - k as f32);
        let sigma = rgba[3];
        let (mut x, mut add) = (0.0, 0.0);
        if sigma > 0.0 && seg > 0.0 {
            x = (sigma * seg * p.inv_ref).min(1.0e30);
            let ln = (t[1] * t[1] + t[2] * t[2] + t[3] * t[3]).sqrt();
            let light = if ln > 0.0 && p.light_valid == 1 {
                let cos = (t[1] * p.light_dir[0] + t[2] * p.light_dir[1] + t[3] * p.light_dir[2]) / ln;
                p.ambient + p.diffuse * cos.max(0.0)
            } else {
                p.ambient
            };
            add = one_minus_exp_neg(x) * light;
        }
        for k in 0..3 {
            color_b[k] += trans * add * rgba[k];
        }
        tau_b += x;
        // Partial sums of 256 samples, folded as the shader folds them.
        if taken & 255 == 0 {
            tau += tau_b;
            tau_b = 0.0;
            for k in 0..3 {
                color[k] += color_b[k];
                color_b[k] = 0.0;
            }
        }
        trans = (-(tau + tau_b)).exp();
        if 1.0 - trans >= p.threshold || trans < 1e-30 {
            stopped = trans < 1e-30;
            break;
        }
    }
    for k in 0..3 {
        color[k] += color_b[k];
    }
    tau += tau_b;
    let alpha = if stopped { 1.0 } else { one_minus_exp_neg(tau) };
    ([color[0], color[1], color[2], alpha], taken)
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{one_minus_exp_neg, voxel_coords, Chord, Frame};
    use std::arch::x86_64::*;

    /// e^x for x <= 0 (2^(x log2 e), degree-6 polynomial): relative error ~2e-7.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn exp_nonpositive(x: __m256) -> __m256 {
        let x = _mm256_max_ps(x, _mm256_set1_ps(-87.0));
        let t = _mm256_mul_ps(x, _mm256_set1_ps(std::f32::consts::LOG2_E));
        let k = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(t);
        let r = _mm256_mul_ps(_mm256_sub_ps(t, k), _mm256_set1_ps(std::f32::consts::LN_2));
        let mut poly = _mm256_set1_ps(1.0 / 720.0);
        for c in [1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
            poly = _mm256_fmadd_ps(poly, r, _mm256_set1_ps(c));
        }
        let bits = _mm256_slli_epi32::<23>(_mm256_add_epi32(_mm256_cvtps_epi32(k), _mm256_set1_epi32(127)));
        _mm256_mul_ps(poly, _mm256_castsi256_ps(bits))
    }

    fn lanes(f: impl Fn(usize) -> f32) -> [f32; 8] {
        std::array::from_fn(f)
    }

    /// Eight rays in lockstep; lanes without a chord have n = 0.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn march(fr: &Frame, rays: &[Chord; 8], out: &mut [[f32; 4]; 8]) -> u64 {
        let p = &fr.p;
        let ld = |a: [f32; 8]| _mm256_loadu_ps(a.as_ptr());
        // Voxel coordinates at the chord's start and per unit of ray parameter.
        let start: [[f32; 3]; 8] = std::array::from_fn(|l| {
            let c = &rays[l];
            voxel_coords(fr, std::array::from_fn(|k| c.o[k] + c.d[k] * c.t0))
        });
        let per: [[f32; 3]; 8] = std::array::from_fn(|l| {
            std::array::from_fn(|k| rays[l].d[k] * p.tex_scale[k] * fr.dims[k] as f32)
        });
        let u0: [__m256; 3] = std::array::from_fn(|k| ld(lanes(|l| start[l][k])));
        let du: [__m256; 3] = std::array::from_fn(|k| ld(lanes(|l| per[l][k])));
        let len = ld(lanes(|l| rays[l].len));
        let n = ld(lanes(|l| rays[l].n as f32));
        let [d0, d1, d2] = fr.dims;
        let hi: [__m256i; 3] = [d0, d1, d2].map(|d| _mm256_set1_epi32(d as i32 - 1));
        // Float offsets of one step along each numpy axis.
        let stride = [_mm256_set1_epi32((4 * d1 * d2) as i32), _mm256_set1_epi32((4 * d2) as i32), _mm256_set1_epi32(4)];
        let (zero, one, zi, onei) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0), _mm256_setzero_si256(), _mm256_set1_epi32(1));
        let h = _mm256_set1_ps(p.step_size);
        let scale = _mm256_set1_ps((fr.lut.len() - 1) as f32);
        let last = _mm256_set1_epi32(fr.lut.len() as i32 - 2);
        let lit = p.light_valid == 1;
        let ldir: [__m256; 3] = std::array::from_fn(|k| _mm256_set1_ps(p.light_dir[k]));
        let (amb, dif) = (_mm256_set1_ps(p.ambient), _mm256_set1_ps(p.diffuse));
        let vp = fr.texels.as_ptr() as *const f32;
        let lp = fr.lut.as_ptr() as *const f32;
        let mut i = zero;
        let mut active = _mm256_cmp_ps::<_CMP_LT_OQ>(i, n);
        let mut color = [zero; 3];
        let mut color_b = [zero; 3];
        let (mut tau, mut tau_b, mut trans) = (zero, zero, one);
        let mut steps = 0u32;
        let mut taken = 0u64;
        while _mm256_movemask_ps(active) != 0 {
            taken += _mm256_movemask_ps(active).count_ones() as u64;
            let a = _mm256_mul_ps(i, h);
            let seg = _mm256_max_ps(_mm256_min_ps(h, _mm256_sub_ps(len, a)), zero);
            let mid = _mm256_fmadd_ps(seg, _mm256_set1_ps(0.5), a);
            let mut w = [zero; 3];
            let mut offs = [[zi; 2]; 3];
            for k in 0..3 {
                let u = _mm256_fmadd_ps(du[k], mid, u0[k]);
                let fl = _mm256_floor_ps(u);
                w[k] = _mm256_sub_ps(u, fl);
                let base = _mm256_cvttps_epi32(fl);
                let clamp = |v: __m256i| _mm256_min_epi32(_mm256_max_epi32(v, zi), hi[k]);
                offs[k] = [
                    _mm256_mullo_epi32(clamp(base), stride[k]),
                    _mm256_mullo_epi32(clamp(_mm256_add_epi32(base, onei)), stride[k]),
                ];
            }
            let mut texel = [zero; 4];
            for ch in 0..4 {
                let chi = _mm256_set1_epi32(ch as i32);
                let mut planes = [zero; 2];
                for (pi, o0) in offs[0].iter().enumerate() {
                    let mut rows = [zero; 2];
                    for (ri, o1) in offs[1].iter().enumerate() {
                        let b = _mm256_add_epi32(_mm256_add_epi32(*o0, *o1), chi);
                        let x0 = _mm256_i32gather_ps::<4>(vp, _mm256_add_epi32(b, offs[2][0]));
                        let x1 = _mm256_i32gather_ps::<4>(vp, _mm256_add_epi32(b, offs[2][1]));
                        rows[ri] = _mm256_fmadd_ps(_mm256_sub_ps(x1, x0), w[2], x0);
                    }
                    planes[pi] = _mm256_fmadd_ps(_mm256_sub_ps(rows[1], rows[0]), w[1], rows[0]);
                }
                texel[ch] = _mm256_fmadd_ps(_mm256_sub_ps(planes[1], planes[0]), w[0], planes[0]);
            }
            let v = _mm256_fmadd_ps(texel[0], _mm256_set1_ps(p.value_scale), _mm256_set1_ps(p.value_offset));
            let xl = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(v, zero), one), scale);
            let k = _mm256_min_epi32(_mm256_cvttps_epi32(xl), last);
            let t = _mm256_sub_ps(xl, _mm256_cvtepi32_ps(k));
            let k4 = _mm256_slli_epi32::<2>(k);
            let rgba: [__m256; 4] = std::array::from_fn(|ch| {
                let at = _mm256_add_epi32(k4, _mm256_set1_epi32(ch as i32));
                let e0 = _mm256_i32gather_ps::<4>(lp, at);
                let e1 = _mm256_i32gather_ps::<4>(lp, _mm256_add_epi32(at, _mm256_set1_epi32(4)));
                _mm256_fmadd_ps(_mm256_sub_ps(e1, e0), t, e0)
            });
            let x = _mm256_min_ps(_mm256_mul_ps(_mm256_mul_ps(rgba[3], seg), _mm256_set1_ps(p.inv_ref)), _mm256_set1_ps(1e30));
            let visible = _mm256_and_ps(
                _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(rgba[3], zero), _mm256_cmp_ps::<_CMP_GT_OQ>(seg, zero)),
                active,
            );
            let x = _mm256_and_ps(x, visible);
            // 1 - e^-x, by its series below 1e-3 as in the shader.
            let series = _mm256_mul_ps(x, _mm256_fnmadd_ps(x, _mm256_fnmadd_ps(x, _mm256_set1_ps(1.0 / 6.0), _mm256_set1_ps(0.5)), one));
            let absorbed = _mm256_blendv_ps(
                _mm256_sub_ps(one, exp_nonpositive(_mm256_sub_ps(zero, x))),
                series,
                _mm256_cmp_ps::<_CMP_LT_OQ>(x, _mm256_set1_ps(1e-3)),
            );
            let mut light = amb;
            if lit {
                let nn = _mm256_fmadd_ps(texel[1], texel[1], _mm256_fmadd_ps(texel[2], texel[2], _mm256_mul_ps(texel[3], texel[3])));
                let nl = _mm256_fmadd_ps(texel[1], ldir[0], _mm256_fmadd_ps(texel[2], ldir[1], _mm256_mul_ps(texel[3], ldir[2])));
                let cos = _mm256_max_ps(_mm256_div_ps(nl, _mm256_sqrt_ps(nn)), zero);
                light = _mm256_blendv_ps(amb, _mm256_fmadd_ps(dif, cos, amb), _mm256_cmp_ps::<_CMP_GT_OQ>(nn, zero));
            }
            let weight = _mm256_and_ps(_mm256_mul_ps(_mm256_mul_ps(trans, absorbed), light), visible);
            for ch in 0..3 {
                color_b[ch] = _mm256_fmadd_ps(weight, rgba[ch], color_b[ch]);
            }
            tau_b = _mm256_add_ps(tau_b, x);
            steps += 1;
            if steps & 255 == 0 {
                tau = _mm256_add_ps(tau, tau_b);
                tau_b = zero;
                for ch in 0..3 {
                    color[ch] = _mm256_add_ps(color[ch], color_b[ch]);
                    color_b[ch] = zero;
                }
            }
            let total = _mm256_add_ps(tau, tau_b);
            trans = _mm256_blendv_ps(trans, exp_nonpositive(_mm256_sub_ps(zero, total)), active);
            i = _mm256_add_ps(i, one);
            let stop = _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_sub_ps(one, trans), _mm256_set1_ps(p.threshold)),
                _mm256_cmp_ps::<_CMP_LT_OQ>(trans, _mm256_set1_ps(1e-30)),
            );
            active = _mm256_andnot_ps(stop, _mm256_and_ps(active, _mm256_cmp_ps::<_CMP_LT_OQ>(i, n)));
        }
        let mut rows = [[0f32; 8]; 5];
        for ch in 0..3 {
            _mm256_storeu_ps(rows[ch].as_mut_ptr(), _mm256_add_ps(color[ch], color_b[ch]));
        }
        _mm256_storeu_ps(rows[3].as_mut_ptr(), _mm256_add_ps(tau, tau_b));
        _mm256_storeu_ps(rows[4].as_mut_ptr(), trans);
        for l in 0..8 {
            let alpha = if rows[4][l] < 1e-30 { 1.0 } else { one_minus_exp_neg(rows[3][l]) };
            out[l] = [rows[0][l], rows[1][l], rows[2][l], if rays[l].n == 0 { 0.0 } else { alpha }];
        }
        taken
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Engine {
    Scalar,
    Avx2,
}

/// Renders on every core in tiles of 8x8 pixels handed out in turn (each
/// tile's rows in order on one core, so that each row finds the last one's
/// voxels in its cache); returns the image (row 0 at the bottom, as the GPU's) and
/// the samples taken.
fn native(f: &Frame, engine: Engine) -> (Vec<[f32; 4]>, u64) {
    let (w, h) = (f.p.width as usize, f.p.height as usize);
    let (tiles_x, tiles) = (w.div_ceil(8), w.div_ceil(8) * h.div_ceil(8));
    let next = AtomicUsize::new(0);
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    let parts: Vec<(Vec<(usize, [f32; 4])>, u64)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let (mut px, mut samples) = (Vec::new(), 0u64);
                    loop {
                        let tile = next.fetch_add(1, Ordering::Relaxed);
                        if tile >= tiles {
                            return (px, samples);
                        }
                        let x0 = (tile % tiles_x) * 8;
                        for row in (tile / tiles_x) * 8..((tile / tiles_x) * 8 + 8).min(h) {
                        let rays: [Chord; 8] = std::array::from_fn(|l| {
                            if x0 + l < w { chord(&f.p, (x0 + l) as u32, row as u32).unwrap_or_default() } else { Chord::default() }
                        });
                        let mut out = [[0f32; 4]; 8];
                        match engine {
                            #[cfg(target_arch = "x86_64")]
                            Engine::Avx2 => samples += unsafe { avx2::march(f, &rays, &mut out) },
                            _ => {
                                for l in 0..8 {
                                    if rays[l].n > 0 {
                                        let (c, k) = unsafe { march_scalar(f, &rays[l]) };
                                        out[l] = c;
                                        samples += k as u64;
                                    }
                                }
                            }
                        }
                        for (l, c) in out.into_iter().enumerate().filter(|(l, _)| x0 + l < w) {
                            px.push((row * w + x0 + l, c));
                        }
                        }
                    }
                })
            })
            .collect();
        workers.into_iter().map(|t| t.join().expect("worker panicked")).collect()
    });
    let mut img = vec![[0f32; 4]; w * h];
    let mut samples = 0;
    for (px, s) in parts {
        samples += s;
        for (i, c) in px {
            img[i] = c;
        }
    }
    (img, samples)
}

/// Median of 3 timed runs after a warm-up.
fn timed<T>(mut run: impl FnMut() -> T) -> (T, f64) {
    let mut out = run();
    let mut ms = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        out = run();
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    (out, ms[1])
}

fn main() {
    // `cargo bench` adds `--bench`; only the numbers are ours.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let size: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(512);
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(256);
    // pyvr's double_sphere and its normals (central differences).
    let c = |a: usize| -1.0 + 2.0 * a as f64 / (n - 1) as f64;
    let value = |i: usize, j: usize, k: usize| {
        let (x, y, z) = (c(i), c(j), c(k));
        let r1 = ((x - 0.3).powi(2) + y * y + z * z).sqrt();
        let r2 = ((x + 0.3).powi(2) + y * y + z * z).sqrt();
        (-(4.0 * r1).powi(2)).exp().max((-(4.0 * r2).powi(2)).exp()) as f32
    };
    let mut data = Vec::with_capacity(n * n * n);
    let mut normals = Vec::with_capacity(3 * n * n * n);
    let at = |i: usize, j: usize, k: usize, a: usize, s: isize| {
        let mut q = [i as isize, j as isize, k as isize];
        q[a] = (q[a] + s).clamp(0, n as isize - 1);
        value(q[0] as usize, q[1] as usize, q[2] as usize)
    };
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                data.push(value(i, j, k));
                normals.extend((0..3).map(|a| at(i, j, k, a, 1) - at(i, j, k, a, -1)));
            }
        }
    }
    let bounds = Bounds::new(DVec3::splat(-1.0), DVec3::splat(1.0)).expect("a valid box");
    let vol = VolumeView::new([n, n, n], Voxels::F32(&data), Some(&normals), bounds).expect("a valid volume");
    let lut: Vec<[f32; 4]> = (0..256)
        .map(|i| {
            let s = i as f32 / 255.0;
            [s, 0.5 * s, 1.0 - s, 0.1 * s]
        })
        .collect();
    let camera = Camera { position: DVec3::new(1.8371, 1.8371, 1.5), target: DVec3::ZERO, up: DVec3::Z, fov_y: std::f64::consts::FRAC_PI_4 };
    let light = Light::default();
    let cfg = RenderConfig::default();

    let mut gpu = GpuRenderer::new(size, size).expect("a device");
    // The native marches sample every step: so does the GPU path here.
    gpu.skip_empty = false;
    gpu.set_volume(&vol).expect("upload");
    gpu.set_lut(&lut).expect("table");
    let ((gpu_img, stats), gpu_ms) = timed(|| gpu.render(&camera, &light, &cfg).expect("a frame"));
    let inputs = FrameInputs {
        bounds,
        dims: [n, n, n],
        width: size,
        height: size,
        lut_size: lut.len() as u32,
        value_map: ValueMap::IDENTITY,
        clip: None,
        max_extinction: 0.1,
    };
    let basis = camera.basis(size, size).expect("a camera");
    let texels = data
        .iter()
        .zip(normals.chunks_exact(3))
        .map(|(&v, g)| {
            let l = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            if l > 0.0 { [v, g[0] / l, g[1] / l, g[2] / l] } else { [v, 0.0, 0.0, 0.0] }
        })
        .collect();
    let frame = Frame { texels, dims: [n, n, n], lut, p: Params::new(&inputs, &basis, &light, &cfg) };

    println!("{size}x{size}, {n}^3 double sphere with normals, balanced, {} threads", std::thread::available_parallelism().map_or(1, |t| t.get()));
    let per = |ms: f64, s: u64| ms * 1e6 / s as f64;
    let gpu_ns = per(gpu_ms, stats.samples);
    println!("{:8} {:>9} {:>10} {:>10} {:>12} {:>22}", "engine", "ms", "samples M", "ns/sample", "vs GPU path", "max diff vs GPU, levels");
    println!("{:8} {:9.1} {:10.2} {:10.2} {:>12} {:>22}", "gpu", gpu_ms, stats.samples as f64 / 1e6, gpu_ns, "1.00x", "-");
    // Rows for benches/native_march.py, which stamps them into a docs table.
    let row = |name: &str, ms: f64, samples: u64, ns: f64, diff: String| {
        format!("[\"{name}\", {ms:.1}, {:.2}, {ns:.2}, {:.2}, {diff}]", samples as f64 / 1e6, gpu_ns / ns)
    };
    let mut rows = vec![row("gpu path", gpu_ms, stats.samples, gpu_ns, "\"-\"".into())];
    // Both marches are compiled for AVX2 and FMA on x86-64 (the scalar one
    // for its floor and fused multiply-adds).
    #[cfg(target_arch = "x86_64")]
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        println!("this CPU has no AVX2 and FMA: the native marches are not measured");
        return;
    }
    let mut engines = vec![("scalar", Engine::Scalar)];
    if cfg!(target_arch = "x86_64") {
        engines.push(("avx2", Engine::Avx2));
    }
    for (name, engine) in engines {
        let ((img, samples), ms) = timed(|| native(&frame, engine));
        let diff = img
            .iter()
            .flatten()
            .zip(gpu_img.iter())
            .map(|(a, b)| (a - b).abs() * 255.0)
            .fold(0f32, f32::max);
        let ns = per(ms, samples);
        println!(
            "{name:8} {ms:9.1} {:10.2} {ns:10.2} {:>11.2}x {diff:22.4}",
            samples as f64 / 1e6,
            gpu_ns / ns
        );
        assert!(diff <= 0.05, "{name}: differs from the GPU image by {diff} levels: not the same rule");
        rows.push(row(name, ms, samples, ns, format!("{diff:.4}")));
    }
    if let Some(path) = std::env::var_os("NATIVE_MARCH_JSON") {
        let device = gpu.context().describe().replace('\\', "/").replace('"', "'");
        let json = format!("{{\"device\": \"{device}\", \"rows\": [{}]}}\n", rows.join(", "));
        std::fs::write(&path, json).expect("writing the rows");
    }
}
