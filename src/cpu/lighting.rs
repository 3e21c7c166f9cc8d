//! Light at eight samples (shaders/lighting.wgsl): diffuse shading from
//! normals, point and directional lights, and the field's gradient from
//! central differences.

use super::ops::*;
use super::sampling::*;
use super::Frame;
use crate::plan::params::Params;
use std::arch::x86_64::*;

/// The light at a texel lit from its normal (texel[1..4], any length) by a
/// directional light travelling along `light_dir` (lighting.wgsl
/// `light_intensity`): ambient where the normal is zero.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn lit_by(texel: &[__m256; 4], light_dir: &[__m256; 3], ambient: __m256, diffuse: __m256) -> __m256 {
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let mag = _mm256_max_ps(_mm256_max_ps(abs(texel[1]), abs(texel[2])), abs(texel[3]));
    let lit = _mm256_cmp_ps::<_CMP_GT_OQ>(mag, zero);
    let inv = _mm256_div_ps(one, _mm256_blendv_ps(one, mag, lit));
    let nrm: [__m256; 3] = std::array::from_fn(|c| _mm256_mul_ps(texel[c + 1], inv));
    let len =
        _mm256_sqrt_ps(_mm256_fmadd_ps(nrm[0], nrm[0], _mm256_fmadd_ps(nrm[1], nrm[1], _mm256_mul_ps(nrm[2], nrm[2]))));
    let dot = _mm256_fmadd_ps(
        nrm[0],
        light_dir[0],
        _mm256_fmadd_ps(nrm[1], light_dir[1], _mm256_mul_ps(nrm[2], light_dir[2])),
    );
    let cos = _mm256_max_ps(_mm256_div_ps(dot, _mm256_blendv_ps(one, len, lit)), zero);
    _mm256_blendv_ps(ambient, _mm256_fmadd_ps(diffuse, cos, ambient), lit)
}

/// The light a sample at ray offset `at` takes (lighting.wgsl): lit from
/// its texel's normal, or from the field's gradient at voxel coordinates
/// `u` where the frame takes gradients, by the frame's directional or point
/// light; ambient alone where the frame is unlit.
///
/// # Safety
/// Needs AVX2, FMA and F16C, and `tex` the padding its reads need.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn sample_light<T: Texels>(
    f: &Frame,
    tex: &T,
    rays: &super::rays8::Rays,
    u: &[__m256; 3],
    texel: &[__m256; 4],
    at: __m256,
    hi: &[__m256i; 3],
    stride: &[__m256i; 3],
    read: Option<&CellRows>,
) -> __m256 {
    let p = f.params;
    let (ambient, diffuse) = (_mm256_set1_ps(p.ambient), _mm256_set1_ps(p.diffuse));
    // SAFETY: the caller's contract.
    let normal = || if f.gradient { unsafe { gradient_at(tex, p, u, texel[0], hi, stride, read) } } else { *texel };
    if f.lit && !f.point_light && p.light_valid == 1 {
        let light_dir: [__m256; 3] = std::array::from_fn(|k| _mm256_set1_ps(p.light_dir[k]));
        lit_by(&normal(), &light_dir, ambient, diffuse)
    } else if f.lit && f.point_light {
        let (travel, defined) = point_light_travel(p, rays, at);
        _mm256_blendv_ps(ambient, lit_by(&normal(), &travel, ambient, diffuse), defined)
    } else {
        ambient
    }
}

/// The unit direction a point light at `light_pos` travels at ray
/// parameter `at` past the chords' start, and where it is defined (away
/// from the light itself): sampling.wgsl `direction_and_length`, scaled by
/// the largest component first so that no length overflows.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn point_light_travel(p: &Params, rays: &super::rays8::Rays, at: __m256) -> ([__m256; 3], __m256) {
    let t = _mm256_add_ps(rays.t0, at);
    let pos = std::array::from_fn(|k| _mm256_fmadd_ps(rays.d[k], t, rays.o[k]));
    let (dir, defined, _) = travel_from_light(p, pos);
    (dir, defined)
}

/// The unit direction a point light's light travels at `pos`, where it is
/// defined, and the distance back to the light (sampling.wgsl
/// `direction_and_length`).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn travel_from_light(p: &Params, pos: [__m256; 3]) -> ([__m256; 3], __m256, __m256) {
    let set = _mm256_set1_ps;
    let v: [__m256; 3] = std::array::from_fn(|k| _mm256_sub_ps(pos[k], set(p.light_pos[k])));
    let m = _mm256_max_ps(_mm256_max_ps(abs(v[0]), abs(v[1])), abs(v[2]));
    let defined = _mm256_cmp_ps::<_CMP_GT_OQ>(m, _mm256_setzero_ps());
    let huge = _mm256_cmp_ps::<_CMP_GT_OQ>(m, set(1.0e30));
    let s = _mm256_blendv_ps(set(1.0), set(5.421010862e-20), huge);
    let ms = _mm256_mul_ps(_mm256_blendv_ps(set(1.0), m, defined), s);
    let u: [__m256; 3] = std::array::from_fn(|k| _mm256_div_ps(_mm256_mul_ps(v[k], s), ms));
    let l = _mm256_sqrt_ps(_mm256_fmadd_ps(u[0], u[0], _mm256_fmadd_ps(u[1], u[1], _mm256_mul_ps(u[2], u[2]))));
    (std::array::from_fn(|k| _mm256_div_ps(u[k], l)), defined, _mm256_mul_ps(m, l))
}

/// The four rows of texels along the last axis through the cell around
/// voxel coordinates `u` of a values-only storage, each read as four
/// texels from the one before the cell (`value_quad`) and interpolated at
/// the cell's weight along the last axis as its down, own and up rows; with
/// what the other axes' rows need. None where one of the eight lanes' cell
/// touches the storage's ends along the last axis (where texels are clamped).
pub(super) struct CellRows {
    /// [j0][j1]: the rows at numpy axes 0 and 1 texels b and b + 1.
    rows: [[[__m256; 3]; 2]; 2],
    /// The cell's weights, and offsets of texels b - 1 to b + 2 along axes
    /// 0 and 1 (clamped, as `corners` clamps) and of texel b along the last.
    w: [__m256; 3],
    along: [[__m256i; 4]; 2],
    last: __m256i,
}

impl CellRows {
    /// # Safety
    /// Needs AVX2, FMA and F16C, and `tex` the padding its reads need.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) unsafe fn read<T: Texels>(
        tex: &T,
        u: &[__m256; 3],
        hi: &[__m256i; 3],
        stride: &[__m256i; 3],
    ) -> Option<CellRows> {
        let (zi, onei) = (_mm256_setzero_si256(), _mm256_set1_epi32(1));
        if !T::VALUES_ONLY {
            return None;
        }
        let fl = u.map(|x| _mm256_floor_ps(x));
        let b = fl.map(|x| _mm256_cvttps_epi32(x));
        // Texels b - 1 to b + 2 along the last axis, unclamped.
        let last = _mm256_sub_epi32(hi[2], onei);
        let inside = _mm256_and_si256(_mm256_cmpgt_epi32(b[2], zi), _mm256_cmpgt_epi32(last, b[2]));
        if _mm256_movemask_epi8(inside) != -1 {
            return None;
        }
        let w: [__m256; 3] = std::array::from_fn(|k| _mm256_sub_ps(u[k], fl[k]));
        let along = |k: usize| -> [__m256i; 4] {
            std::array::from_fn(|j| {
                let t = _mm256_add_epi32(b[k], _mm256_set1_epi32(j as i32 - 1));
                _mm256_mullo_epi32(_mm256_min_epi32(_mm256_max_epi32(t, zi), hi[k]), stride[k])
            })
        };
        let along = [along(0), along(1)];
        let last = _mm256_mullo_epi32(b[2], stride[2]);
        let mut rows = [[[_mm256_setzero_ps(); 3]; 2]; 2];
        for (a, j0) in [1, 2].into_iter().enumerate() {
            for (c, j1) in [1, 2].into_iter().enumerate() {
                let from =
                    _mm256_sub_epi32(_mm256_add_epi32(_mm256_add_epi32(along[0][j0], along[1][j1]), last), stride[2]);
                // SAFETY: the offsets address texels (the caller's
                // contract), and texels b - 1 to b + 2 exist along the last axis.
                let t = unsafe { tex.value_quad(from) };
                rows[a][c] = [lerp(t[0], t[1], w[2]), lerp(t[1], t[2], w[2]), lerp(t[2], t[3], w[2])];
            }
        }
        Some(CellRows { rows, w, along, last })
    }

    /// Rows [j0][j1] interpolated as the trilinear read does: along numpy axis 1, then 0.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    fn tri(&self, r: [[__m256; 2]; 2]) -> __m256 {
        let w = &self.w;
        lerp(lerp(r[0][0], r[0][1], w[1]), lerp(r[1][0], r[1][1], w[1]), w[0])
    }

    /// The trilinear value at `u`: `Texels::trilinear`'s, bit for bit (the
    /// same texels, weights and order, no corner clamped along the last axis).
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn value(&self) -> __m256 {
        self.tri(std::array::from_fn(|a| std::array::from_fn(|c| self.rows[a][c][1])))
    }
}

/// The interpolated values' differences T(u + e_k) - T(u - e_k) one voxel
/// either side of voxel coordinates `u` along each numpy axis k.
///
/// Six trilinear reads take 24 pairs of texels along the last axis. Values
/// alone share them: the four rows of the cell around `u` (`CellRows`, which
/// the sample's own value may have read already) give the last axis's
/// differences and the rows the other two axes share; those read four pairs
/// more each. Each difference is interpolated in the trilinear read's
/// order from the same texels, with the cell's own weights where the six
/// reads take those of u + 1 and u - 1 (the same but for their rounding).
/// Eight lanes of which one's cell touches the storage's ends along the
/// last axis (where texels are clamped) take the six reads.
///
/// # Safety
/// Needs AVX2, FMA and F16C, and `tex` the padding its reads need.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn differences<T: Texels>(
    tex: &T,
    u: &[__m256; 3],
    hi: &[__m256i; 3],
    stride: &[__m256i; 3],
    read: Option<&CellRows>,
) -> [__m256; 3] {
    let one = _mm256_set1_ps(1.0);
    let six_reads = || -> [__m256; 3] {
        std::array::from_fn(|k| {
            let (mut up, mut down) = (*u, *u);
            up[k] = _mm256_add_ps(up[k], one);
            down[k] = _mm256_sub_ps(down[k], one);
            let ((ou, wu), (od, wd)) = (corners(&up, hi, stride), corners(&down, hi, stride));
            // SAFETY: the offsets are clamped into the texture.
            unsafe { _mm256_sub_ps(tex.trilinear(&ou, &wu)[0], tex.trilinear(&od, &wd)[0]) }
        })
    };
    // SAFETY: the caller's contract.
    let fresh;
    let c = match read {
        Some(c) => c,
        None => match unsafe { CellRows::read(tex, u, hi, stride) } {
            Some(c) => {
                fresh = c;
                &fresh
            }
            None => return six_reads(),
        },
    };
    let (o0, o1) = (&c.along[0], &c.along[1]);
    // SAFETY: the offsets address texels (the caller's contract), and texel
    // b + 1 exists along the last axis.
    let row = |j0: usize, j1: usize| unsafe {
        let (lo, hi) = tex.value_pair(_mm256_add_epi32(_mm256_add_epi32(o0[j0], o1[j1]), c.last));
        lerp(lo, hi, c.w[2])
    };
    let own = |a: usize, b: usize| c.rows[a][b][1];
    let g2 = _mm256_sub_ps(
        c.tri(std::array::from_fn(|a| std::array::from_fn(|b| c.rows[a][b][2]))),
        c.tri(std::array::from_fn(|a| std::array::from_fn(|b| c.rows[a][b][0]))),
    );
    let g1 = _mm256_sub_ps(
        c.tri([[own(0, 1), row(1, 3)], [own(1, 1), row(2, 3)]]),
        c.tri([[row(1, 0), own(0, 0)], [row(2, 0), own(1, 0)]]),
    );
    let g0 = _mm256_sub_ps(
        c.tri([[own(1, 0), own(1, 1)], [row(3, 1), row(3, 2)]]),
        c.tri([[row(0, 1), row(0, 2)], [own(0, 0), own(0, 1)]]),
    );
    [g0, g1, g2]
}

/// (value, gradient) at voxel coordinates `u` from central differences one
/// voxel apart of the interpolated values (sampling.wgsl `gradient`: zero
/// where one is NaN, scaled by its largest component, then by the
/// spacings), for volumes lit without stored normals or gradients; `hi`
/// and `stride` as for `corners`.
///
/// # Safety
/// Needs AVX2, FMA and F16C, and `tex` the padding its reads need.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn gradient_at<T: Texels>(
    tex: &T,
    p: &Params,
    u: &[__m256; 3],
    value: __m256,
    hi: &[__m256i; 3],
    stride: &[__m256i; 3],
    read: Option<&CellRows>,
) -> [__m256; 4] {
    let set = _mm256_set1_ps;
    let (zero, one) = (_mm256_setzero_ps(), set(1.0));
    // SAFETY: the caller's contract.
    let g = unsafe { differences(tex, u, hi, stride, read) };
    let ordered = _mm256_and_ps(_mm256_cmp_ps::<_CMP_ORD_Q>(g[0], g[1]), _mm256_cmp_ps::<_CMP_ORD_Q>(g[2], g[2]));
    let m = _mm256_max_ps(_mm256_max_ps(abs(g[0]), abs(g[1])), abs(g[2]));
    let some = _mm256_and_ps(ordered, _mm256_cmp_ps::<_CMP_GT_OQ>(m, zero));
    let s = _mm256_blendv_ps(one, set(5.421010862e-20), _mm256_cmp_ps::<_CMP_GT_OQ>(m, set(1.0e30)));
    let ms = _mm256_mul_ps(_mm256_blendv_ps(one, m, some), s);
    let n = |k: usize| {
        let unit = _mm256_div_ps(_mm256_mul_ps(g[k], s), ms);
        _mm256_and_ps(_mm256_mul_ps(unit, set(p.inv_two_spacing[k])), some)
    };
    [value, n(0), n(1), n(2)]
}
