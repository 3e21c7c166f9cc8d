//! Texels stored as codes (shaders/sampling.wgsl): 16-bit fixed point,
//! 8- and 16-bit unsigned values, float16, and normals kept apart from
//! values alone, read in eight lanes.

use super::ops::*;
use super::sampling::*;
use std::arch::x86_64::*;

/// The trilinear value of codes `SCALE` bytes wide, made a float by `code`
/// from the low bits of a 32-bit lane. The 32-bit word at a corner's
/// offset holds that code and the next along the last axis: one gather
/// reads both corners of a pair, four a sample instead of eight.
///
/// # Safety
/// The offsets address texels, and 4 - SCALE bytes follow the last.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn word_codes<const SCALE: i32>(
    base: *const i32,
    offs: &[[__m256i; 2]; 3],
    w: &[__m256; 3],
    code: impl Fn(__m256i) -> __m256,
) -> [__m256; 4] {
    // Where the upper corner is clamped onto the lower, the word's next
    // code is the next texel's (or padding): the lower one stands for both.
    let clamped = _mm256_castsi256_ps(_mm256_cmpeq_epi32(offs[2][0], offs[2][1]));
    let row = |o0: __m256i, o1: __m256i| {
        let o = _mm256_add_epi32(_mm256_add_epi32(o0, o1), offs[2][0]);
        // SAFETY: the caller's contract.
        let (lower, upper) = unsafe { word_pair::<SCALE>(base, o, &code) };
        lerp(lower, _mm256_blendv_ps(upper, lower, clamped), w[2])
    };
    let plane = |o0: __m256i| lerp(row(o0, offs[1][0]), row(o0, offs[1][1]), w[1]);
    value_only(lerp(plane(offs[0][0]), plane(offs[0][1]), w[0]))
}

/// The codes `SCALE` bytes wide at offsets `o` and after them, from the
/// 32-bit word at each offset.
///
/// # Safety
/// The offsets address texels, and 4 - SCALE bytes follow each.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn word_pair<const SCALE: i32>(
    base: *const i32,
    o: __m256i,
    code: impl Fn(__m256i) -> __m256,
) -> (__m256, __m256) {
    // SAFETY: the caller's contract.
    let word = unsafe { _mm256_i32gather_epi32::<SCALE>(base, o) };
    (code(word), code(_mm256_srl_epi32(word, _mm_cvtsi32_si128(8 * SCALE))))
}

/// Each lane's four 16-bit codes from texel offset `o` on, in one 64-bit
/// load a ray, made floats by `code` (four a 128-bit register).
///
/// # Safety
/// The four codes from each offset exist.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn code_quads(base: *const u16, o: __m256i, code: impl Fn(__m128i) -> __m128) -> [__m256; 4] {
    let at = int_lanes(o);
    // SAFETY: the caller's contract.
    let load = |l: usize| unsafe { _mm_loadl_epi64(base.add(at[l] as usize) as *const __m128i) };
    transpose_rays(&std::array::from_fn(|l| code(load(l))))
}

/// Codes read as the low halves of 32-bit words (the storage holds one
/// code past the last texel).
pub struct R16Snorm<'a>(pub &'a [i16]);

impl R16Snorm<'_> {
    /// A code's float: the low half, sign extended.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    fn code(x: __m256i) -> __m256 {
        _mm256_cvtepi32_ps(_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(x)))
    }
}

impl Texels for R16Snorm<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0 / crate::fixed16::CODE_MAX as f32;
    const UNIT_BYTES: usize = 2;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // SAFETY: offsets address texels, and one code follows the last.
        unsafe { word_codes::<2>(self.0.as_ptr() as *const i32, offs, w, |x| Self::code(x)) }
    }
    const VALUES_ONLY: bool = true;
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        // SAFETY: the caller's contract.
        unsafe { word_pair::<2>(self.0.as_ptr() as *const i32, o, |x| Self::code(x)) }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_quad(&self, o: __m256i) -> [__m256; 4] {
        // SAFETY: the caller's contract.
        unsafe { code_quads(self.0.as_ptr() as *const u16, o, |x| _mm_cvtepi32_ps(_mm_cvtepi16_epi32(x))) }
    }
}

/// 8-bit codes (0..=255 for 0..=1) read as the low bytes of 32-bit words
/// (the storage holds three bytes past the last texel).
pub struct R8Unorm<'a>(pub &'a [u8]);

impl R8Unorm<'_> {
    /// A code's float: the low byte.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    fn code(x: __m256i) -> __m256 {
        _mm256_cvtepi32_ps(_mm256_and_si256(x, _mm256_set1_epi32(0xff)))
    }
}

impl Texels for R8Unorm<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0 / 255.0;
    const UNIT_BYTES: usize = 1;
    fn base(&self) -> *const u8 {
        self.0.as_ptr()
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // SAFETY: offsets address texels, and three bytes follow the last.
        unsafe { word_codes::<1>(self.0.as_ptr() as *const i32, offs, w, |x| Self::code(x)) }
    }
    const VALUES_ONLY: bool = true;
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        // SAFETY: the caller's contract.
        unsafe { word_pair::<1>(self.0.as_ptr() as *const i32, o, |x| Self::code(x)) }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_quad(&self, o: __m256i) -> [__m256; 4] {
        // One word holds all four codes.
        // SAFETY: the caller's contract.
        let word = unsafe { _mm256_i32gather_epi32::<1>(self.0.as_ptr() as *const i32, o) };
        let byte = |x| _mm256_cvtepi32_ps(_mm256_and_si256(x, _mm256_set1_epi32(0xff)));
        [
            byte(word),
            byte(_mm256_srli_epi32::<8>(word)),
            byte(_mm256_srli_epi32::<16>(word)),
            byte(_mm256_srli_epi32::<24>(word)),
        ]
    }
}

/// 16-bit codes (0..=65535 for 0..=1) read as the low halves of 32-bit
/// words (the storage holds one code past the last texel).
pub struct R16Unorm<'a>(pub &'a [u16]);

impl R16Unorm<'_> {
    /// A code's float: the low half.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    fn code(x: __m256i) -> __m256 {
        _mm256_cvtepi32_ps(_mm256_and_si256(x, _mm256_set1_epi32(0xffff)))
    }
}

impl Texels for R16Unorm<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0 / 65535.0;
    const UNIT_BYTES: usize = 2;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // SAFETY: offsets address texels, and one code follows the last.
        unsafe { word_codes::<2>(self.0.as_ptr() as *const i32, offs, w, |x| Self::code(x)) }
    }
    const VALUES_ONLY: bool = true;
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        // SAFETY: the caller's contract.
        unsafe { word_pair::<2>(self.0.as_ptr() as *const i32, o, |x| Self::code(x)) }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_quad(&self, o: __m256i) -> [__m256; 4] {
        // SAFETY: the caller's contract.
        unsafe { code_quads(self.0.as_ptr(), o, |x| _mm_cvtepi32_ps(_mm_cvtepu16_epi32(x))) }
    }
}

/// Values from a values-only storage `T` and normals stored apart, one
/// Rgba8Snorm texel a value (`super::CpuVolume::normals`): a ray's pair of
/// corners along the last axis in one 64-bit load.
pub struct Apart<'a, T>(pub T, pub &'a [[i8; 4]]);

impl<T: Texels> Texels for Apart<'_, T> {
    const PER_TEXEL: usize = T::PER_TEXEL;
    const VALUE_UNIT: f32 = T::VALUE_UNIT;
    const UNIT_BYTES: usize = T::UNIT_BYTES;
    fn strides(&self, dims: [usize; 3]) -> [i32; 3] {
        self.0.strides(dims)
    }
    fn base(&self) -> *const u8 {
        self.0.base()
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        const { assert!(T::PER_TEXEL == 1, "an offset is a texel's index") };
        // SAFETY: the caller's contract (offsets address texels, and every
        // texel has its normal).
        let value = unsafe { self.0.trilinear(offs, w)[0] };
        let base = self.1.as_ptr() as *const u8;
        // SAFETY: as above; a pair's 8 bytes hold the texel's normal and the
        // next one's, which exists unless clamped onto the texel.
        let codes = unsafe {
            corner_pairs(offs, w, |at, apart| {
                let p = base.add(4 * at);
                let bytes = if apart {
                    _mm_loadl_epi64(p as *const __m128i)
                } else {
                    _mm_set1_epi32(std::ptr::read_unaligned(p as *const i32))
                };
                _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(bytes))
            })
        };
        // Codes of 1/127 (snorm's -128, which no normal is stored as, aside).
        let unit = _mm256_set1_ps(1.0 / 127.0);
        [value, _mm256_mul_ps(codes[0], unit), _mm256_mul_ps(codes[1], unit), _mm256_mul_ps(codes[2], unit)]
    }
}

/// The binary16 floats in the low halves of `x`'s 32-bit lanes, exactly
/// (subnormal, infinite and NaN ones too), in integer arithmetic but for
/// the subnormals' one conversion and product: a normal half's bits moved
/// into a binary32's place take its exponent rebiased; a subnormal one is
/// its fraction times 2^-24; infinities and NaNs take binary32's all-ones
/// exponent. (Moving a subnormal half's bits makes a subnormal binary32,
/// and a product reading one takes a microcode assist, which fields that
/// fall smoothly to 0 would pay at many texels.)
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn half_floats(x: __m256i) -> __m256 {
    let set = _mm256_set1_epi32;
    let magnitude = _mm256_and_si256(x, set(0x7fff));
    let sign = _mm256_slli_epi32::<16>(_mm256_and_si256(x, set(0x8000)));
    let moved = _mm256_slli_epi32::<13>(magnitude);
    let normal = _mm256_castsi256_ps(_mm256_add_epi32(moved, set((127 - 15) << 23)));
    let small = _mm256_mul_ps(_mm256_cvtepi32_ps(magnitude), _mm256_set1_ps(1.0 / 16_777_216.0));
    let special = _mm256_castsi256_ps(_mm256_or_si256(moved, set(0x7f80_0000)));
    let subnormal = _mm256_castsi256_ps(_mm256_cmpgt_epi32(set(0x400), magnitude));
    let all_ones = _mm256_castsi256_ps(_mm256_cmpgt_epi32(magnitude, set(0x7bff)));
    let v = _mm256_blendv_ps(_mm256_blendv_ps(normal, small, subnormal), special, all_ones);
    _mm256_or_ps(v, _mm256_castsi256_ps(sign))
}

/// binary16 values read as the low halves of 32-bit words (the storage
/// holds one value past the last texel).
pub struct R16Float<'a>(pub &'a [u16]);

impl Texels for R16Float<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0;
    const UNIT_BYTES: usize = 2;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // SAFETY: offsets address texels, and one value follows the last.
        unsafe { word_codes::<2>(self.0.as_ptr() as *const i32, offs, w, |x| half_floats(x)) }
    }
    const VALUES_ONLY: bool = true;
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        // SAFETY: the caller's contract.
        unsafe { word_pair::<2>(self.0.as_ptr() as *const i32, o, |x| half_floats(x)) }
    }
}

/// (value, normal) in binary16: a ray's pair of corners along the last
/// axis in one 128-bit load, made float32 by the F16C conversion.
pub struct Rgba16Float<'a>(pub &'a [[u16; 4]]);

impl Texels for Rgba16Float<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0;
    const UNIT_BYTES: usize = 8;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        let base = self.0.as_ptr() as *const u16;
        // SAFETY: the caller's contract; a pair's 16 bytes hold the texel
        // and the next, which exists unless clamped onto the texel.
        unsafe {
            corner_pairs(offs, w, |at, apart| {
                let p = base.add(4 * at);
                let halves = if apart {
                    _mm_loadu_si128(p as *const __m128i)
                } else {
                    _mm_set1_epi64x(std::ptr::read_unaligned(p as *const i64))
                };
                _mm256_cvtph_ps(halves)
            })
        }
    }
}
