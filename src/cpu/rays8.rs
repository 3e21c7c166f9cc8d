//! The eight rays of a row of a tile, built in the lanes of AVX2 registers.
//!
//! A frame builds one ray per pixel, and built one at a time (a square root
//! and a dozen divisions in a chain) that took about as long as marching a
//! small scene's samples. Here every operation is the scalar rule's
//! (`super::Ray`, which the test below holds these lanes to bit for bit) on
//! eight pixels at once, in the same order and without fused multiply-adds.

use super::{Frame, TILE};
use std::arch::x86_64::*;

/// Lane l holds pixel (col0 + l, row)'s ray; lanes without one (off the
/// image or missing the box) have an empty window and zero geometry.
pub struct Rays {
    /// Where each ray starts: the camera, or for parallel rays a point of
    /// the camera's plane.
    pub o: [__m256; 3],
    pub d: [__m256; 3],
    pub t0: __m256,
    pub chord: __m256,
    pub shift: __m256,
    pub n: __m256i,
    /// The steps each ray needs (as a float: up to 4e9).
    pub needed: __m256,
    /// Segments [lo, hi) are marched.
    pub lo: __m256i,
    pub hi: __m256i,
    /// All bits set where the lane has a ray.
    pub hit: __m256,
}

/// model::hash32 in eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub fn hash32(mut x: __m256i) -> __m256i {
    x = _mm256_xor_si256(x, _mm256_srli_epi32::<16>(x));
    x = _mm256_mullo_epi32(x, _mm256_set1_epi32(0x7feb_352d));
    x = _mm256_xor_si256(x, _mm256_srli_epi32::<15>(x));
    x = _mm256_mullo_epi32(x, _mm256_set1_epi32(0x846c_a68b_u32 as i32));
    _mm256_xor_si256(x, _mm256_srli_epi32::<16>(x))
}

/// model::jitter_shift in eight lanes.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn jitter_shift(cols: __m256i, row: u32, seed: u32) -> __m256 {
    let inner = crate::model::hash32(row ^ crate::model::hash32(seed));
    let h = hash32(_mm256_xor_si256(cols, _mm256_set1_epi32(inner as i32)));
    let unit = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(h)), _mm256_set1_ps(1.0 / 16_777_216.0));
    _mm256_xor_ps(unit, _mm256_set1_ps(-0.0))
}

/// The rays of pixels col0..col0 + 8 of `row`.
///
/// # Safety
/// Needs AVX2, FMA and F16C.
#[target_feature(enable = "avx2,fma,f16c")]
pub unsafe fn rays(frame: &Frame, col0: u32, row: u32) -> Rays {
    let p = frame.params;
    let set = _mm256_set1_ps;
    let (zero, one) = (_mm256_setzero_ps(), set(1.0));
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let cols = _mm256_add_epi32(_mm256_set1_epi32(col0 as i32), lane);
    let in_image = _mm256_cmpgt_epi32(_mm256_set1_epi32(p.width.min(i32::MAX as u32) as i32), cols);
    let mut hit = _mm256_castsi256_ps(in_image);
    // (2x + 1 - W) / W, as the shader (main.wgsl): an exact numerator.
    let w = set(p.width as f32);
    let ndc_x = _mm256_div_ps(_mm256_sub_ps(_mm256_fmadd_ps(set(2.0), _mm256_cvtepi32_ps(cols), one), w), w);
    let ndc_y = set((2.0 * row as f32 + 1.0 - p.height as f32) / p.height as f32);
    // (pos + X right) + Y up, or fwd + X right + Y up normalised: the scalar rule's order.
    let across = |base: &[f32; 4], a: usize| {
        _mm256_add_ps(
            _mm256_add_ps(set(base[a]), _mm256_mul_ps(ndc_x, set(p.cam_right[a]))),
            _mm256_mul_ps(ndc_y, set(p.cam_up[a])),
        )
    };
    let (o, d): ([__m256; 3], [__m256; 3]) = if p.orthographic == 1 {
        (std::array::from_fn(|a| across(&p.cam_pos, a)), std::array::from_fn(|a| set(p.cam_fwd[a])))
    } else {
        let d: [__m256; 3] = std::array::from_fn(|a| across(&p.cam_fwd, a));
        let len = _mm256_sqrt_ps(_mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])),
            _mm256_mul_ps(d[2], d[2]),
        ));
        (std::array::from_fn(|a| set(p.cam_pos[a])), d.map(|c| _mm256_div_ps(c, len)))
    };
    let (mut t0, mut t1) = (set(-3.0e38), set(3.0e38));
    for a in 0..3 {
        // A ray parallel to an axis's planes meets the box only from between them.
        let flat = _mm256_cmp_ps::<_CMP_EQ_OQ>(d[a], zero);
        let (lo, hi) = (set(p.clip_lo[a]), set(p.clip_hi[a]));
        let beyond = _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(o[a], lo), _mm256_cmp_ps::<_CMP_GT_OQ>(o[a], hi));
        hit = _mm256_andnot_ps(_mm256_and_ps(flat, beyond), hit);
        let inv = _mm256_div_ps(one, d[a]);
        let ta = _mm256_mul_ps(_mm256_sub_ps(lo, o[a]), inv);
        let tb = _mm256_mul_ps(_mm256_sub_ps(hi, o[a]), inv);
        t0 = _mm256_blendv_ps(_mm256_max_ps(_mm256_min_ps(ta, tb), t0), t0, flat);
        t1 = _mm256_blendv_ps(_mm256_min_ps(_mm256_max_ps(ta, tb), t1), t1, flat);
    }
    // Clip planes (main.wgsl): along the ray n . p + c is f0 + t (n . d).
    for q in &p.clip_planes[..p.clip_count as usize] {
        let f0 = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(set(q[0]), o[0]), _mm256_mul_ps(set(q[1]), o[1])),
                _mm256_mul_ps(set(q[2]), o[2]),
            ),
            set(q[3]),
        );
        let slope = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(set(q[0]), d[0]), _mm256_mul_ps(set(q[1]), d[1])),
            _mm256_mul_ps(set(q[2]), d[2]),
        );
        let at = _mm256_div_ps(_mm256_xor_ps(f0, set(-0.0)), slope);
        let rising = _mm256_cmp_ps::<_CMP_GT_OQ>(slope, zero);
        let falling = _mm256_cmp_ps::<_CMP_LT_OQ>(slope, zero);
        t0 = _mm256_blendv_ps(t0, _mm256_max_ps(t0, at), rising);
        t1 = _mm256_blendv_ps(t1, _mm256_min_ps(t1, at), falling);
        let along = _mm256_cmp_ps::<_CMP_EQ_OQ>(slope, zero);
        let outside = _mm256_cmp_ps::<_CMP_LT_OQ>(f0, zero);
        hit = _mm256_andnot_ps(_mm256_and_ps(along, outside), hit);
    }
    // An opaque surface stops each ray at its own depth.
    if let Some(depth) = frame.depth_in {
        let base = row as usize * p.width as usize;
        let at: [f32; 8] = std::array::from_fn(|l| {
            let col = col0 as usize + l;
            if col < p.width as usize {
                depth[base + col]
            } else {
                f32::INFINITY
            }
        });
        t1 = _mm256_min_ps(t1, _mm256_loadu_ps(at.as_ptr()));
    }
    let misses = _mm256_or_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(t0, t1), _mm256_cmp_ps::<_CMP_LE_OQ>(t1, zero));
    hit = _mm256_andnot_ps(misses, hit);
    // (max with the second operand 0 also reads NaN as 0, as f32::max does.)
    let t0 = _mm256_max_ps(t0, zero);
    let chord = _mm256_sub_ps(t1, t0);
    let shift = if frame.jitter { jitter_shift(cols, row, p.jitter_seed) } else { zero };
    let h = set(p.step_size);
    let needed = _mm256_min_ps(_mm256_ceil_ps(_mm256_sub_ps(_mm256_div_ps(chord, h), shift)), set(4.0e9));
    // Clamped to [0, 2^30] (exact in f32, at least max_steps) before the
    // integer conversion, as `as u32` saturates.
    let needed_i = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(needed, zero), set(super::MAX_STEPS as f32)));
    let hit_i = _mm256_castps_si256(hit);
    let n = _mm256_and_si256(_mm256_min_epi32(needed_i, _mm256_set1_epi32(p.max_steps as i32)), hit_i);
    let (lo, hi) = if p.bricked == 1 {
        let (lo, hi) = brick_window(p, &o, &d, t0, t1, shift, n);
        if frame.skip_empty && p.occupied_hi[3] == 1.0 {
            // Within the brick, only the window of its occupied cells.
            let (olo, ohi) = occupied_window(frame, &o, &d, t0, chord, shift, n);
            let (lo, hi) = (_mm256_max_epi32(lo, olo), _mm256_min_epi32(hi, ohi));
            let empty = _mm256_cmpgt_epi32(_mm256_add_epi32(lo, _mm256_set1_epi32(1)), hi);
            (_mm256_andnot_si256(empty, lo), _mm256_andnot_si256(empty, hi))
        } else {
            (lo, hi)
        }
    } else if frame.skip_empty && p.occupied_hi[3] == 1.0 {
        occupied_window(frame, &o, &d, t0, chord, shift, n)
    } else {
        (_mm256_setzero_si256(), n)
    };
    let keep = |x: __m256| _mm256_and_ps(x, hit);
    Rays {
        o: o.map(keep),
        d: d.map(keep),
        t0: keep(t0),
        chord: keep(chord),
        shift: keep(shift),
        n,
        needed: keep(needed),
        lo: _mm256_and_si256(lo, hit_i),
        hi: _mm256_and_si256(hi, hit_i),
        hit,
    }
}

/// main.wgsl `brick_window` (`super::Ray::brick_window`): the segments
/// whose nominal midpoints lie in the brick's core box, from the ray's
/// entry `t0` and exit `t1`; (0, 0) where there are none.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn brick_window(
    p: &crate::plan::params::Params,
    o: &[__m256; 3],
    d: &[__m256; 3],
    t0: __m256,
    t1: __m256,
    shift: __m256,
    n: __m256i,
) -> (__m256i, __m256i) {
    let set = _mm256_set1_ps;
    let zero = _mm256_setzero_ps();
    let (mut a0, mut a1, mut outside) = (t0, t1, zero);
    for a in 0..3 {
        let o = o[a];
        let (lo, hi) = (set(p.core_lo[a]), set(p.core_hi[a]));
        let flat = _mm256_cmp_ps::<_CMP_EQ_OQ>(d[a], zero);
        let beyond = _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(o, lo), _mm256_cmp_ps::<_CMP_GE_OQ>(o, hi));
        outside = _mm256_or_ps(outside, _mm256_and_ps(flat, beyond));
        let inv = _mm256_div_ps(set(1.0), d[a]);
        let ta = _mm256_mul_ps(_mm256_sub_ps(lo, o), inv);
        let tb = _mm256_mul_ps(_mm256_sub_ps(hi, o), inv);
        a0 = _mm256_blendv_ps(_mm256_max_ps(_mm256_min_ps(ta, tb), a0), a0, flat);
        a1 = _mm256_blendv_ps(_mm256_min_ps(_mm256_max_ps(ta, tb), a1), a1, flat);
    }
    outside = _mm256_or_ps(outside, _mm256_cmp_ps::<_CMP_NGT_UQ>(a1, a0));
    let nf = _mm256_cvtepi32_ps(n);
    // main.wgsl `segment_at`, clamped to the ray's n.
    let segment_at = |t: __m256| {
        let k = _mm256_ceil_ps(_mm256_sub_ps(
            _mm256_sub_ps(_mm256_div_ps(_mm256_sub_ps(t, t0), set(p.step_size)), shift),
            set(0.5),
        ));
        _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(k, zero), nf))
    };
    let lo = _mm256_and_si256(segment_at(a0), _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(a0, t0)));
    let hi = _mm256_blendv_epi8(n, segment_at(a1), _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(a1, t1)));
    // No segments here: the ray waits for its other bricks.
    let empty = _mm256_or_si256(
        _mm256_castps_si256(outside),
        _mm256_cmpgt_epi32(_mm256_add_epi32(lo, _mm256_set1_epi32(1)), hi),
    );
    (_mm256_andnot_si256(empty, lo), _mm256_andnot_si256(empty, hi))
}

/// skipping.wgsl `occupied_window` (`super::Ray::occupied_window`).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn occupied_window(
    frame: &Frame,
    o: &[__m256; 3],
    d: &[__m256; 3],
    t0: __m256,
    chord: __m256,
    shift: __m256,
    n: __m256i,
) -> (__m256i, __m256i) {
    let p = frame.params;
    let set = _mm256_set1_ps;
    let zero = _mm256_setzero_ps();
    let dims = frame.volume.dims;
    let (mut a, mut b, mut outside) = (zero, chord, zero);
    for k in 0..3 {
        // The block's boxes are in texture axis order: numpy axis k is texture axis 2 - k.
        let (lo, hi) = (set(p.occupied_lo[2 - k]), set(p.occupied_hi[2 - k]));
        let size = set(dims[k] as f32);
        let tc = _mm256_add_ps(
            _mm256_mul_ps(_mm256_add_ps(o[k], _mm256_mul_ps(d[k], t0)), set(p.tex_scale[k])),
            set(p.tex_offset[k]),
        );
        let u0 = _mm256_sub_ps(_mm256_mul_ps(tc, size), set(p.border as f32));
        let du = _mm256_mul_ps(_mm256_mul_ps(d[k], set(p.tex_scale[k])), size);
        let flat = _mm256_cmp_ps::<_CMP_EQ_OQ>(du, zero);
        let beyond = _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(u0, lo), _mm256_cmp_ps::<_CMP_GT_OQ>(u0, hi));
        outside = _mm256_or_ps(outside, _mm256_and_ps(flat, beyond));
        let ta = _mm256_div_ps(_mm256_sub_ps(lo, u0), du);
        let tb = _mm256_div_ps(_mm256_sub_ps(hi, u0), du);
        a = _mm256_blendv_ps(_mm256_max_ps(_mm256_min_ps(ta, tb), a), a, flat);
        b = _mm256_blendv_ps(_mm256_min_ps(_mm256_max_ps(ta, tb), b), b, flat);
    }
    outside = _mm256_or_ps(outside, _mm256_cmp_ps::<_CMP_NGE_UQ>(b, a));
    let h = set(p.step_size);
    let nf = _mm256_cvtepi32_ps(n);
    let clamp = |x: __m256| _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(x, zero), nf));
    // Steps from a segment's midpoint to the farthest of its points that count.
    let reach = if frame.preint.is_some() || frame.unbiased { 0.5 } else { 0.0 };
    let lo_f = _mm256_sub_ps(_mm256_sub_ps(_mm256_sub_ps(_mm256_div_ps(a, h), set(0.5 + reach)), shift), set(1e-3));
    let mut lo = clamp(_mm256_ceil_ps(lo_f));
    let hi_f = _mm256_add_ps(_mm256_sub_ps(_mm256_sub_ps(_mm256_div_ps(b, h), set(0.5 - reach)), shift), set(1e-3));
    let mut hi = clamp(_mm256_add_ps(_mm256_floor_ps(hi_f), set(1.0)));
    let onei = _mm256_set1_epi32(1);
    // A window starting at segment 0 or 1 starts at 0; one ending at the
    // last segment or the one before it ends at n.
    lo = _mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_add_epi32(onei, onei), lo), lo);
    let to_end = _mm256_cmpgt_epi32(_mm256_add_epi32(hi, _mm256_add_epi32(onei, onei)), n);
    hi = _mm256_blendv_epi8(hi, n, to_end);
    let inside = _mm256_castps_si256(_mm256_xor_ps(outside, _mm256_castsi256_ps(_mm256_set1_epi32(-1))));
    (_mm256_and_si256(lo, inside), _mm256_and_si256(hi, inside))
}

const _: () = assert!(TILE == 8, "eight rays fill an AVX2 register");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::test_rays::pick;
    use crate::cpu::{CpuVolume, Ray, Texels};
    use crate::plan::params::Params;

    /// Every lane equals the scalar rule's ray bit for bit, over cameras
    /// outside, inside and grazing the box, an axis-aligned one whose middle
    /// column's rays are parallel to two faces, parallel projections, crops,
    /// clip planes (one along some rays), jitter, truncation, occupied
    /// windows and bricks' windows.
    #[test]
    fn lanes_are_the_scalar_rays() {
        if !crate::cpu::avx2_available() {
            return;
        }
        let volume = CpuVolume { texels: Texels::R32Float(vec![0.0; 8]), dims: [11, 6, 8], normals: None };
        let mut k = 0u32;
        let (mut compared, mut missed, mut truncated, mut windowed) = (0, 0, 0, 0);
        let (mut bricked, mut outside) = (0, 0);
        for case in 0..84 {
            let v4 = |x: [f32; 3]| [x[0], x[1], x[2], 0.0];
            let mut p = Params { width: 37, height: 21, border: (case % 2), jitter_seed: case, ..Default::default() };
            let ext = [1.0, 0.6, 0.8];
            let pos: [f32; 3] = match case % 3 {
                0 => std::array::from_fn(|_| pick(&mut k, -1.5, 2.5)),
                1 => std::array::from_fn(|a| pick(&mut k, 0.1, ext[a] - 0.1)),
                _ => [0.5, 0.3, 3.0],
            };
            let target: [f32; 3] = std::array::from_fn(|a| pick(&mut k, 0.3, 0.7) * ext[a]);
            let towards = (glam::Vec3::from(target) - glam::Vec3::from(pos)).normalize().into();
            let fwd = if case % 3 == 2 { [0.0, 0.0, -1.0] } else { towards };
            let f = glam::Vec3::from(fwd);
            let right = f.cross(if f.z.abs() > 0.9 { glam::Vec3::Y } else { glam::Vec3::Z }).normalize();
            let up = right.cross(f);
            p.cam_pos = v4(pos);
            p.cam_fwd = v4(fwd);
            p.cam_right = v4((right * 0.6).into());
            p.cam_up = v4((up * 0.4).into());
            p.step_size = pick(&mut k, 0.003, 0.1);
            p.max_steps = if case % 4 == 0 { 7 } else { 100_000 };
            // Parallel rays from the camera's plane, its extents the same vectors'.
            p.orthographic = matches!(case % 7, 3 | 5) as u32;
            let crop = case % 5 == 0;
            p.clip_lo = v4(std::array::from_fn(|a| if crop { 0.2 * ext[a] } else { 0.0 }));
            p.clip_hi = v4(std::array::from_fn(|a| if crop { 0.9 * ext[a] } else { ext[a] }));
            // Clip planes: oblique ones through the box, and for the
            // axis-aligned camera one its middle column's rays run along.
            if case % 4 == 1 || case % 3 == 2 {
                let n = glam::Vec3::new(pick(&mut k, -1.0, 1.0), pick(&mut k, -1.0, 1.0), 0.5).normalize();
                p.clip_planes[0] = [n.x, n.y, n.z, -n.dot(glam::Vec3::from(target))];
                p.clip_planes[1] = if case % 3 == 2 { [1.0, 0.0, 0.0, -0.5] } else { [-n.y, n.x, 0.2, 0.1] };
                p.clip_count = 2;
            }
            p.tex_scale = v4(ext.map(|e| 1.0 / e));
            // Occupied voxels in texture axis order.
            p.occupied_lo = [1.5, 0.5, 2.0, 0.0];
            p.occupied_hi = [7.0, 5.0, 9.5, 1.0];
            // A brick's core box, whose faces on the volume's boundary lie far out.
            if matches!(case % 6, 1 | 2) {
                p.bricked = 1;
                let cut: [f32; 3] = std::array::from_fn(|a| pick(&mut k, 0.2, 0.8) * ext[a]);
                let upper = case % 12 < 6;
                p.core_lo = v4(std::array::from_fn(|a| if upper && a != 1 { cut[a] } else { -f32::MAX }));
                p.core_hi = v4(std::array::from_fn(|a| if upper && a != 1 { f32::MAX } else { cut[a] }));
            }
            let frame = crate::cpu::Frame {
                skip_empty: case % 2 == 0,
                jitter: case % 3 != 1,
                ..crate::cpu::test_rays::frame(&p, &volume)
            };
            for row in 0..p.height {
                for col0 in (0..p.width).step_by(TILE) {
                    // SAFETY: AVX2, FMA and F16C are available.
                    let r = unsafe { rays(&frame, col0, row) };
                    let lanes = |x: __m256| -> [u32; 8] { unsafe { std::mem::transmute(x) } };
                    let ints = |x: __m256i| -> [u32; 8] { unsafe { std::mem::transmute(x) } };
                    let hits = lanes(r.hit);
                    for l in 0..TILE {
                        let col = col0 + l as u32;
                        let want = if col < p.width { Ray::new(&frame, col, row) } else { None };
                        let Some(w) = want else {
                            assert_eq!(hits[l], 0, "case {case}, pixel ({col}, {row}) has no ray");
                            missed += 1;
                            continue;
                        };
                        assert_eq!(hits[l], u32::MAX, "case {case}, pixel ({col}, {row})");
                        let origin: [u32; 3] = std::array::from_fn(|a| lanes(r.o[a])[l]);
                        assert_eq!(origin, w.o.map(f32::to_bits), "case {case}, pixel ({col}, {row}) origin");
                        let got = (
                            std::array::from_fn::<u32, 3, _>(|a| lanes(r.d[a])[l]),
                            [lanes(r.t0)[l], lanes(r.chord)[l], lanes(r.shift)[l]],
                            (ints(r.n)[l], f32::from_bits(lanes(r.needed)[l]) as u32, (ints(r.lo)[l], ints(r.hi)[l])),
                        );
                        let geometry = [w.t0, w.chord, w.shift].map(f32::to_bits);
                        let expected = (w.d.map(f32::to_bits), geometry, (w.n, w.needed, w.window));
                        assert_eq!(got, expected, "case {case}, pixel ({col}, {row})");
                        compared += 1;
                        truncated += (w.n < w.needed) as u32;
                        windowed += (w.window != (0, w.n)) as u32;
                        bricked += (p.bricked == 1 && w.window.0 < w.window.1) as u32;
                        outside += (p.bricked == 1 && w.window == (0, 0) && w.n > 0) as u32;
                    }
                }
            }
        }
        // The cases reach every branch of the rule.
        let counts = format!("{compared} {missed} {truncated} {windowed} {bricked} {outside}");
        assert!(compared > 10_000 && missed > 1_000 && truncated > 1_000 && windowed > 1_000, "{counts}");
        assert!(bricked > 1_000 && outside > 500, "{counts}");
    }
}
