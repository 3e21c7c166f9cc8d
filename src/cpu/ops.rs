//! Operations on eight lanes that the march's stages share: exponentials
//! and logarithms, the transfer function's lookup, lanes to arrays, and
//! the end of a row's rays.

use super::sampling::*;
use super::{Stats, TILE};
use std::arch::x86_64::*;

/// e^x for x <= 0 (2^(x log2 e), degree-6 polynomial): relative error
/// ~2e-7; below -87 it returns ~1.6e-38, under the 1e-30 at which a ray
/// stops with transmittance 0, as the shader's exp underflows to.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn exp_nonpositive(x: __m256) -> __m256 {
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

/// The transfer function's table (entries at scalars m / (M - 1), M >= 2)
/// interpolated at eight values, clamped to [0, 1].
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn lut_rgba(lut: &[[f32; 4]], v: __m256) -> [__m256; 4] {
    let m = lut.len();
    let xl = _mm256_mul_ps(
        _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), _mm256_set1_ps(1.0)),
        _mm256_set1_ps((m - 1) as f32),
    );
    let k = _mm256_min_epi32(_mm256_cvttps_epi32(xl), _mm256_set1_epi32(m as i32 - 2));
    let t = _mm256_sub_ps(xl, _mm256_cvtepi32_ps(k));
    // Each ray's entries k and k + 1 in one 256-bit load.
    let (k, t) = (int_lanes(k), lanes(t));
    let base = lut.as_ptr() as *const f32;
    let rays: [__m128; 8] = std::array::from_fn(|l| {
        // SAFETY: 0 <= k <= M - 2, so both entries lie in the table.
        let e = unsafe { _mm256_loadu_ps(base.add(4 * k[l] as usize)) };
        let (e0, e1) = (_mm256_castps256_ps128(e), _mm256_extractf128_ps::<1>(e));
        _mm_fmadd_ps(_mm_sub_ps(e1, e0), _mm_set1_ps(t[l]), e0)
    });
    transpose_rays(&rays)
}

/// -ln(1 - a) for opacities a in [0, 1], the power form's extinction
/// (compositing.wgsl `extinction`): its series below 1e-3, 1e30 from 1 up.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn neg_log_one_minus(a: __m256) -> __m256 {
    let one = _mm256_set1_ps(1.0);
    let series = _mm256_fmadd_ps(a, _mm256_set1_ps(1.0 / 3.0), _mm256_set1_ps(0.5));
    let series = _mm256_mul_ps(a, _mm256_fmadd_ps(a, series, one));
    // Clamped to a normal number; lanes at 1 and up are replaced.
    let ln_y = ln(_mm256_max_ps(_mm256_sub_ps(one, a), _mm256_set1_ps(f32::MIN_POSITIVE)));
    let full = _mm256_sub_ps(_mm256_setzero_ps(), ln_y);
    let x = _mm256_blendv_ps(full, series, _mm256_cmp_ps::<_CMP_LT_OQ>(a, _mm256_set1_ps(1e-3)));
    _mm256_blendv_ps(x, _mm256_set1_ps(1.0e30), _mm256_cmp_ps::<_CMP_GE_OQ>(a, one))
}

/// ln y for normal y > 0: y = m 2^e, m in [sqrt(1/2), sqrt(2)), is e ln 2
/// plus 2 atanh((m - 1) / (m + 1)) to its f^9 term (|f| <= 0.172, the next
/// term ~4e-10): relative error ~1e-7.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn ln(y: __m256) -> __m256 {
    let one = _mm256_set1_ps(1.0);
    let bits = _mm256_castps_si256(y);
    // The exponent taken about sqrt(1/2), so that m lands in [sqrt(1/2), sqrt(2)).
    let shifted = _mm256_sub_epi32(bits, _mm256_set1_epi32(0x3f35_04f3));
    let e = _mm256_srai_epi32::<23>(shifted);
    let m = _mm256_castsi256_ps(_mm256_sub_epi32(bits, _mm256_slli_epi32::<23>(e)));
    let f = _mm256_div_ps(_mm256_sub_ps(m, one), _mm256_add_ps(m, one));
    let f2 = _mm256_mul_ps(f, f);
    let mut poly = _mm256_set1_ps(1.0 / 9.0);
    for c in [1.0 / 7.0, 1.0 / 5.0, 1.0 / 3.0, 1.0] {
        poly = _mm256_fmadd_ps(poly, f2, _mm256_set1_ps(c));
    }
    let ln_m = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(2.0), f), poly);
    _mm256_fmadd_ps(_mm256_cvtepi32_ps(e), _mm256_set1_ps(std::f32::consts::LN_2), ln_m)
}

/// 1 - e^-x for x >= 0, by its series below 1e-3 (compositing.wgsl).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn one_minus_exp_neg(x: __m256) -> __m256 {
    let one = _mm256_set1_ps(1.0);
    let series =
        _mm256_mul_ps(x, _mm256_fnmadd_ps(x, _mm256_fnmadd_ps(x, _mm256_set1_ps(1.0 / 6.0), _mm256_set1_ps(0.5)), one));
    let full = _mm256_sub_ps(one, exp_nonpositive(_mm256_sub_ps(_mm256_setzero_ps(), x)));
    _mm256_blendv_ps(full, series, _mm256_cmp_ps::<_CMP_LT_OQ>(x, _mm256_set1_ps(1e-3)))
}

/// The eight lanes of a register.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn lanes(x: __m256) -> [f32; 8] {
    let mut out = [0f32; 8];
    // SAFETY: an unaligned store of eight floats into eight.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
    out
}

/// The eight lanes of an integer register.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn int_lanes(x: __m256i) -> [i32; 8] {
    let mut out = [0i32; 8];
    // SAFETY: an unaligned store of eight integers into eight.
    unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, x) };
    out
}

/// All bits set in lane l where bit l of `bits` is (a brick's stopped rays).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn lanes_of(bits: u8) -> __m256 {
    let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), bit), bit))
}

/// Channel `c` of eight pixels (a brick's ray states), one a lane.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn channel(px: &[[f32; 4]; TILE], c: usize) -> __m256 {
    // SAFETY: an unaligned load of eight floats.
    unsafe { _mm256_loadu_ps(std::array::from_fn::<f32, 8, _>(|l| px[l][c]).as_ptr()) }
}

/// Whether a brick's march reports lane l's ray as cut short by max_steps:
/// the brick holds the ray's last segment (its window [lo, hi) is not empty
/// and ends at n), the ray has not stopped, and it needed more than n.
pub(super) fn truncated_here(lo: i32, hi: i32, n: i32, needed: u32, stopped: bool) -> bool {
    !stopped && lo < hi && hi == n && (n as u32) < needed
}

/// How eight rays leave a march (`march`, `track`, `projection::project`):
/// their samples (`taken`) and rays cut short by max_steps go into the
/// statistics, and each lane with a ray gets `result(l)` in `out`. For a
/// whole frame that is its pixel, and lanes without a ray are transparent.
/// For a brick (`stopped_before` given) it is the ray's state for the next
/// brick, rays that stopped in an earlier brick keep theirs, and the lanes
/// whose rays stop here (`stopped`) join `stopped_before`.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn leave_row(
    rays: &super::rays8::Rays,
    taken: __m256i,
    stopped: __m256,
    out: &mut [[f32; 4]; TILE],
    mut stopped_before: Option<&mut u8>,
    result: impl Fn(usize) -> [f32; 4],
) -> Stats {
    let (counts, steps, needed) = (int_lanes(taken), int_lanes(rays.n), lanes(rays.needed));
    let (lo, hi) = (int_lanes(rays.lo), int_lanes(rays.hi));
    let (hits, stopped) = (_mm256_movemask_ps(rays.hit), _mm256_movemask_ps(stopped));
    let earlier = stopped_before.as_deref().copied();
    let mut stats = Stats::default();
    for l in 0..TILE {
        if hits & (1 << l) == 0 || earlier.is_some_and(|e| e & (1 << l) != 0) {
            if earlier.is_none() {
                out[l] = [0.0; 4];
            }
            continue;
        }
        stats.samples += counts[l] as u64;
        let was_stopped = stopped & (1 << l) != 0;
        // (`as u32` saturates, as the scalar rule's conversion does.)
        let want = needed[l] as u32;
        let truncated = match earlier {
            Some(_) => truncated_here(lo[l], hi[l], steps[l], want, was_stopped),
            None => !was_stopped && (steps[l] as u32) < want,
        };
        if truncated {
            stats.truncated_needed = stats.truncated_needed.max(want);
        }
        out[l] = result(l);
        if let Some(before) = stopped_before.as_deref_mut() {
            *before |= (was_stopped as u8) << l;
        }
    }
    stats
}

#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn dot3(a: &[__m256; 3], b: &[__m256; 3]) -> __m256 {
    _mm256_fmadd_ps(a[0], b[0], _mm256_fmadd_ps(a[1], b[1], _mm256_mul_ps(a[2], b[2])))
}

#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn abs(x: __m256) -> __m256 {
    _mm256_andnot_ps(_mm256_set1_ps(-0.0), x)
}
