//! Maximum, minimum and average intensity projections in the native march
//! (shaders/projections.wgsl): eight rays in the lanes of AVX2 registers,
//! one trilinear read at each segment's midpoint, NaN values passed over,
//! and the pixel the transfer function's premultiplied colour of the value
//! projected. Every value counts, whatever its opacity; but the table
//! clamps values to [0, 1], so a ray whose maximum reaches 1 (whose minimum
//! reaches 0) has its pixel and stops, as the shader's do. A maximum
//! (minimum) projection's ray leaps over a cell whose values cannot pass
//! its maximum (minimum) so far (`Frame::bounds`): the same pixel from
//! fewer reads, by the shader's rule.

use super::cells::Cells;
use super::{compositing::*, ops::*, sampling::*};
use super::{Frame, Model, Stats, TILE};
use std::arch::x86_64::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Pixels col0..col0 + 8 of `row` of a projection (`f.model` is Mip, MinIp
/// or Average); stops early (its pixels then are garbage) once `halt` is set.
/// In a brick's march (`stopped` given, as `super::ops::march` takes it)
/// `out` holds each ray's state before and after: (the maximum or minimum,
/// 1 where a value was read) or (the sum of value times length, the length).
/// A brick's maximum that reaches 1 (minimum 0) stops its ray as in one
/// texture.
///
/// # Safety
/// Needs AVX2, FMA and F16C, and the texels followed by the padding their reads
/// need (`Texels::padded`, which `super::render` checks).
#[target_feature(enable = "avx2,fma,f16c")]
pub unsafe fn project<T: Texels>(
    f: &Frame,
    tex: &T,
    col0: u32,
    row: u32,
    out: &mut [[f32; 4]; TILE],
    halt: &AtomicBool,
    stopped_before: Option<&mut u8>,
) -> Stats {
    let p = f.params;
    let dims = f.volume.dims;
    // SAFETY: the caller checked AVX2, FMA and F16C.
    let rays = unsafe { super::rays8::rays(f, col0, row) };
    let set = _mm256_set1_ps;
    let (zero, zi) = (_mm256_setzero_ps(), _mm256_setzero_si256());
    let (start, per) = voxel_axes(p, &rays, dims);
    let spans = Spans::new(p, &rays);
    let hi: [__m256i; 3] = dims.map(|d| _mm256_set1_epi32(d as i32 - 1));
    let stride = tex.strides(dims).map(|s| _mm256_set1_epi32(s));
    // `value_prescale` is left out: the caller joins a split scale into `value_scale`.
    let value_scale = set(p.value_scale * T::VALUE_UNIT);
    let value_offset = set(p.value_offset);
    let offset_size = set(p.value_offset.abs());
    let as_ps = _mm256_castsi256_ps;

    let mut i = rays.lo;
    // Lanes whose segments are not all marched. Their steps never wait on
    // the values read (the next read's address would then wait on this
    // one's, and reads would no longer overlap); a lane that has stopped
    // reads nothing more, and the march ends when every lane is done or
    // stopped.
    let mut going = as_ps(_mm256_cmpgt_epi32(rays.hi, i));
    // The maximum or minimum so far (`seen`: where a value was read), or
    // the sums of value times length and of length.
    let (mut best, mut seen) = (zero, zero);
    let (mut sum, mut length) = (zero, zero);
    let mut taken = zi;
    let mut stopped = zero;
    if let Some(before) = stopped_before.as_deref() {
        // The rays go on from their state (projections.wgsl `march_project`).
        going = _mm256_andnot_ps(lanes_of(*before), going);
        let column = |c: usize| _mm256_and_ps(channel(out, c), rays.hit);
        if f.model == Model::Average {
            (sum, length) = (column(0), column(1));
        } else {
            best = column(0);
            seen = _mm256_cmp_ps::<_CMP_GT_OQ>(column(1), zero);
        }
    }
    // The cells' bounds, where rays leap.
    let leaps = f.bounds.as_ref().filter(|_| f.model != Model::Average);
    let cells = leaps.map(|b| Cells::new(p, start, per, b.grid, false));
    let h = set(p.step_size);
    let mut steps = 0u32;
    while _mm256_movemask_ps(_mm256_andnot_ps(stopped, going)) != 0 {
        let active = _mm256_andnot_ps(stopped, going);
        steps = steps.wrapping_add(1);
        if steps.is_multiple_of(1024) && halt.load(Ordering::Relaxed) {
            break;
        }
        let (start_at, seg) = spans.span(i);
        let mid = _mm256_fmadd_ps(seg, set(0.5), start_at);
        // Lanes that leap, and the segment each goes on from.
        let (mut leap, mut next) = (zero, i);
        if let (Some(b), Some(cells)) = (leaps, cells.as_ref()) {
            let can = _mm256_and_ps(active, seen);
            if _mm256_movemask_ps(can) != 0 {
                let cell = cells.at(mid);
                // The value so far, less 1e-6 of the f32 mapping's terms (`value_bounds`).
                let slack = _mm256_mul_ps(_mm256_add_ps(_mm256_andnot_ps(set(-0.0), best), offset_size), set(1e-6));
                let passed = |bounds: &[f32]| {
                    // SAFETY: the cell is clamped into the grid, a bound a cell.
                    let bound = unsafe { _mm256_i32gather_ps::<4>(bounds.as_ptr(), cell.index) };
                    if f.model == Model::Mip {
                        _mm256_cmp_ps::<_CMP_LE_OQ>(bound, _mm256_add_ps(best, slack))
                    } else {
                        _mm256_cmp_ps::<_CMP_GE_OQ>(bound, _mm256_sub_ps(best, slack))
                    }
                };
                leap = _mm256_and_ps(can, passed(&b.cell));
                if _mm256_movemask_ps(leap) != 0 {
                    // Out of the cube where its bound is passed too, else
                    // the cell; to the first segment whose midpoint lies past
                    // it, a thousandth of a step early (compositing.wgsl `segment_past`).
                    let far = _mm256_castps_si256(passed(&b.wide));
                    let cube = _mm256_blendv_epi8(_mm256_set1_epi32(1), _mm256_set1_epi32(b.reach), far);
                    let exit = cells.exit(&cell, cube);
                    let past = _mm256_sub_ps(_mm256_div_ps(_mm256_add_ps(mid, exit), h), set(0.5));
                    let kf = _mm256_ceil_ps(_mm256_sub_ps(past, _mm256_add_ps(rays.shift, set(1e-3))));
                    let after = _mm256_cvtepi32_ps(_mm256_add_epi32(i, _mm256_set1_epi32(1)));
                    let kf = _mm256_min_ps(_mm256_max_ps(kf, after), _mm256_cvtepi32_ps(rays.hi));
                    next = _mm256_cvttps_epi32(kf);
                }
            }
        }
        let reads = _mm256_and_ps(_mm256_andnot_ps(leap, active), _mm256_cmp_ps::<_CMP_GT_OQ>(seg, zero));
        taken = _mm256_sub_epi32(taken, _mm256_castps_si256(reads));
        let u: [__m256; 3] = std::array::from_fn(|k| _mm256_fmadd_ps(per[k], mid, start[k]));
        let (offs, w) = corners(&u, &hi, &stride);
        // SAFETY: the offsets are clamped into the texture.
        let texel = unsafe { tex.trilinear(&offs, &w) };
        let v = _mm256_fmadd_ps(texel[0], value_scale, value_offset);
        let valid = _mm256_and_ps(reads, _mm256_cmp_ps::<_CMP_ORD_Q>(v, v));
        match f.model {
            Model::Average => {
                sum = _mm256_blendv_ps(sum, _mm256_add_ps(sum, _mm256_mul_ps(v, seg)), valid);
                length = _mm256_blendv_ps(length, _mm256_add_ps(length, seg), valid);
            }
            model => {
                let mip = model == Model::Mip;
                let kept = if mip { _mm256_max_ps(best, v) } else { _mm256_min_ps(best, v) };
                best = _mm256_blendv_ps(best, _mm256_blendv_ps(v, kept, seen), valid);
                seen = _mm256_or_ps(seen, valid);
                let done = if mip {
                    _mm256_cmp_ps::<_CMP_GE_OQ>(best, set(1.0))
                } else {
                    _mm256_cmp_ps::<_CMP_LE_OQ>(best, zero)
                };
                stopped = _mm256_or_ps(stopped, _mm256_and_ps(valid, done));
            }
        }
        i = _mm256_sub_epi32(i, _mm256_castps_si256(going));
        i = _mm256_castps_si256(_mm256_blendv_ps(as_ps(i), as_ps(next), leap));
        going = _mm256_and_ps(going, as_ps(_mm256_cmpgt_epi32(rays.hi, i)));
    }

    let (best, seen, sum, length) = (lanes(best), lanes(seen), lanes(sum), lanes(length));
    let brick = stopped_before.is_some();
    leave_row(&rays, taken, stopped, out, stopped_before, |l| {
        let seen = seen[l].to_bits() != 0;
        if brick {
            return match f.model {
                Model::Average => [sum[l], length[l], 0.0, 0.0],
                _ => [best[l], if seen { 1.0 } else { 0.0 }, 0.0, 0.0],
            };
        }
        let value = match f.model {
            Model::Average if length[l] > 0.0 => sum[l] / length[l],
            _ if f.model != Model::Average && seen => best[l],
            _ => return [0.0; 4],
        };
        let c = crate::transfer::eval_lut(f.lut, value as f64).map(|c| c as f32);
        [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]]
    })
}
