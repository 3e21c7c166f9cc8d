//! The occupancy grid's cells along eight rays: which cell holds a point,
//! its code, and where a ray leaves the cube of cells around it
//! (skipping.wgsl `cell_of`, `exit_of_cube`). The march, the isosurface and
//! the unbiased walk leap by this one rule.

use super::CELL;
use crate::plan::params::Params;
use std::arch::x86_64::*;

/// A point's cell: the point in voxel coordinates shifted by the texture's
/// border (cell units times CELL), the cell's coordinates (clamped into
/// the grid) and its index in the grid.
pub(super) struct Cell {
    pub uc: [__m256; 3],
    pub c: [__m256i; 3],
    pub index: __m256i,
}

/// The grid as eight rays, each at voxel coordinates start + per * t, cross it.
pub(super) struct Cells {
    start: [__m256; 3],
    per: [__m256; 3],
    border: __m256,
    hi: [__m256i; 3],
    strides: [__m256i; 3],
    /// Ray parameter per voxel along each axis (1 where the ray does not move along it).
    per_voxel: [__m256; 3],
    moving: [__m256; 3],
    /// The ray leaves through the upper side along each axis.
    ahead: [__m256; 3],
    back: bool,
}

impl Cells {
    /// The cells of a grid `grid` cells a side (numpy axis order) along rays
    /// at voxel coordinates `start + per * t`; `back`: the rays march the
    /// other way (t falling), and exits are measured that way.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn new(p: &Params, start: [__m256; 3], per: [__m256; 3], grid: [usize; 3], back: bool) -> Cells {
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let moving: [__m256; 3] = std::array::from_fn(|k| _mm256_cmp_ps::<_CMP_NEQ_OQ>(per[k], zero));
        let towards = |k: usize| if back { _mm256_sub_ps(zero, per[k]) } else { per[k] };
        Cells {
            start,
            per,
            border: _mm256_set1_ps(0.5 - p.border as f32),
            hi: grid.map(|d| _mm256_set1_epi32(d as i32 - 1)),
            strides: [grid[1] * grid[2], grid[2], 1].map(|s| _mm256_set1_epi32(s as i32)),
            per_voxel: std::array::from_fn(|k| _mm256_div_ps(one, _mm256_blendv_ps(one, per[k], moving[k]))),
            moving,
            ahead: std::array::from_fn(|k| _mm256_cmp_ps::<_CMP_GT_OQ>(towards(k), zero)),
            back,
        }
    }

    /// The cell holding ray parameter `at`.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn at(&self, at: __m256) -> Cell {
        let zi = _mm256_setzero_si256();
        let uc: [__m256; 3] =
            std::array::from_fn(|k| _mm256_add_ps(_mm256_fmadd_ps(self.per[k], at, self.start[k]), self.border));
        let c: [__m256i; 3] = std::array::from_fn(|k| {
            // Truncation, not floor: the two differ only below 0, which the
            // clamp takes to cell 0 either way (a rounding less on the
            // chain of lookups a pre-integrated leap waits for).
            let ci = _mm256_cvttps_epi32(_mm256_mul_ps(uc[k], _mm256_set1_ps(1.0 / CELL)));
            _mm256_min_epi32(_mm256_max_epi32(ci, zi), self.hi[k])
        });
        let index = _mm256_add_epi32(
            _mm256_add_epi32(_mm256_mullo_epi32(c[0], self.strides[0]), _mm256_mullo_epi32(c[1], self.strides[1])),
            c[2],
        );
        Cell { uc, c, index }
    }

    /// The ray parameter from the cell's point to where the ray leaves the
    /// cube of `cube` cells' radius around the cell (0 for none), at least 0.
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn exit(&self, cell: &Cell, cube: __m256i) -> __m256 {
        let far = _mm256_set1_ps(3.0e38);
        let mut exit = far;
        for k in 0..3 {
            let first = _mm256_sub_epi32(cell.c[k], _mm256_sub_epi32(cube, _mm256_set1_epi32(1)));
            let lo = _mm256_mul_ps(_mm256_cvtepi32_ps(first), _mm256_set1_ps(CELL));
            let up = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(cell.c[k], cube)), _mm256_set1_ps(CELL));
            let side = _mm256_blendv_ps(lo, up, self.ahead[k]);
            let tk = _mm256_mul_ps(_mm256_sub_ps(side, cell.uc[k]), self.per_voxel[k]);
            let tk = if self.back { _mm256_sub_ps(_mm256_setzero_ps(), tk) } else { tk };
            exit = _mm256_min_ps(exit, _mm256_blendv_ps(far, tk, self.moving[k]));
        }
        _mm256_max_ps(exit, _mm256_setzero_ps())
    }
}

/// The byte of each lane's cell `index` in `codes`, a byte a cell.
///
/// # Safety
/// Every index addresses a cell, and three readable bytes follow the last.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) unsafe fn byte(codes: *const u8, index: __m256i) -> __m256i {
    // SAFETY: the caller's contract: a 32-bit read at each cell.
    let word = unsafe { _mm256_i32gather_epi32::<1>(codes as *const i32, index) };
    _mm256_and_si256(word, _mm256_set1_epi32(0xff))
}
