//! Reading the volume in eight lanes (shaders/sampling.wgsl): the texel
//! readers' trait, float32 texels, and each sample's corners and weights.

use super::ops::*;
use crate::plan::params::Params;
use std::arch::x86_64::*;

/// Where a march reads its texels: the offsets of each axis's two corner
/// planes (in the storage's units) and the trilinear weights give eight
/// lanes' interpolated (value, normal); the normal is 0 where none is held.
pub trait Texels {
    /// Gather units (the offsets' scale) per texel.
    const PER_TEXEL: usize;
    /// What one unit of the interpolated value channel stands for.
    const VALUE_UNIT: f32;
    /// Bytes per gather unit (an offset of 1).
    const UNIT_BYTES: usize;
    /// Offsets of one voxel step along each numpy axis.
    fn strides(&self, dims: [usize; 3]) -> [i32; 3] {
        numpy_strides(dims, Self::PER_TEXEL)
    }
    /// # Safety
    /// Needs AVX2, FMA and F16C; every offset must address a texel.
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4];
    /// The storage's first byte.
    fn base(&self) -> *const u8;
    /// Whether the storage holds values alone, which `value_pair` reads.
    const VALUES_ONLY: bool = false;
    /// Eight lanes' values at texel offset `o` and at the next texel along
    /// the last axis (`VALUES_ONLY` storages).
    ///
    /// # Safety
    /// Needs AVX2, FMA and F16C; both texels must exist.
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        let _ = o;
        unreachable!("only storages of values alone read value pairs")
    }
    /// Eight lanes' values at texel offset `o` and the next three texels
    /// along the last axis (`VALUES_ONLY` storages).
    ///
    /// # Safety
    /// Needs AVX2, FMA and F16C; the four texels must exist.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_quad(&self, o: __m256i) -> [__m256; 4] {
        // SAFETY: the caller's contract (values alone: an offset counts texels).
        let later = _mm256_add_epi32(o, _mm256_set1_epi32(2));
        let ((a, b), (c, d)) = unsafe { (self.value_pair(o), self.value_pair(later)) };
        [a, b, c, d]
    }
}

#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn lerp(x: __m256, y: __m256, t: __m256) -> __m256 {
    _mm256_fmadd_ps(_mm256_sub_ps(y, x), t, x)
}

/// Trilinear interpolation of channels read by `corner` at each corner's offset.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn interpolate<const C: usize>(
    offs: &[[__m256i; 2]; 3],
    w: &[__m256; 3],
    corner: impl Fn(__m256i) -> [__m256; C],
) -> [__m256; C] {
    let mix = |x: [__m256; C], y: [__m256; C], t: __m256| std::array::from_fn(|c| lerp(x[c], y[c], t));
    let plane = |o0: __m256i| {
        let row = |o1: __m256i| {
            let b = _mm256_add_epi32(o0, o1);
            mix(corner(_mm256_add_epi32(b, offs[2][0])), corner(_mm256_add_epi32(b, offs[2][1])), w[2])
        };
        mix(row(offs[1][0]), row(offs[1][1]), w[1])
    };
    mix(plane(offs[0][0]), plane(offs[0][1]), w[0])
}

/// Eight rays' four channels, each ray's in a 128-bit register, as four
/// registers of eight lanes (channel c of ray l in lane l of register c).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn transpose_rays(rays: &[__m128; 8]) -> [__m256; 4] {
    // Rays l and l + 4 share a register, then a 4x4 transpose in each half.
    transpose_pairs(&std::array::from_fn(|l| _mm256_set_m128(rays[l + 4], rays[l])))
}

/// Four registers of two rays' channels each (register l: [ray l | ray
/// l + 4]) as four registers of eight lanes (channel c in register c).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn transpose_pairs(r: &[__m256; 4]) -> [__m256; 4] {
    let (t0, t1) = (_mm256_unpacklo_ps(r[0], r[1]), _mm256_unpackhi_ps(r[0], r[1]));
    let (t2, t3) = (_mm256_unpacklo_ps(r[2], r[3]), _mm256_unpackhi_ps(r[2], r[3]));
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// A value-only storage's texel: no normal.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn value_only(v: __m256) -> [__m256; 4] {
    let zero = _mm256_setzero_ps();
    [v, zero, zero, zero]
}

pub(super) fn numpy_strides([_, d1, d2]: [usize; 3], per_texel: usize) -> [i32; 3] {
    [(d1 * d2 * per_texel) as i32, (d2 * per_texel) as i32, per_texel as i32]
}

pub struct Rgba32Float<'a>(pub &'a [[f32; 4]]);

impl Texels for Rgba32Float<'_> {
    const PER_TEXEL: usize = 4;
    const VALUE_UNIT: f32 = 1.0;
    const UNIT_BYTES: usize = 4;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // Each ray's two corners along the last axis lie side by side: one
        // 256-bit load a pair instead of 32 gathers (each of them ~8 loads).
        let base = self.0.as_ptr() as *const f32;
        // SAFETY: the caller's contract; a pair's upper texel is the next
        // one unless clamped, when the texel alone is read.
        unsafe {
            corner_pairs(offs, w, |at, apart| {
                let p = base.add(at);
                if apart {
                    _mm256_loadu_ps(p)
                } else {
                    // (Texels are 4-byte aligned: no reference to an __m128.)
                    let texel = _mm_loadu_ps(p);
                    _mm256_set_m128(texel, texel)
                }
            })
        }
    }
}

/// One 64-bit gather of four lanes' texels reads all four channels of a
/// corner: a quarter of float32's gathered elements (reading a ray at a
/// time, as `Rgba32Float` does, is slower for these 8-byte texels).
pub struct Rgba16Snorm<'a>(pub &'a [[i16; 4]]);

impl Texels for Rgba16Snorm<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0 / crate::fixed16::CODE_MAX as f32;
    const UNIT_BYTES: usize = 8;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        let base = self.0.as_ptr() as *const i64;
        // Lanes (0, 1, 4, 5) and (2, 3, 6, 7) are gathered apart, so that
        // one shuffle of the two results' even (odd) 32-bit words puts each
        // lane's (value, nx) ((ny, nz)) in lane order.
        let order = _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7);
        let low = |x: __m256i| _mm256_cvtepi32_ps(_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(x)));
        let high = |x: __m256i| _mm256_cvtepi32_ps(_mm256_srai_epi32::<16>(x));
        interpolate(offs, w, |o| {
            let o = _mm256_permutevar8x32_epi32(o, order);
            // SAFETY: offsets address texels (the caller's contract).
            let (a, b) = unsafe {
                (
                    _mm256_castsi256_ps(_mm256_i32gather_epi64::<8>(base, _mm256_castsi256_si128(o))),
                    _mm256_castsi256_ps(_mm256_i32gather_epi64::<8>(base, _mm256_extracti128_si256::<1>(o))),
                )
            };
            let first = _mm256_castps_si256(_mm256_shuffle_ps::<0x88>(a, b));
            let second = _mm256_castps_si256(_mm256_shuffle_ps::<0xDD>(a, b));
            [low(first), high(first), low(second), high(second)]
        })
    }
}

/// Trilinear four channels read a ray at a time: `pair(offset, apart)`
/// gives the eight channels of the texel at `offset` and of the next one
/// along the last axis, or of that texel twice where `apart` is false (its
/// upper corner clamped onto it). Each ray interpolates its pairs in its
/// own registers, and one transpose puts the rays in lanes: no gathers.
///
/// # Safety
/// `pair` must read only texels the offsets address.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn corner_pairs(
    offs: &[[__m256i; 2]; 3],
    w: &[__m256; 3],
    pair: impl Fn(usize, bool) -> __m256,
) -> [__m256; 4] {
    let plane = |x: usize, y: usize| -> [i32; 8] {
        // SAFETY: i32x8 and [i32; 8] have the same size.
        unsafe { std::mem::transmute(_mm256_add_epi32(_mm256_add_epi32(offs[0][x], offs[1][y]), offs[2][0])) }
    };
    let at = [plane(0, 0), plane(0, 1), plane(1, 0), plane(1, 1)];
    // SAFETY: as above.
    let (apart, ws): ([i32; 8], [[f32; 8]; 3]) = unsafe {
        (
            std::mem::transmute::<__m256i, [i32; 8]>(_mm256_sub_epi32(offs[2][1], offs[2][0])),
            std::mem::transmute::<[__m256; 3], [[f32; 8]; 3]>(*w),
        )
    };
    let rays: [__m128; 8] = std::array::from_fn(|l| {
        let corner = |k: usize| pair(at[k][l] as usize, apart[l] != 0);
        let (wx, wy) = (_mm256_set1_ps(ws[0][l]), _mm256_set1_ps(ws[1][l]));
        let both = lerp(lerp(corner(0), corner(1), wy), lerp(corner(2), corner(3), wy), wx);
        let (lo, hi) = (_mm256_castps256_ps128(both), _mm256_extractf128_ps::<1>(both));
        _mm_fmadd_ps(_mm_sub_ps(hi, lo), _mm_set1_ps(ws[2][l]), lo)
    });
    transpose_rays(&rays)
}

pub struct R32Float<'a>(pub &'a [f32]);

impl Texels for R32Float<'_> {
    const PER_TEXEL: usize = 1;
    const VALUE_UNIT: f32 = 1.0;
    const UNIT_BYTES: usize = 4;
    fn base(&self) -> *const u8 {
        self.0.as_ptr() as *const u8
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn trilinear(&self, offs: &[[__m256i; 2]; 3], w: &[__m256; 3]) -> [__m256; 4] {
        // Where the upper corner is clamped onto the lower, the pair's
        // second word is the next texel's (the storage holds one past the
        // last): the lower one stands for both.
        let clamped = _mm256_castsi256_ps(_mm256_cmpeq_epi32(offs[2][0], offs[2][1]));
        let row = |o0: __m256i, o1: __m256i| {
            // SAFETY: offsets address texels, and one follows the last (the caller's contract).
            let (z0, z1) = unsafe { self.value_pair(_mm256_add_epi32(_mm256_add_epi32(o0, o1), offs[2][0])) };
            lerp(z0, _mm256_blendv_ps(z1, z0, clamped), w[2])
        };
        let plane = |o0: __m256i| lerp(row(o0, offs[1][0]), row(o0, offs[1][1]), w[1]);
        value_only(lerp(plane(offs[0][0]), plane(offs[0][1]), w[0]))
    }
    const VALUES_ONLY: bool = true;
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_pair(&self, o: __m256i) -> (__m256, __m256) {
        // Each ray's two corners along the last axis lie side by side: one
        // 64-bit gather element a pair, half the elements of a gather a
        // corner. Lanes (0, 1, 4, 5) and (2, 3, 6, 7) are gathered apart, so
        // that one shuffle of the two results' even (odd) words puts the
        // lower (upper) corners in lane order.
        let base = self.0.as_ptr() as *const f64;
        let o = _mm256_permutevar8x32_epi32(o, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
        // SAFETY: the caller's contract.
        let (a, b) = unsafe {
            (
                _mm256_castpd_ps(_mm256_i32gather_pd::<4>(base, _mm256_castsi256_si128(o))),
                _mm256_castpd_ps(_mm256_i32gather_pd::<4>(base, _mm256_extracti128_si256::<1>(o))),
            )
        };
        (_mm256_shuffle_ps::<0x88>(a, b), _mm256_shuffle_ps::<0xDD>(a, b))
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    unsafe fn value_quad(&self, o: __m256i) -> [__m256; 4] {
        // A ray's four texels in one 128-bit load (four gathers would take 16 elements).
        let at = int_lanes(o);
        let base = self.0.as_ptr();
        // SAFETY: the caller's contract.
        transpose_rays(&std::array::from_fn(|l| unsafe { _mm_loadu_ps(base.add(at[l] as usize)) }))
    }
}

/// Cell-centred voxel coordinates along each numpy axis at the chords'
/// start, and per unit of ray parameter.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn voxel_axes(p: &Params, rays: &super::rays8::Rays, dims: [usize; 3]) -> ([__m256; 3], [__m256; 3]) {
    let set = _mm256_set1_ps;
    let start = std::array::from_fn(|k| {
        let at = _mm256_add_ps(rays.o[k], _mm256_mul_ps(rays.d[k], rays.t0));
        let tc = _mm256_add_ps(_mm256_mul_ps(at, set(p.tex_scale[k])), set(p.tex_offset[k]));
        _mm256_sub_ps(_mm256_mul_ps(tc, set(dims[k] as f32)), set(0.5))
    });
    let per =
        std::array::from_fn(|k| _mm256_mul_ps(_mm256_mul_ps(rays.d[k], set(p.tex_scale[k])), set(dims[k] as f32)));
    (start, per)
}

/// The texel offsets of the two corners around cell-centred coordinate `u`
/// along each axis, clamped to the texture's last texel `hi` (times the
/// axis's `stride`), and the weights of the upper ones.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn corners(u: &[__m256; 3], hi: &[__m256i; 3], stride: &[__m256i; 3]) -> ([[__m256i; 2]; 3], [__m256; 3]) {
    let (zi, onei) = (_mm256_setzero_si256(), _mm256_set1_epi32(1));
    let mut w = [_mm256_setzero_ps(); 3];
    let mut offs = [[zi; 2]; 3];
    for k in 0..3 {
        let fl = _mm256_floor_ps(u[k]);
        w[k] = _mm256_sub_ps(u[k], fl);
        let base = _mm256_cvttps_epi32(fl);
        let clamp = |v: __m256i| _mm256_min_epi32(_mm256_max_epi32(v, zi), hi[k]);
        offs[k] = [
            _mm256_mullo_epi32(clamp(base), stride[k]),
            _mm256_mullo_epi32(clamp(_mm256_add_epi32(base, onei)), stride[k]),
        ];
    }
    (offs, w)
}
