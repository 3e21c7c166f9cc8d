//! Unbiased frames (tracking.wgsl `march_tracking`): ratio tracking on the
//! segment grid in the eight lanes of AVX2 registers. Each lane walks its
//! own ray's blocks of Poisson points, from the shader's integer streams,
//! so both engines draw the same points up to the rounding of their
//! logarithms; then the eight points are read, lit and composited together.

use super::cells::byte;
use super::rays8::hash32;
use super::{compositing::*, lighting::*, ops::*, sampling::*};
use super::{Frame, Model, Stats, TILE};
use crate::occupancy::UNIFORM_FLAG;
use std::arch::x86_64::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::LazyLock;

/// Samples per partial sum: 2^BLOCK_SHIFT (compositing.wgsl).
const BLOCK_SHIFT: i32 = 8;
/// Rounds of the search for the next points between looks at the halt flag.
const ROUNDS_PER_LOOK: u32 = 1 << 16;
/// Each majorant code's rate, 2^((q - 128) / 16) per reference step
/// (`occupancy::majorant_code`).
static CODE_RATES: LazyLock<[f32; 256]> = LazyLock::new(|| std::array::from_fn(|q| ((q as f32 - 128.0) / 16.0).exp2()));

/// (f32(x >> 8) + 0.5) / 2^24 of eight 32-bit words: uniform in (0, 1].
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn unit(x: __m256i) -> __m256 {
    let top = _mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(x));
    _mm256_mul_ps(_mm256_add_ps(top, _mm256_set1_ps(0.5)), _mm256_set1_ps(1.0 / 16_777_216.0))
}

/// Each stream's next gap at its rate, and the advanced streams
/// (tracking.wgsl `next_gap` of `stream_uniform`).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn next_gap(state: __m256i, rate: __m256) -> (__m256, __m256i) {
    let state = _mm256_add_epi32(
        _mm256_mullo_epi32(state, _mm256_set1_epi32(747_796_405)),
        _mm256_set1_epi32(2_891_336_453_u32 as i32),
    );
    let u = unit(hash32(state));
    (_mm256_div_ps(_mm256_sub_ps(_mm256_setzero_ps(), ln(u)), rate), state)
}

/// Pixels col0..col0 + 8 of `row` of an unbiased frame (emission–absorption,
/// absorption or emission, either marching order; one pass). With
/// `stopped_before` (a brick of a bricked frame, as `compositing::march` takes
/// it): `out` holds each ray's state, which the walk goes on from and
/// leaves there, and the lanes whose rays have stopped; back to front, the
/// bricks come far to near. A block's points come from its own stream, so
/// each brick draws the points of its window that the one texture would.
///
/// Stops early (its pixels then are garbage) once `halt` is set.
///
/// # Safety
/// Needs AVX2, FMA and F16C; `f.cells` and `f.majorants`, where given, are
/// followed by three readable bytes, and the texels by the padding their
/// reads need.
#[target_feature(enable = "avx2,fma,f16c")]
pub unsafe fn track<T: Texels>(
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
    let rays = super::rays8::rays(f, col0, row);
    let (start, per) = voxel_axes(p, &rays, dims);
    let set = _mm256_set1_ps;
    let seti = _mm256_set1_epi32;
    let as_ps = _mm256_castsi256_ps;
    let as_si = _mm256_castps_si256;
    let (zero, one) = (_mm256_setzero_ps(), set(1.0));
    let (zi, onei) = (_mm256_setzero_si256(), seti(1));
    let yes = as_ps(seti(-1));
    let any = |m: __m256| _mm256_movemask_ps(m) != 0;
    let hi: [__m256i; 3] = dims.map(|d| seti(d as i32 - 1));
    let stride = tex.strides(dims).map(|s| seti(s));
    let value_scale = set(p.value_scale * T::VALUE_UNIT);
    let value_offset = set(p.value_offset);
    let h = set(p.step_size);

    // Each lane's ray: its pixel's index, segments, window end and blocks.
    let cols = _mm256_add_epi32(seti(col0 as i32), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    let idx = _mm256_add_epi32(seti(row.wrapping_mul(p.width) as i32), cols);
    let n = rays.n;
    let spans = Spans::new(p, &rays);
    // Segments per block (tracking.wgsl `block_size`), a power of two.
    let block_shift = if f.majorants.is_some() { 0 } else { 3 };
    let shift_v = _mm_cvtsi32_si128(block_shift);
    let last_segment = _mm256_sub_epi32(n, onei);
    let w_hi = {
        let (a, len) = spans.span(_mm256_max_epi32(_mm256_sub_epi32(rays.hi, onei), zi));
        _mm256_add_ps(a, len)
    };
    let block_span = |k: __m256i| -> (__m256, __m256) {
        let first = spans.span(_mm256_sll_epi32(k, shift_v));
        let end = _mm256_min_epi32(_mm256_sll_epi32(_mm256_add_epi32(k, onei), shift_v), n);
        let last = spans.span(_mm256_sub_epi32(end, onei));
        (first.0, _mm256_sub_ps(_mm256_add_ps(last.0, last.1), first.0))
    };
    // The block holding ray offset t.
    let block_at = |t: __m256| -> __m256i {
        let i = _mm256_floor_ps(_mm256_sub_ps(_mm256_div_ps(t, h), rays.shift));
        let i = _mm256_min_ps(_mm256_max_ps(i, zero), _mm256_cvtepi32_ps(last_segment));
        _mm256_srl_epi32(_mm256_cvttps_epi32(i), shift_v)
    };
    let seed = seti(crate::model::hash32(p.jitter_seed ^ 0x68e3_1da4) as i32);
    let stream = |k: __m256i| hash32(_mm256_xor_si256(idx, hash32(_mm256_xor_si256(k, seed))));

    // The occupancy cells along the rays, and their codes.
    let (grid, codes) = match f.cells {
        Some((codes, grid)) => (grid, codes.as_ptr()),
        None => ([1; 3], std::ptr::null()),
    };
    let back = f.back_to_front;
    let cells = super::cells::Cells::new(p, start, per, grid, back);
    let skip_empty = f.skip_empty && !codes.is_null();
    // A block's rate (tracking.wgsl `segment_rate`): its midpoint cell's
    // majorant between a point a step and the frame's rate; 0 for an empty
    // cell when leaping.
    let track_rate = set(p.track_rate);
    let rate_of = |bstart: __m256, blen: __m256| -> __m256 {
        let Some(majorants) = f.majorants else {
            return track_rate;
        };
        let cell = cells.at(_mm256_fmadd_ps(blen, set(0.5), bstart));
        // SAFETY: the cell is clamped into the grid, whose majorants are
        // followed by three bytes (`super::render` checks).
        let q = unsafe { byte(majorants.as_ptr(), cell.index) };
        let own = _mm256_mul_ps(_mm256_i32gather_ps::<4>(CODE_RATES.as_ptr(), q), set(p.inv_ref));
        let frame_rate = _mm256_or_si256(_mm256_cmpeq_epi32(q, zi), _mm256_cmpeq_epi32(q, seti(255)));
        let rate = _mm256_blendv_ps(own, track_rate, as_ps(frame_rate));
        let rate = _mm256_min_ps(_mm256_max_ps(rate, set(1.0 / p.step_size)), track_rate);
        if skip_empty {
            _mm256_andnot_ps(as_ps(_mm256_cmpeq_epi32(q, zi)), rate)
        } else {
            rate
        }
    };
    // Ray parameter from `at` to where the ray, marching on, leaves the
    // empty cube around its cell (skipping.wgsl `empty_cell_exit`), and the
    // lanes whose cell is empty.
    let empty_exit = |at: __m256| -> (__m256, __m256) {
        let cell = cells.at(at);
        // SAFETY: as in `rate_of`, for the occupancy codes.
        let code = unsafe { byte(codes, cell.index) };
        let flagged = _mm256_cmpgt_epi32(code, seti(UNIFORM_FLAG as i32 - 1));
        let radius = _mm256_andnot_si256(flagged, code);
        (cells.exit(&cell, radius), as_ps(_mm256_cmpgt_epi32(radius, zi)))
    };

    // The walk: block k (its span, stream and rate), the next point at
    // distance u from its near end in the march direction, points before
    // skip_to (in that direction) passed. Back to front, the blocks and
    // their points are taken from the far end.
    let w_lo = spans.span(rays.lo).0;
    let (mut k, mut state) =
        (_mm256_srl_epi32(if back { _mm256_sub_epi32(rays.hi, onei) } else { rays.lo }, shift_v), zi);
    let (mut bstart, mut blen, mut rate, mut u) = (zero, zero, zero, zero);
    let mut skip_to = if back { w_hi } else { w_lo };
    let first_block = _mm256_srl_epi32(rays.lo, shift_v);
    let mut entered = zero;
    let mut done =
        _mm256_or_ps(_mm256_xor_ps(rays.hit, yes), as_ps(_mm256_cmpgt_epi32(_mm256_add_epi32(rays.lo, onei), rays.hi)));
    // The sums (compositing.wgsl `Integration`).
    let (mut color, mut color_b) = ([zero; 3], [zero; 3]);
    let (mut tau, mut tau_b, mut trans) = (zero, zero, one);
    let (mut taken, mut blocks) = (zi, zi);
    let mut stopped = zero;
    let emission = f.model == Model::Emission;
    if let Some(before) = stopped_before.as_deref() {
        // The rays go on from their state (compositing.wgsl `start_integration`).
        done = _mm256_or_ps(done, lanes_of(*before));
        color = std::array::from_fn(|c| _mm256_and_ps(channel(out, c), rays.hit));
        tau = _mm256_and_ps(channel(out, 3), rays.hit);
        trans = exp_nonpositive(_mm256_sub_ps(zero, tau));
    }
    let roll_seed = seti(crate::model::hash32(p.jitter_seed ^ 0x2545_f491) as i32);
    let q = 1.0 - p.threshold;
    let (q_v, q_depth) = (set(q), set(if q > 0.0 { -q.ln() } else { 0.0 }));
    let (mut passes, mut rounds) = (0u32, 0u32);
    'march: loop {
        // Each lane moves on to its next point: past exhausted blocks and
        // points before its landing; lanes without one are done.
        let mut pending = _mm256_xor_ps(done, yes);
        let (mut found, mut at) = (zero, zero);
        while any(pending) {
            rounds = rounds.wrapping_add(1);
            if rounds % ROUNDS_PER_LOOK == 0 && halt.load(Ordering::Relaxed) {
                break 'march;
            }
            let enter = _mm256_andnot_ps(entered, pending);
            if any(enter) {
                let (bs, bl) = block_span(k);
                let fresh = stream(k);
                let r = rate_of(bs, bl);
                // No points in an empty block: it is passed at once.
                let points = _mm256_and_ps(enter, _mm256_cmp_ps::<_CMP_GT_OQ>(r, zero));
                let (gap, advanced) = next_gap(fresh, r);
                bstart = _mm256_blendv_ps(bstart, bs, enter);
                blen = _mm256_blendv_ps(blen, bl, enter);
                rate = _mm256_blendv_ps(rate, r, enter);
                u = _mm256_blendv_ps(u, _mm256_blendv_ps(set(3.0e38), gap, points), enter);
                state = as_si(_mm256_blendv_ps(as_ps(state), as_ps(fresh), enter));
                state = as_si(_mm256_blendv_ps(as_ps(state), as_ps(advanced), points));
                entered = _mm256_or_ps(entered, enter);
            }
            let exhausted = _mm256_and_ps(pending, _mm256_cmp_ps::<_CMP_GE_OQ>(u, blen));
            let (next_block, beyond) = if back {
                (_mm256_sub_epi32(k, onei), as_ps(_mm256_cmpgt_epi32(_mm256_add_epi32(first_block, onei), k)))
            } else {
                let next = _mm256_add_epi32(k, onei);
                (next, as_ps(_mm256_cmpgt_epi32(_mm256_sll_epi32(next, shift_v), _mm256_sub_epi32(rays.hi, onei))))
            };
            let last = _mm256_and_ps(exhausted, beyond);
            let moves = _mm256_andnot_ps(beyond, exhausted);
            k = as_si(_mm256_blendv_ps(as_ps(k), as_ps(next_block), moves));
            entered = _mm256_andnot_ps(moves, entered);
            let candidate = _mm256_andnot_ps(exhausted, pending);
            let (a, past, point) = if back {
                let a = _mm256_sub_ps(_mm256_add_ps(bstart, blen), u);
                (a, _mm256_cmp_ps::<_CMP_LT_OQ>(a, w_lo), _mm256_cmp_ps::<_CMP_LT_OQ>(a, skip_to))
            } else {
                let a = _mm256_add_ps(bstart, u);
                (a, _mm256_cmp_ps::<_CMP_GE_OQ>(a, w_hi), _mm256_cmp_ps::<_CMP_GE_OQ>(a, skip_to))
            };
            let past = _mm256_and_ps(candidate, past);
            let point = _mm256_andnot_ps(past, _mm256_and_ps(candidate, point));
            let passed = _mm256_andnot_ps(_mm256_or_ps(past, point), candidate);
            done = _mm256_or_ps(done, _mm256_or_ps(last, past));
            found = _mm256_or_ps(found, point);
            at = _mm256_blendv_ps(at, a, point);
            pending = _mm256_andnot_ps(_mm256_or_ps(_mm256_or_ps(last, past), point), pending);
            if any(passed) {
                let (gap, advanced) = next_gap(state, rate);
                u = _mm256_blendv_ps(u, _mm256_add_ps(u, gap), passed);
                state = as_si(_mm256_blendv_ps(as_ps(state), as_ps(advanced), passed));
            }
        }
        passes = passes.wrapping_add(1);
        if !any(found) || (passes % 1024 == 0 && halt.load(Ordering::Relaxed)) {
            break;
        }
        taken = _mm256_sub_epi32(taken, as_si(found));
        let uv: [__m256; 3] = std::array::from_fn(|k| _mm256_fmadd_ps(per[k], at, start[k]));
        let (offs, w) = corners(&uv, &hi, &stride);
        let texel = tex.trilinear(&offs, &w);
        // The point as a segment of opacity sigma / rate (tracking.wgsl
        // `tracked_point`); NaN reads as value 0 and opacity 0.
        let v = _mm256_fmadd_ps(texel[0], value_scale, value_offset);
        let valid = _mm256_cmp_ps::<_CMP_ORD_Q>(v, v);
        let rgba = lut_rgba(f.lut, _mm256_and_ps(v, valid));
        let a = _mm256_and_ps(rgba[3], valid);
        let sigma = if f.power { neg_log_one_minus(a) } else { a };
        let a = _mm256_div_ps(_mm256_mul_ps(sigma, set(p.inv_ref)), rate);
        let (x, add): (__m256, [__m256; 3]) = if emission {
            let x = _mm256_min_ps(a, set(1.0e30));
            (x, std::array::from_fn(|c| _mm256_mul_ps(x, rgba[c])))
        } else {
            let o = _mm256_min_ps(a, one);
            let absorbs_only = f.model == Model::Absorption;
            (neg_log_one_minus(o), std::array::from_fn(|c| if absorbs_only { zero } else { _mm256_mul_ps(o, rgba[c]) }))
        };
        let (gap, advanced) = next_gap(state, rate);
        u = _mm256_blendv_ps(u, _mm256_add_ps(u, gap), found);
        state = as_si(_mm256_blendv_ps(as_ps(state), as_ps(advanced), found));
        // A point with nothing in an empty cell: resume past its cube, a
        // thousandth of a step early (rounding must never pass an occupied point).
        let shows = _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero);
        let mut live = found;
        if skip_empty {
            let idle = _mm256_andnot_ps(shows, found);
            if any(idle) {
                let (exit, empty) = empty_exit(at);
                let leap = _mm256_and_ps(idle, empty);
                let landing = if back {
                    _mm256_fmadd_ps(set(1e-3), h, _mm256_sub_ps(at, exit))
                } else {
                    _mm256_fnmadd_ps(set(1e-3), h, _mm256_add_ps(at, exit))
                };
                skip_to = _mm256_blendv_ps(skip_to, landing, leap);
                let next =
                    if back { _mm256_min_epi32(block_at(skip_to), k) } else { _mm256_max_epi32(block_at(skip_to), k) };
                let moved = _mm256_andnot_ps(as_ps(_mm256_cmpeq_epi32(next, k)), leap);
                k = as_si(_mm256_blendv_ps(as_ps(k), as_ps(next), moved));
                entered = _mm256_andnot_ps(moved, entered);
                live = _mm256_andnot_ps(leap, live);
            }
        }
        if !any(live) {
            continue;
        }
        // The light a point takes where it emits (compositing.wgsl `lit`).
        let light = sample_light(f, tex, &rays, &uv, &texel, at, &hi, &stride, None);
        let add = add.map(|c| _mm256_blendv_ps(c, _mm256_mul_ps(c, light), shows));
        // compositing.wgsl `composite`: back to front C = c + e^-x C (the
        // emission model's sum alone), else front to back.
        if back {
            let behind = if emission { one } else { exp_nonpositive(_mm256_sub_ps(zero, x)) };
            for c in 0..3 {
                color[c] = _mm256_blendv_ps(color[c], _mm256_fmadd_ps(behind, color[c], add[c]), live);
            }
        } else {
            let weight = _mm256_and_ps(trans, live);
            for c in 0..3 {
                color_b[c] = _mm256_fmadd_ps(weight, add[c], color_b[c]);
            }
        }
        if !emission {
            tau_b = _mm256_add_ps(tau_b, _mm256_and_ps(x, live));
        }
        let block = _mm256_srli_epi32::<BLOCK_SHIFT>(taken);
        let fold = _mm256_andnot_ps(as_ps(_mm256_cmpeq_epi32(block, blocks)), live);
        if any(fold) {
            blocks = as_si(_mm256_blendv_ps(as_ps(blocks), as_ps(block), fold));
            for c in 0..3 {
                color[c] = _mm256_add_ps(color[c], _mm256_and_ps(color_b[c], fold));
                color_b[c] = _mm256_andnot_ps(fold, color_b[c]);
            }
            tau = _mm256_add_ps(tau, _mm256_and_ps(tau_b, fold));
            tau_b = _mm256_andnot_ps(fold, tau_b);
        }
        if emission || back {
            continue;
        }
        let total = _mm256_add_ps(tau, tau_b);
        trans = _mm256_blendv_ps(trans, exp_nonpositive(_mm256_sub_ps(zero, total)), live);
        let faded = _mm256_and_ps(live, _mm256_cmp_ps::<_CMP_LT_OQ>(trans, set(1e-30)));
        trans = _mm256_andnot_ps(faded, trans);
        let mut stop = faded;
        if f.early_termination {
            let seen = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(total, zero),
                _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_sub_ps(one, trans), set(p.threshold)),
            );
            stop = _mm256_or_ps(stop, _mm256_and_ps(live, seen));
        }
        if any(stop) {
            // Russian roulette below transmittance q: on with probability
            // T / q at weight q, else stopped. Its number comes from the
            // point, not the block's stream.
            let roll = hash32(_mm256_xor_si256(as_si(at), hash32(_mm256_xor_si256(idx, roll_seed))));
            let xi = unit(roll);
            let on = if q > 0.0 {
                let odds = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_mul_ps(xi, q_v), trans);
                _mm256_and_ps(stop, _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(trans, zero), odds))
            } else {
                zero
            };
            let off = _mm256_andnot_ps(on, stop);
            for c in 0..3 {
                color[c] = _mm256_add_ps(color[c], _mm256_and_ps(color_b[c], on));
                color_b[c] = _mm256_andnot_ps(on, color_b[c]);
            }
            tau = _mm256_blendv_ps(_mm256_blendv_ps(tau, q_depth, on), set(1.0e30), off);
            tau_b = _mm256_andnot_ps(stop, tau_b);
            trans = _mm256_andnot_ps(off, _mm256_blendv_ps(trans, q_v, on));
            stopped = _mm256_or_ps(stopped, off);
            done = _mm256_or_ps(done, off);
        }
    }

    let (color, tau) = (std::array::from_fn(|c| _mm256_add_ps(color[c], color_b[c])), _mm256_add_ps(tau, tau_b));
    leave_composited(&rays, taken, stopped, (color, tau, trans), emission, out, stopped_before)
}
