//! The isosurface in the native march (shaders/isosurface.wgsl): eight
//! rays in the lanes of AVX2 registers test the chord's entry, each
//! segment's midpoint and its exit for the first value at or above the iso
//! value (NaN counts as below), leap the cells whose values cannot reach it,
//! bracket the crossing by bisection, place it by a secant step, and shade
//! it from the normal held in the texel there, or from the field's gradient
//! (central differences) where the texels hold none (under a directional
//! or a point light).

use super::{compositing::*, lighting::*, ops::*, sampling::*};
use super::{Frame, Stats, TILE};
use crate::plan::ISO_BISECTIONS;
use std::arch::x86_64::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Pixels col0..col0 + 8 of `row` of an isosurface frame, and each ray's
/// hit distance (from the camera, in the box's longest side; infinity on a
/// miss) in `depth`; stops early (its pixels then are garbage) once `halt`
/// is set.
///
/// In a brick's march (`stopped` given, as `super::ops::march` takes it)
/// `out` holds each ray's state before and after: (the bracket's lower end,
/// its value, 1 where that value was read, 1 once the ray has started), or
/// for a ray that has ended (its bit in `stopped`) its pixel's colour and
/// hit distance (infinity on a miss). A ray starts in the brick holding its
/// entry, whose value it tests, or, where the bricks before were passed
/// over, from the last midpoint before its window (read from the ghosts);
/// the brick holding its last segment tests its exit.
///
/// # Safety
/// Needs AVX2, FMA and F16C; `f.cells`, where given, is followed by three
/// readable bytes, and the texels by the padding their reads need
/// (`Texels::padded`, which `super::render` checks).
#[target_feature(enable = "avx2,fma,f16c")]
pub unsafe fn iso<T: Texels>(
    f: &Frame,
    tex: &T,
    col0: u32,
    row: u32,
    out: &mut [[f32; 4]; TILE],
    depth: &mut [f32; TILE],
    halt: &AtomicBool,
    stopped_before: Option<&mut u8>,
) -> Stats {
    let p = f.params;
    let dims = f.volume.dims;
    // SAFETY: the caller checked AVX2, FMA and F16C.
    let rays = unsafe { super::rays8::rays(f, col0, row) };
    let set = _mm256_set1_ps;
    let (zero, zi, onei) = (_mm256_setzero_ps(), _mm256_setzero_si256(), _mm256_set1_epi32(1));
    let as_ps = _mm256_castsi256_ps;
    let (start, per) = voxel_axes(p, &rays, dims);
    let h = set(p.step_size);
    let spans = Spans::new(p, &rays);
    let hi: [__m256i; 3] = dims.map(|d| _mm256_set1_epi32(d as i32 - 1));
    let stride = tex.strides(dims).map(|s| _mm256_set1_epi32(s));
    // `value_prescale` is left out: the caller joins a split scale into `value_scale`.
    let (value_scale, value_offset) = (set(p.value_scale * T::VALUE_UNIT), set(p.value_offset));
    let iso_value = set(p.iso_value);
    let coords = |at: __m256| -> [__m256; 3] { std::array::from_fn(|k| _mm256_fmadd_ps(per[k], at, start[k])) };
    let texel_at = |at: __m256| -> [__m256; 4] {
        let (offs, w) = corners(&coords(at), &hi, &stride);
        // SAFETY: the offsets are clamped into the texture.
        unsafe { tex.trilinear(&offs, &w) }
    };
    let value_at = |at: __m256| _mm256_fmadd_ps(texel_at(at)[0], value_scale, value_offset);
    // NaN counts as below.
    let reaches = |v: __m256| _mm256_cmp_ps::<_CMP_GE_OQ>(v, iso_value);
    let midpoint = |i: __m256i| -> __m256 {
        let (start_at, seg) = spans.span(i);
        _mm256_fmadd_ps(seg, set(0.5), start_at)
    };
    // Cells leapt: the empty radius codes of the cells that cannot reach the iso value.
    let (radius_grid, grid) = match f.cells {
        Some((g, d)) if f.skip_empty => (g.as_ptr(), d),
        _ => (std::ptr::null(), [1, 1, 1]),
    };
    let cells = super::cells::Cells::new(p, start, per, grid, false);
    let n = rays.n;
    // Rays whose every step was taken test their exit too.
    let whole = as_ps(_mm256_cmpeq_epi32(n, _mm256_cvttps_epi32(_mm256_min_ps(rays.needed, set(2.0e9)))));
    let mut whole = _mm256_and_ps(whole, _mm256_cmp_ps::<_CMP_LT_OQ>(rays.needed, set(2.0e9)));
    // Segments [i, end) are marched: all of them, or a brick's window.
    let (mut i, mut end) = (zi, n);

    // The entry: a ray starting inside the surface hits at 0.
    let mut taken = _mm256_and_si256(_mm256_castps_si256(rays.hit), onei);
    let mut prev = zero;
    let mut prev_v = value_at(zero);
    let mut prev_known = rays.hit;
    let mut found = _mm256_and_ps(rays.hit, reaches(prev_v));
    let mut started = rays.hit;
    // A brick's lanes with segments in it (the others keep their state).
    let mut open = rays.hit;
    if let Some(before) = stopped_before.as_deref() {
        let column = |c: usize| channel(out, c);
        open =
            _mm256_andnot_ps(lanes_of(*before), _mm256_and_ps(rays.hit, as_ps(_mm256_cmpgt_epi32(rays.hi, rays.lo))));
        let was_started = _mm256_cmp_ps::<_CMP_NEQ_UQ>(column(3), zero);
        let entry = _mm256_andnot_ps(was_started, _mm256_and_ps(open, as_ps(_mm256_cmpeq_epi32(rays.lo, zi))));
        let resumed = _mm256_andnot_ps(entry, open);
        let begins = _mm256_andnot_ps(was_started, resumed);
        // A ray starting past its entry brackets from the midpoint before its window.
        let before_window = midpoint(_mm256_sub_epi32(rays.lo, onei));
        prev = _mm256_blendv_ps(_mm256_blendv_ps(zero, column(0), resumed), before_window, begins);
        let read = _mm256_or_ps(entry, begins);
        let v = value_at(prev);
        prev_v = _mm256_blendv_ps(column(1), v, read);
        prev_known = _mm256_or_ps(read, _mm256_and_ps(resumed, _mm256_cmp_ps::<_CMP_NEQ_UQ>(column(2), zero)));
        taken = _mm256_and_si256(_mm256_castps_si256(read), onei);
        found = _mm256_and_ps(entry, reaches(v));
        started = _mm256_or_ps(read, _mm256_and_ps(open, was_started));
        (i, end) = (rays.lo, rays.hi);
        // Only the brick holding a ray's last segment tests its exit.
        whole = _mm256_and_ps(whole, as_ps(_mm256_cmpeq_epi32(end, n)));
    }
    let mut hit_at = zero;
    // Lanes still marching: their ray has started, has not hit, and has points left.
    let mut going = _mm256_andnot_ps(found, started);
    let mut steps = 0u32;
    loop {
        // Segment i's midpoint while i < end; the exit at i == n for a whole ray.
        let inside = as_ps(_mm256_cmpgt_epi32(end, i));
        let exit = _mm256_and_ps(whole, as_ps(_mm256_cmpeq_epi32(i, n)));
        going = _mm256_and_ps(going, _mm256_or_ps(inside, exit));
        if _mm256_movemask_ps(going) == 0 {
            break;
        }
        steps = steps.wrapping_add(1);
        if steps.is_multiple_of(1024) && halt.load(Ordering::Relaxed) {
            break;
        }
        let at = _mm256_blendv_ps(rays.chord, midpoint(i), inside);
        i = _mm256_sub_epi32(i, _mm256_castps_si256(going));
        let v = value_at(at);
        taken = _mm256_sub_epi32(taken, _mm256_castps_si256(going));
        let hits = _mm256_and_ps(going, reaches(v));
        if _mm256_movemask_ps(hits) != 0 {
            // The bracket's lower end, read now where a leap left it unread.
            let unread = _mm256_andnot_ps(prev_known, hits);
            if _mm256_movemask_ps(unread) != 0 {
                prev_v = _mm256_blendv_ps(prev_v, value_at(prev), unread);
                taken = _mm256_sub_epi32(taken, _mm256_castps_si256(unread));
            }
            // isosurface.wgsl `locate_crossing`.
            let (mut lo, mut up, mut vlo, mut vup) = (prev, at, prev_v, v);
            for _ in 0..ISO_BISECTIONS {
                let m = _mm256_mul_ps(set(0.5), _mm256_add_ps(lo, up));
                let vm = value_at(m);
                let above = reaches(vm);
                lo = _mm256_blendv_ps(m, lo, above);
                vlo = _mm256_blendv_ps(vm, vlo, above);
                up = _mm256_blendv_ps(up, m, above);
                vup = _mm256_blendv_ps(vup, vm, above);
            }
            let bisections = _mm256_set1_epi32(ISO_BISECTIONS as i32);
            taken = _mm256_add_epi32(taken, _mm256_and_si256(_mm256_castps_si256(hits), bisections));
            let t = _mm256_div_ps(_mm256_sub_ps(iso_value, vlo), _mm256_sub_ps(vup, vlo));
            let t = _mm256_min_ps(_mm256_max_ps(t, zero), set(1.0));
            let secant = _mm256_and_ps(_mm256_cmp_ps::<_CMP_ORD_Q>(vlo, vlo), _mm256_cmp_ps::<_CMP_GT_OQ>(vup, vlo));
            let placed = _mm256_blendv_ps(up, _mm256_fmadd_ps(_mm256_sub_ps(up, lo), t, lo), secant);
            hit_at = _mm256_blendv_ps(hit_at, placed, hits);
            found = _mm256_or_ps(found, hits);
            going = _mm256_andnot_ps(hits, going);
        }
        let below = _mm256_andnot_ps(hits, going);
        prev = _mm256_blendv_ps(prev, at, below);
        prev_v = _mm256_blendv_ps(prev_v, v, below);
        prev_known = _mm256_or_ps(prev_known, below);
        if !radius_grid.is_null() {
            // isosurface.wgsl `iso_leap`: from a point below the iso value in
            // an empty cube, to the first midpoint past it, keeping the last
            // midpoint inside as the bracket's (unread) lower end.
            let may = _mm256_and_ps(below, as_ps(_mm256_cmpgt_epi32(_mm256_add_epi32(end, onei), i)));
            if _mm256_movemask_ps(may) != 0 {
                let cell = cells.at(at);
                // SAFETY: the cell is clamped into the grid, whose codes are followed by three bytes.
                let radius = unsafe { super::cells::byte(radius_grid, cell.index) };
                let flagged = _mm256_cmpgt_epi32(radius, _mm256_set1_epi32(crate::occupancy::UNIFORM_FLAG as i32 - 1));
                let radius = _mm256_andnot_si256(flagged, radius);
                let empty = _mm256_and_ps(may, as_ps(_mm256_cmpgt_epi32(radius, zi)));
                if _mm256_movemask_ps(empty) != 0 {
                    let exit = cells.exit(&cell, radius);
                    let kf = _mm256_ceil_ps(_mm256_sub_ps(
                        _mm256_sub_ps(_mm256_div_ps(_mm256_add_ps(at, exit), h), set(0.5)),
                        _mm256_add_ps(rays.shift, set(1e-3)),
                    ));
                    let kf = _mm256_min_ps(_mm256_max_ps(kf, _mm256_cvtepi32_ps(i)), _mm256_cvtepi32_ps(end));
                    let next = _mm256_cvttps_epi32(kf);
                    let leaps = _mm256_and_ps(empty, as_ps(_mm256_cmpgt_epi32(next, i)));
                    prev = _mm256_blendv_ps(prev, midpoint(_mm256_sub_epi32(next, onei)), leaps);
                    prev_known = _mm256_andnot_ps(leaps, prev_known);
                    i = _mm256_castps_si256(_mm256_blendv_ps(as_ps(i), as_ps(next), leaps));
                }
            }
        }
    }

    // isosurface.wgsl `shade_hit`: the table's colour at the iso value, lit
    // at the hit by the texel's normal or the field's gradient there.
    let normal_at = |at: __m256| {
        if f.gradient {
            // SAFETY: the texels hold the padding their reads need (the caller's contract).
            unsafe { gradient_at(tex, p, &coords(at), zero, &hi, &stride, None) }
        } else {
            texel_at(at)
        }
    };
    let light = if f.lit && f.point_light {
        let (travel, defined) = point_light_travel(p, &rays, hit_at);
        _mm256_blendv_ps(set(p.ambient), lit_by(&normal_at(hit_at), &travel, set(p.ambient), set(p.diffuse)), defined)
    } else if f.lit && p.light_valid == 1 {
        let light_dir: [__m256; 3] = std::array::from_fn(|k| set(p.light_dir[k]));
        lit_by(&normal_at(hit_at), &light_dir, set(p.ambient), set(p.diffuse))
    } else {
        set(p.ambient)
    };
    let (found, light, hit_at) = (lanes(found), lanes(light), lanes(hit_at));
    let (t0, needed) = (lanes(rays.t0), lanes(rays.needed));
    let (counts, steps_n) = (int_lanes(taken), int_lanes(rays.n));
    let c = crate::transfer::eval_lut(f.lut, p.iso_value as f64).map(|c| c as f32);
    let hits = _mm256_movemask_ps(rays.hit);
    let mut stats = Stats::default();
    if let Some(before) = stopped_before {
        let earlier = *before;
        let (state, ends) = ([lanes(prev), lanes(prev_v), lanes(prev_known), lanes(started)], int_lanes(end));
        let open = _mm256_movemask_ps(open);
        for l in (0..TILE).filter(|l| open & (1 << l) != 0 && earlier & (1 << l) == 0) {
            stats.samples += counts[l] as u64;
            let set = |x: f32| if x.to_bits() != 0 { 1.0 } else { 0.0 };
            if found[l].to_bits() != 0 {
                out[l] = [c[0] * light[l], c[1] * light[l], c[2] * light[l], t0[l] + hit_at[l]];
                *before |= 1 << l;
            } else if state[3][l].to_bits() != 0 && ends[l] == steps_n[l] {
                // Past its last segment (and exit) without a hit: a miss.
                let needed = needed[l] as u32;
                if truncated_here(0, ends[l], steps_n[l], needed, false) {
                    stats.truncated_needed = stats.truncated_needed.max(needed);
                }
                out[l] = [0.0, 0.0, 0.0, f32::INFINITY];
                *before |= 1 << l;
            } else {
                out[l] = [state[0][l], state[1][l], set(state[2][l]), set(state[3][l])];
            }
        }
        return stats;
    }
    for l in 0..TILE {
        out[l] = [0.0; 4];
        depth[l] = f32::INFINITY;
        if hits & (1 << l) == 0 {
            continue;
        }
        stats.samples += counts[l] as u64;
        if found[l].to_bits() == 0 {
            // (`as u32` saturates, as the scalar rule's conversion does.)
            let needed = needed[l] as u32;
            if (steps_n[l] as u32) < needed {
                stats.truncated_needed = stats.truncated_needed.max(needed);
            }
            continue;
        }
        out[l] = [c[0] * light[l], c[1] * light[l], c[2] * light[l], 1.0];
        depth[l] = t0[l] + hit_at[l];
    }
    stats
}
