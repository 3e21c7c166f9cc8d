//! AVX2's operations on eight lanes, in portable Rust: the native march's
//! portable path (`portable`, made by build.rs from the AVX2 modules) takes
//! its intrinsics from here instead of `std::arch::x86_64`, so the same
//! march runs on any CPU (ARM, or x86-64 without AVX2). Each function does
//! what Intel's guide says its namesake does, lane by lane, NaN and
//! out-of-range cases included (`min`/`max` return the second operand when
//! either is NaN; float-to-int conversions give i32::MIN out of range):
//! the march relies on those rules. The compiler vectorises the lane loops
//! for the target's own registers (two NEON registers a value on ARM).

#![allow(non_camel_case_types, non_upper_case_globals, clippy::missing_safety_doc)]

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct __m256(pub [f32; 8]);
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct __m256i(pub [i32; 8]);
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct __m256d(pub [f64; 4]);
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct __m128(pub [f32; 4]);
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct __m128i(pub [i32; 4]);

pub const _CMP_EQ_OQ: i32 = 0x00;
pub const _CMP_NEQ_UQ: i32 = 0x04;
pub const _CMP_ORD_Q: i32 = 0x07;
pub const _CMP_NEQ_OQ: i32 = 0x0c;
pub const _CMP_LT_OQ: i32 = 0x11;
pub const _CMP_LE_OQ: i32 = 0x12;
pub const _CMP_NGE_UQ: i32 = 0x19;
pub const _CMP_NGT_UQ: i32 = 0x1a;
pub const _CMP_GE_OQ: i32 = 0x1d;
pub const _CMP_GT_OQ: i32 = 0x1e;
pub const _MM_FROUND_TO_NEAREST_INT: i32 = 0x00;
pub const _MM_FROUND_NO_EXC: i32 = 0x08;
pub const _MM_HINT_T0: i32 = 3;

const ALL: u32 = u32::MAX;

#[inline(always)]
fn map(a: __m256, f: impl Fn(f32) -> f32) -> __m256 {
    __m256(std::array::from_fn(|l| f(a.0[l])))
}

#[inline(always)]
fn zip(a: __m256, b: __m256, f: impl Fn(f32, f32) -> f32) -> __m256 {
    __m256(std::array::from_fn(|l| f(a.0[l], b.0[l])))
}

#[inline(always)]
fn bits(a: __m256) -> [u32; 8] {
    a.0.map(f32::to_bits)
}

#[inline(always)]
fn from_bits(b: [u32; 8]) -> __m256 {
    __m256(b.map(f32::from_bits))
}

#[inline(always)]
fn zip_bits(a: __m256, b: __m256, f: impl Fn(u32, u32) -> u32) -> __m256 {
    let (x, y) = (bits(a), bits(b));
    from_bits(std::array::from_fn(|l| f(x[l], y[l])))
}

#[inline(always)]
fn mapi(a: __m256i, f: impl Fn(i32) -> i32) -> __m256i {
    __m256i(std::array::from_fn(|l| f(a.0[l])))
}

#[inline(always)]
fn zipi(a: __m256i, b: __m256i, f: impl Fn(i32, i32) -> i32) -> __m256i {
    __m256i(std::array::from_fn(|l| f(a.0[l], b.0[l])))
}

#[inline(always)]
fn mask(m: bool) -> u32 {
    if m {
        ALL
    } else {
        0
    }
}

/// x86's conversion of an out-of-range or NaN float: the "integer indefinite".
#[inline(always)]
fn to_i32(x: f32) -> i32 {
    if (-2147483648.0..2147483648.0).contains(&x) {
        x as i32
    } else {
        i32::MIN
    }
}

// Setting.

#[inline(always)]
pub fn _mm256_set1_ps(x: f32) -> __m256 {
    __m256([x; 8])
}
#[inline(always)]
pub fn _mm256_setzero_ps() -> __m256 {
    __m256([0.0; 8])
}
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn _mm256_setr_ps(a: f32, b: f32, c: f32, d: f32, e: f32, f: f32, g: f32, h: f32) -> __m256 {
    __m256([a, b, c, d, e, f, g, h])
}
#[inline(always)]
pub fn _mm256_set1_epi32(x: i32) -> __m256i {
    __m256i([x; 8])
}
#[inline(always)]
pub fn _mm256_setzero_si256() -> __m256i {
    __m256i([0; 8])
}
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn _mm256_setr_epi32(a: i32, b: i32, c: i32, d: i32, e: i32, f: i32, g: i32, h: i32) -> __m256i {
    __m256i([a, b, c, d, e, f, g, h])
}
#[inline(always)]
pub fn _mm256_set_m128(hi: __m128, lo: __m128) -> __m256 {
    __m256([lo.0[0], lo.0[1], lo.0[2], lo.0[3], hi.0[0], hi.0[1], hi.0[2], hi.0[3]])
}

// Float arithmetic.

#[inline(always)]
pub fn _mm256_add_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| x + y)
}
#[inline(always)]
pub fn _mm256_sub_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| x - y)
}
#[inline(always)]
pub fn _mm256_mul_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| x * y)
}
#[inline(always)]
pub fn _mm256_div_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| x / y)
}
#[inline(always)]
pub fn _mm256_min_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| if x < y { x } else { y })
}
#[inline(always)]
pub fn _mm256_max_ps(a: __m256, b: __m256) -> __m256 {
    zip(a, b, |x, y| if x > y { x } else { y })
}
#[inline(always)]
pub fn _mm256_sqrt_ps(a: __m256) -> __m256 {
    map(a, f32::sqrt)
}
#[inline(always)]
pub fn _mm256_floor_ps(a: __m256) -> __m256 {
    map(a, f32::floor)
}
#[inline(always)]
pub fn _mm256_ceil_ps(a: __m256) -> __m256 {
    map(a, f32::ceil)
}
#[inline(always)]
pub fn _mm256_round_ps<const MODE: i32>(a: __m256) -> __m256 {
    match MODE & 3 {
        0 => map(a, f32::round_ties_even),
        1 => map(a, f32::floor),
        2 => map(a, f32::ceil),
        _ => map(a, f32::trunc),
    }
}
#[inline(always)]
pub fn _mm256_fmadd_ps(a: __m256, b: __m256, c: __m256) -> __m256 {
    __m256(std::array::from_fn(|l| a.0[l].mul_add(b.0[l], c.0[l])))
}
#[inline(always)]
pub fn _mm256_fmsub_ps(a: __m256, b: __m256, c: __m256) -> __m256 {
    __m256(std::array::from_fn(|l| a.0[l].mul_add(b.0[l], -c.0[l])))
}
#[inline(always)]
pub fn _mm256_fnmadd_ps(a: __m256, b: __m256, c: __m256) -> __m256 {
    __m256(std::array::from_fn(|l| (-a.0[l]).mul_add(b.0[l], c.0[l])))
}

// Comparisons, masks and bits of floats.

#[inline(always)]
pub fn _mm256_cmp_ps<const P: i32>(a: __m256, b: __m256) -> __m256 {
    let test = |x: f32, y: f32| match P {
        _CMP_EQ_OQ => x == y,
        _CMP_NEQ_UQ => !(x == y),
        _CMP_ORD_Q => !x.is_nan() && !y.is_nan(),
        _CMP_NEQ_OQ => x != y && !x.is_nan() && !y.is_nan(),
        _CMP_LT_OQ => x < y,
        _CMP_LE_OQ => x <= y,
        _CMP_NGE_UQ => !(x >= y),
        _CMP_NGT_UQ => !(x > y),
        _CMP_GE_OQ => x >= y,
        _CMP_GT_OQ => x > y,
        _ => unreachable!("comparison predicate {P} is not one the march uses"),
    };
    from_bits(std::array::from_fn(|l| mask(test(a.0[l], b.0[l]))))
}
#[inline(always)]
pub fn _mm256_and_ps(a: __m256, b: __m256) -> __m256 {
    zip_bits(a, b, |x, y| x & y)
}
#[inline(always)]
pub fn _mm256_or_ps(a: __m256, b: __m256) -> __m256 {
    zip_bits(a, b, |x, y| x | y)
}
#[inline(always)]
pub fn _mm256_xor_ps(a: __m256, b: __m256) -> __m256 {
    zip_bits(a, b, |x, y| x ^ y)
}
#[inline(always)]
pub fn _mm256_andnot_ps(a: __m256, b: __m256) -> __m256 {
    zip_bits(a, b, |x, y| !x & y)
}
#[inline(always)]
pub fn _mm256_blendv_ps(a: __m256, b: __m256, m: __m256) -> __m256 {
    let s = bits(m);
    __m256(std::array::from_fn(|l| if s[l] >> 31 != 0 { b.0[l] } else { a.0[l] }))
}
#[inline(always)]
pub fn _mm256_movemask_ps(a: __m256) -> i32 {
    bits(a).iter().enumerate().fold(0, |m, (l, &x)| m | ((x >> 31) as i32) << l)
}

// Conversions and reinterpretations.

#[inline(always)]
pub fn _mm256_castps_si256(a: __m256) -> __m256i {
    __m256i(bits(a).map(|x| x as i32))
}
#[inline(always)]
pub fn _mm256_castsi256_ps(a: __m256i) -> __m256 {
    from_bits(a.0.map(|x| x as u32))
}
#[inline(always)]
pub fn _mm256_castpd_ps(a: __m256d) -> __m256 {
    let b = a.0.map(f64::to_bits);
    from_bits(std::array::from_fn(|l| (b[l / 2] >> (32 * (l % 2))) as u32))
}
#[inline(always)]
pub fn _mm256_castsi256_si128(a: __m256i) -> __m128i {
    __m128i([a.0[0], a.0[1], a.0[2], a.0[3]])
}
#[inline(always)]
pub fn _mm256_castps256_ps128(a: __m256) -> __m128 {
    __m128([a.0[0], a.0[1], a.0[2], a.0[3]])
}
#[inline(always)]
pub fn _mm256_cvtepi32_ps(a: __m256i) -> __m256 {
    __m256(a.0.map(|x| x as f32))
}
#[inline(always)]
pub fn _mm256_cvttps_epi32(a: __m256) -> __m256i {
    __m256i(a.0.map(to_i32))
}
#[inline(always)]
pub fn _mm256_cvtps_epi32(a: __m256) -> __m256i {
    __m256i(a.0.map(|x| to_i32(x.round_ties_even())))
}
#[inline(always)]
pub fn _mm256_cvtph_ps(a: __m128i) -> __m256 {
    let h: [u16; 8] = bytemuck::cast(a.0);
    __m256(h.map(crate::half::f16_to_f32))
}
#[inline(always)]
pub fn _mm256_cvtepi8_epi32(a: __m128i) -> __m256i {
    let b: [i8; 16] = bytemuck::cast(a.0);
    __m256i(std::array::from_fn(|l| b[l] as i32))
}

// Integer arithmetic and bits.

#[inline(always)]
pub fn _mm256_add_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, i32::wrapping_add)
}
#[inline(always)]
pub fn _mm256_sub_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, i32::wrapping_sub)
}
#[inline(always)]
pub fn _mm256_mullo_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, i32::wrapping_mul)
}
#[inline(always)]
pub fn _mm256_min_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, i32::min)
}
#[inline(always)]
pub fn _mm256_max_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, i32::max)
}
#[inline(always)]
pub fn _mm256_cmpgt_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| -((x > y) as i32))
}
#[inline(always)]
pub fn _mm256_cmpeq_epi32(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| -((x == y) as i32))
}
#[inline(always)]
pub fn _mm256_and_si256(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| x & y)
}
#[inline(always)]
pub fn _mm256_or_si256(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| x | y)
}
#[inline(always)]
pub fn _mm256_xor_si256(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| x ^ y)
}
#[inline(always)]
pub fn _mm256_andnot_si256(a: __m256i, b: __m256i) -> __m256i {
    zipi(a, b, |x, y| !x & y)
}
#[inline(always)]
pub fn _mm256_srli_epi32<const N: i32>(a: __m256i) -> __m256i {
    mapi(a, |x| if N > 31 { 0 } else { ((x as u32) >> N) as i32 })
}
#[inline(always)]
pub fn _mm256_slli_epi32<const N: i32>(a: __m256i) -> __m256i {
    mapi(a, |x| if N > 31 { 0 } else { ((x as u32) << N) as i32 })
}
#[inline(always)]
pub fn _mm256_srai_epi32<const N: i32>(a: __m256i) -> __m256i {
    mapi(a, |x| x >> N.min(31))
}
/// The shift count: the low 64 bits of `count`.
#[inline(always)]
fn count_of(count: __m128i) -> u64 {
    count.0[0] as u32 as u64 | (count.0[1] as u32 as u64) << 32
}
#[inline(always)]
pub fn _mm256_srl_epi32(a: __m256i, count: __m128i) -> __m256i {
    let n = count_of(count);
    mapi(a, |x| if n > 31 { 0 } else { ((x as u32) >> n) as i32 })
}
#[inline(always)]
pub fn _mm256_sll_epi32(a: __m256i, count: __m128i) -> __m256i {
    let n = count_of(count);
    mapi(a, |x| if n > 31 { 0 } else { ((x as u32) << n) as i32 })
}
#[inline(always)]
pub fn _mm256_blendv_epi8(a: __m256i, b: __m256i, m: __m256i) -> __m256i {
    let (x, y, s): ([u8; 32], [u8; 32], [u8; 32]) = (bytemuck::cast(a.0), bytemuck::cast(b.0), bytemuck::cast(m.0));
    let picked: [u8; 32] = std::array::from_fn(|k| if s[k] >> 7 != 0 { y[k] } else { x[k] });
    __m256i(bytemuck::cast(picked))
}
#[inline(always)]
pub fn _mm256_movemask_epi8(a: __m256i) -> i32 {
    let b: [u8; 32] = bytemuck::cast(a.0);
    b.iter().enumerate().fold(0u32, |m, (k, &x)| m | ((x >> 7) as u32) << k) as i32
}

// Lanes moved about.

#[inline(always)]
pub fn _mm256_shuffle_ps<const IMM: i32>(a: __m256, b: __m256) -> __m256 {
    let s = |k: i32| ((IMM >> (2 * k)) & 3) as usize;
    __m256(std::array::from_fn(|l| {
        let (half, k) = (l / 4 * 4, (l % 4) as i32);
        if k < 2 {
            a.0[half + s(k)]
        } else {
            b.0[half + s(k)]
        }
    }))
}
#[inline(always)]
pub fn _mm256_unpacklo_ps(a: __m256, b: __m256) -> __m256 {
    let (a, b) = (a.0, b.0);
    __m256([a[0], b[0], a[1], b[1], a[4], b[4], a[5], b[5]])
}
#[inline(always)]
pub fn _mm256_unpackhi_ps(a: __m256, b: __m256) -> __m256 {
    let (a, b) = (a.0, b.0);
    __m256([a[2], b[2], a[3], b[3], a[6], b[6], a[7], b[7]])
}
#[inline(always)]
pub fn _mm256_permutevar8x32_epi32(a: __m256i, idx: __m256i) -> __m256i {
    __m256i(std::array::from_fn(|l| a.0[(idx.0[l] & 7) as usize]))
}
#[inline(always)]
pub fn _mm256_permutevar8x32_ps(a: __m256, idx: __m256i) -> __m256 {
    __m256(std::array::from_fn(|l| a.0[(idx.0[l] & 7) as usize]))
}
#[inline(always)]
pub fn _mm256_permute2f128_ps<const IMM: i32>(a: __m256, b: __m256) -> __m256 {
    let half = |c: i32| -> [f32; 4] {
        if c & 8 != 0 {
            return [0.0; 4];
        }
        let src = if c & 2 == 0 { &a.0 } else { &b.0 };
        let at = 4 * (c & 1) as usize;
        [src[at], src[at + 1], src[at + 2], src[at + 3]]
    };
    let (lo, hi) = (half(IMM & 0xF), half((IMM >> 4) & 0xF));
    __m256([lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]])
}
#[inline(always)]
pub fn _mm256_extracti128_si256<const I: i32>(a: __m256i) -> __m128i {
    let at = 4 * (I & 1) as usize;
    __m128i([a.0[at], a.0[at + 1], a.0[at + 2], a.0[at + 3]])
}
#[inline(always)]
pub fn _mm256_extractf128_ps<const I: i32>(a: __m256) -> __m128 {
    let at = 4 * (I & 1) as usize;
    __m128([a.0[at], a.0[at + 1], a.0[at + 2], a.0[at + 3]])
}

// Memory. Each function is unsafe as its namesake is: every address it
// reads or writes must be valid for the bytes it moves.

#[inline(always)]
pub unsafe fn _mm256_loadu_ps(p: *const f32) -> __m256 {
    unsafe { __m256(std::ptr::read_unaligned(p as *const [f32; 8])) }
}
#[inline(always)]
pub unsafe fn _mm256_storeu_ps(p: *mut f32, a: __m256) {
    unsafe { std::ptr::write_unaligned(p as *mut [f32; 8], a.0) }
}
#[inline(always)]
pub unsafe fn _mm256_loadu_si256(p: *const __m256i) -> __m256i {
    unsafe { __m256i(std::ptr::read_unaligned(p as *const [i32; 8])) }
}
#[inline(always)]
pub unsafe fn _mm256_storeu_si256(p: *mut __m256i, a: __m256i) {
    unsafe { std::ptr::write_unaligned(p as *mut [i32; 8], a.0) }
}
/// The byte `offset` from `base`, as a `T`.
#[inline(always)]
unsafe fn at<T: Copy>(base: *const u8, offset: i64) -> T {
    unsafe { std::ptr::read_unaligned(base.offset(offset as isize) as *const T) }
}
#[inline(always)]
pub unsafe fn _mm256_i32gather_ps<const S: i32>(base: *const f32, idx: __m256i) -> __m256 {
    __m256(std::array::from_fn(|l| unsafe { at(base as *const u8, idx.0[l] as i64 * S as i64) }))
}
#[inline(always)]
pub unsafe fn _mm256_i32gather_epi32<const S: i32>(base: *const i32, idx: __m256i) -> __m256i {
    __m256i(std::array::from_fn(|l| unsafe { at(base as *const u8, idx.0[l] as i64 * S as i64) }))
}
#[inline(always)]
pub unsafe fn _mm256_i32gather_epi64<const S: i32>(base: *const i64, idx: __m128i) -> __m256i {
    let q: [i64; 4] = std::array::from_fn(|l| unsafe { at(base as *const u8, idx.0[l] as i64 * S as i64) });
    __m256i(bytemuck::cast::<[i64; 4], [i32; 8]>(q))
}
#[inline(always)]
pub unsafe fn _mm256_i32gather_pd<const S: i32>(base: *const f64, idx: __m128i) -> __m256d {
    __m256d(std::array::from_fn(|l| unsafe { at(base as *const u8, idx.0[l] as i64 * S as i64) }))
}
#[inline(always)]
pub unsafe fn _mm_prefetch<const HINT: i32>(p: *const i8) {
    let _ = p;
}

// 128-bit values.

#[inline(always)]
pub fn _mm_set1_ps(x: f32) -> __m128 {
    __m128([x; 4])
}
#[inline(always)]
pub fn _mm_sub_ps(a: __m128, b: __m128) -> __m128 {
    __m128(std::array::from_fn(|l| a.0[l] - b.0[l]))
}
#[inline(always)]
pub fn _mm_fmadd_ps(a: __m128, b: __m128, c: __m128) -> __m128 {
    __m128(std::array::from_fn(|l| a.0[l].mul_add(b.0[l], c.0[l])))
}
#[inline(always)]
pub fn _mm_set1_epi32(x: i32) -> __m128i {
    __m128i([x; 4])
}
#[inline(always)]
pub fn _mm_set1_epi64x(x: i64) -> __m128i {
    __m128i([x as i32, (x >> 32) as i32, x as i32, (x >> 32) as i32])
}
#[inline(always)]
pub fn _mm_cvtsi32_si128(x: i32) -> __m128i {
    __m128i([x, 0, 0, 0])
}
#[inline(always)]
pub fn _mm_cvtepi32_ps(a: __m128i) -> __m128 {
    __m128(a.0.map(|x| x as f32))
}
#[inline(always)]
pub fn _mm_cvtepu16_epi32(a: __m128i) -> __m128i {
    let h: [u16; 8] = bytemuck::cast(a.0);
    __m128i(std::array::from_fn(|l| h[l] as i32))
}
#[inline(always)]
pub fn _mm_cvtepi16_epi32(a: __m128i) -> __m128i {
    let h: [i16; 8] = bytemuck::cast(a.0);
    __m128i(std::array::from_fn(|l| h[l] as i32))
}
#[inline(always)]
pub unsafe fn _mm_loadu_ps(p: *const f32) -> __m128 {
    unsafe { __m128(std::ptr::read_unaligned(p as *const [f32; 4])) }
}
#[inline(always)]
pub unsafe fn _mm_loadu_si128(p: *const __m128i) -> __m128i {
    unsafe { __m128i(std::ptr::read_unaligned(p as *const [i32; 4])) }
}
#[inline(always)]
pub unsafe fn _mm_loadl_epi64(p: *const __m128i) -> __m128i {
    let low: [i32; 2] = unsafe { std::ptr::read_unaligned(p as *const [i32; 2]) };
    __m128i([low[0], low[1], 0, 0])
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    //! Each operation against its AVX2 namesake on awkward inputs.
    use std::arch::x86_64 as x;

    fn inputs() -> [[f32; 8]; 4] {
        let nan = f32::NAN;
        [
            [0.0, -0.0, 1.5, -2.5, 3e9, -3e9, nan, f32::INFINITY],
            [1.0, 0.0, 2.5, -2.5, nan, 1e-40, 0.5, -f32::INFINITY],
            [0.5, -1.5, 2.5, 3.5, -0.5, 2147483520.0, -2147483648.0, 1e20],
            [7.0, -7.0, 65504.0, 1e-8, 0.1, 0.2, 0.3, 0.4],
        ]
    }

    /// Equal bits, or both NaN (whose sign and payload nothing reads).
    fn same(a: [f32; 8], b: [f32; 8]) -> bool {
        a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()))
    }

    #[test]
    fn float_operations_match_avx2() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        for a in inputs() {
            for b in inputs() {
                let (pa, pb) = (super::__m256(a), super::__m256(b));
                // SAFETY: AVX2 and FMA were detected above.
                unsafe {
                    let (va, vb) = (x::_mm256_loadu_ps(a.as_ptr()), x::_mm256_loadu_ps(b.as_ptr()));
                    let avx = |v: x::__m256| std::mem::transmute::<x::__m256, [f32; 8]>(v);
                    assert!(same(super::_mm256_min_ps(pa, pb).0, avx(x::_mm256_min_ps(va, vb))));
                    assert!(same(super::_mm256_max_ps(pa, pb).0, avx(x::_mm256_max_ps(va, vb))));
                    assert!(same(super::_mm256_fmadd_ps(pa, pb, pa).0, avx(x::_mm256_fmadd_ps(va, vb, va))));
                    assert!(same(super::_mm256_fnmadd_ps(pa, pb, pb).0, avx(x::_mm256_fnmadd_ps(va, vb, vb))));
                    assert!(same(
                        super::_mm256_cmp_ps::<{ super::_CMP_NGT_UQ }>(pa, pb).0,
                        avx(x::_mm256_cmp_ps::<{ x::_CMP_NGT_UQ }>(va, vb))
                    ));
                    assert!(same(
                        super::_mm256_cmp_ps::<{ super::_CMP_NEQ_OQ }>(pa, pb).0,
                        avx(x::_mm256_cmp_ps::<{ x::_CMP_NEQ_OQ }>(va, vb))
                    ));
                    assert!(same(
                        super::_mm256_shuffle_ps::<0xDD>(pa, pb).0,
                        avx(x::_mm256_shuffle_ps::<0xDD>(va, vb))
                    ));
                    assert!(same(
                        super::_mm256_permute2f128_ps::<0x31>(pa, pb).0,
                        avx(x::_mm256_permute2f128_ps::<0x31>(va, vb))
                    ));
                    assert!(same(super::_mm256_blendv_ps(pa, pb, pa).0, avx(x::_mm256_blendv_ps(va, vb, va))));
                    assert_eq!(super::_mm256_movemask_ps(pa), x::_mm256_movemask_ps(va));
                    let ints = |v: x::__m256i| std::mem::transmute::<x::__m256i, [i32; 8]>(v);
                    assert_eq!(super::_mm256_cvttps_epi32(pa).0, ints(x::_mm256_cvttps_epi32(va)));
                    assert_eq!(super::_mm256_cvtps_epi32(pa).0, ints(x::_mm256_cvtps_epi32(va)));
                    assert!(same(
                        super::_mm256_round_ps::<{ super::_MM_FROUND_TO_NEAREST_INT | super::_MM_FROUND_NO_EXC }>(pa).0,
                        avx(x::_mm256_round_ps::<{ x::_MM_FROUND_TO_NEAREST_INT | x::_MM_FROUND_NO_EXC }>(va))
                    ));
                }
            }
        }
    }
}
