//! Eight rays in the lanes of AVX2 registers (shaders/compositing.wgsl):
//! each lane walks its own segment index, leaping or compositing as the
//! shader's invocation would, until every lane's ray is done.

use super::lighting::*;
use super::ops::*;
use super::sampling::*;
use super::{Frame, Model, Stats, CHAIN, TILE};
use crate::plan::params::Params;
use std::arch::x86_64::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// compositing.wgsl's REFINE_EPS.
pub(super) const REFINE_EPS: f32 = crate::preintegrate::REFINE_OPACITY_CHANGE as f32;

/// The segment grid of eight rays (rays.wgsl `span`): segment i starts
/// i + shift steps past the chord's start (the first one at the start,
/// shorter under jitter) and ends a step later or at the chord's end.
pub(super) struct Spans {
    h: __m256,
    shift_h: __m256,
    first_len: __m256,
    chord: __m256,
}

impl Spans {
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn new(p: &Params, rays: &super::rays8::Rays) -> Spans {
        let h = _mm256_set1_ps(p.step_size);
        let first_len = _mm256_min_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_set1_ps(1.0), rays.shift), h), rays.chord);
        Spans { h, shift_h: _mm256_mul_ps(rays.shift, h), first_len, chord: rays.chord }
    }

    /// Segment i's start and length (0 past the chord).
    #[inline]
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) fn span(&self, i: __m256i) -> (__m256, __m256) {
        let zero = _mm256_setzero_ps();
        let a = _mm256_fmadd_ps(_mm256_cvtepi32_ps(i), self.h, self.shift_h);
        let before = _mm256_cmp_ps::<_CMP_LT_OQ>(a, zero);
        let len = _mm256_max_ps(_mm256_min_ps(self.h, _mm256_sub_ps(self.chord, a)), zero);
        (_mm256_andnot_ps(before, a), _mm256_blendv_ps(len, self.first_len, before))
    }
}

/// Pixels col0..col0 + 8 of `row` (those without a ray stay transparent).
/// In a brick's march (`stopped` given: the lanes' rays that stopped in an
/// earlier brick), `out` holds each ray's state (premultiplied colour and
/// optical depth) from the bricks before, and gets it back with this
/// brick's segments added; the lanes whose rays stop here join `stopped`.
///
/// Stops early (its pixels then are garbage) once `halt` is set.
///
/// # Safety
/// Needs AVX2, FMA and F16C; `clear` is `f`'s (`Clear::new` of its lookup
/// and pre-integration tables); `f.cells`, where given, is followed by three
/// readable bytes, and the texels by the padding their reads need
/// (`Texels::padded`, which `super::render` checks).
#[target_feature(enable = "avx2,fma,f16c")]
pub unsafe fn march<T: Texels>(
    f: &Frame,
    clear: &super::clear::Clear,
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
    // A quarter voxel along the axis the ray crosses fastest (compositing.wgsl `whole_segments`).
    let nudge =
        _mm256_div_ps(_mm256_set1_ps(0.25), _mm256_max_ps(abs(per[0]), _mm256_max_ps(abs(per[1]), abs(per[2]))));
    let prefetch = prefetches(&rays, &per, T::UNIT_BYTES * T::PER_TEXEL, dims);
    let (shift, n, limit) = (rays.shift, rays.n, rays.hi);
    let cap = if p.bricked == 1 { limit } else { n };
    let mut i = rays.lo;

    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let (zi, onei) = (_mm256_setzero_si256(), _mm256_set1_epi32(1));
    let h = _mm256_set1_ps(p.step_size);
    let spans = Spans::new(p, &rays);
    let hi: [__m256i; 3] = dims.map(|d| _mm256_set1_epi32(d as i32 - 1));
    let stride = tex.strides(dims).map(|s| _mm256_set1_epi32(s));
    // `value_prescale` is left out: the caller joins a split scale into
    // `value_scale` (a subnormal product would flush here).
    let value_scale = _mm256_set1_ps(p.value_scale * T::VALUE_UNIT);
    let value_offset = _mm256_set1_ps(p.value_offset);
    let m = f.lut.len();
    let lut_scale = _mm256_set1_ps((m - 1) as f32);
    let lut_last = _mm256_set1_epi32(m as i32 - 2);
    let lut = f.lut.as_ptr() as *const f32;
    let seg_unit = _mm256_set1_ps(p.inv_ref);
    let light_dir: [__m256; 3] = std::array::from_fn(|k| _mm256_set1_ps(p.light_dir[k]));
    let (ambient, diffuse) = (_mm256_set1_ps(p.ambient), _mm256_set1_ps(p.diffuse));
    let scatters = f.model == Model::SingleScattering && f.scatter;
    let threshold = _mm256_set1_ps(p.threshold);
    let (radius_grid, grid) = match f.cells {
        Some((g, d)) if f.skip_empty || f.uniform_runs => (g.as_ptr(), d),
        _ => (std::ptr::null(), [1, 1, 1]),
    };
    let cells = super::cells::Cells::new(p, start, per, grid, false);

    let as_ps = _mm256_castsi256_ps;
    let mut active = as_ps(_mm256_cmpgt_epi32(limit, i));
    let mut stopped = zero;
    let (mut color, mut color_b) = ([zero; 3], [zero; 3]);
    let (mut tau, mut tau_b, mut trans) = (zero, zero, one);
    if let Some(before) = stopped_before.as_deref() {
        // The rays go on from their state (compositing.wgsl `start_integration`).
        active = _mm256_andnot_ps(lanes_of(*before), active);
        color = std::array::from_fn(|c| _mm256_and_ps(channel(out, c), rays.hit));
        tau = _mm256_and_ps(channel(out, 3), rays.hit);
        if f.model != Model::Emission {
            trans = exp_nonpositive(_mm256_sub_ps(zero, tau));
        }
    }
    let (mut taken, mut blocks) = (zi, zi);
    let emission = f.model == Model::Emission;
    let emits = f.model != Model::Absorption;
    // Pre-integration carries each boundary's value and light from the
    // segment that fetched it to the next (compositing.wgsl
    // `preintegrated_segment`): the boundary index (-1: none), value, light.
    let (mut carry_at, mut carry_v, mut carry_light) = (_mm256_set1_epi32(-1), zero, zero);
    // A refined segment in progress (compositing.wgsl `Integration`):
    // segment `sub_at` has taken its first `sub - 1` samples (sub = 0: none
    // in progress), composited front to back into (sub_x, sub_add).
    let refine = f.refine as i32;
    let (mut sub_at, mut sub) = (_mm256_set1_epi32(-1), zi);
    let (mut sub_x, mut sub_add) = (zero, [zero; 3]);
    let piece = _mm256_set1_ps(p.step_size / f.refine.max(1) as f32);
    // Trilinear values change along a ray by at most this much over half a
    // step (compositing.wgsl `needs_refining`: the slopes are in texture axis order).
    let reach = {
        let mut r = zero;
        for k in 0..3 {
            r = _mm256_fmadd_ps(_mm256_set1_ps(p.slopes[2 - k]), abs(per[k]), r);
        }
        _mm256_mul_ps(r, _mm256_set1_ps(0.5 * p.step_size))
    };
    let lut_entry = |v: __m256| lut_rgba(f.lut, v);
    // The opacity alone, as lut_entry interpolates it (two gathers).
    // The lookup table's interval k (0 to M - 2) holding value v, and v's fraction t of it.
    let lut_interval = |v: __m256| -> (__m256i, __m256) {
        let xl = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(v, zero), one), lut_scale);
        let k = _mm256_min_epi32(_mm256_cvttps_epi32(xl), lut_last);
        (k, _mm256_sub_ps(xl, _mm256_cvtepi32_ps(k)))
    };
    let lut_alpha = |v: __m256| -> __m256 {
        let (k, t) = lut_interval(v);
        let at = _mm256_slli_epi32::<2>(k);
        // SAFETY: k <= M - 2, so both entries lie in the table.
        let (e0, e1) = unsafe { (_mm256_i32gather_ps::<4>(lut.add(3), at), _mm256_i32gather_ps::<4>(lut.add(7), at)) };
        _mm256_fmadd_ps(_mm256_sub_ps(e1, e0), t, e0)
    };
    // Lanes whose midpoint sample of value v (not NaN) has opacity 0
    // (`clear`): the lookup table's interval as lut_entry finds it.
    let sample_clear = |v: __m256| -> __m256 {
        let (k, _) = lut_interval(v);
        // SAFETY: 0 <= k <= M - 2, an interval of the lookup table's M - 1.
        let first = unsafe { _mm256_i32gather_epi32::<4>(clear.lut.as_ptr(), k) };
        as_ps(_mm256_cmpgt_epi32(first, k))
    };
    // The table's entries (x0, y0) a bilinear lookup of (front, back)
    // values starts from, and its weights, as the sampler reads them.
    let table_at = |vf: __m256, vb: __m256, t: &super::PreintTable| {
        let scale = _mm256_set1_ps((t.side - 1) as f32);
        let x = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(vf, zero), one), scale);
        let y = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(vb, zero), one), scale);
        let (x0, y0) = (_mm256_floor_ps(x), _mm256_floor_ps(y));
        let (fx, fy) = (_mm256_sub_ps(x, x0), _mm256_sub_ps(y, y0));
        (_mm256_cvttps_epi32(x0), _mm256_cvttps_epi32(y0), fx, fy)
    };
    // Lanes whose lookup from (x0, y0) reads only entries of the table that
    // are zero (`clear`): its intervals from the smaller to the larger.
    let segment_clear = |x0: __m256i, y0: __m256i, t: &super::PreintTable| -> __m256 {
        let last = _mm256_set1_epi32(t.side as i32 - 2);
        let lo = _mm256_min_epi32(_mm256_min_epi32(x0, y0), last);
        let hi = _mm256_min_epi32(_mm256_max_epi32(x0, y0), last);
        // SAFETY: 0 <= lo <= side - 2, an interval of the table's side - 1
        // (`clear.table` is this table's: `render` builds both from the frame).
        let first = unsafe { _mm256_i32gather_epi32::<4>(clear.table.as_ptr(), lo) };
        as_ps(_mm256_cmpgt_epi32(first, hi))
    };
    // The table's bilinear entry from `table_at`.
    let table_entry = |x0: __m256i, y0: __m256i, fx: __m256, fy: __m256, t: &super::PreintTable| -> [__m256; 4] {
        // Each ray's two entries along the front value lie side by side:
        // one 256-bit load a row instead of a gather a channel and corner.
        // Entry x0 + 1 is the sampler's x1 but at x0 = side - 1 (front
        // value 1), where fx is 0 and the entry after the row's last (the
        // next row's first, finite) drops out of the lerp exactly.
        let width = 4 * t.side;
        let at: [i32; 8] = std::mem::transmute(_mm256_add_epi32(
            _mm256_mullo_epi32(y0, _mm256_set1_epi32(width as i32)),
            _mm256_slli_epi32::<2>(x0),
        ));
        let fy_lanes: [f32; 8] = std::mem::transmute(fy);
        let base = t.texels.as_ptr() as *const f32;
        // Ray l's entries x0 and x0 + 1 lerped along the back value: rows y0 and y0 + 1.
        let along_back = |l: usize| {
            // SAFETY: x0 < side and y0 < side: both rows' two entries lie
            // inside the side + 3 rows or more (`march` checks).
            let (r0, r1) = unsafe {
                let p = base.add(at[l] as usize);
                (_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(width)))
            };
            lerp(r0, r1, _mm256_set1_ps(fy_lanes[l]))
        };
        // Rays l and l + 4 share a register ([ray l | ray l + 4]) for the front lerp.
        let pairs: [__m256; 4] = std::array::from_fn(|l| {
            let (a, b) = (along_back(l), along_back(l + 4));
            let w = _mm256_permutevar8x32_ps(
                fx,
                _mm256_setr_epi32(
                    l as i32,
                    l as i32,
                    l as i32,
                    l as i32,
                    l as i32 + 4,
                    l as i32 + 4,
                    l as i32 + 4,
                    l as i32 + 4,
                ),
            );
            lerp(_mm256_permute2f128_ps::<0x20>(a, b), _mm256_permute2f128_ps::<0x31>(a, b), w)
        });
        transpose_pairs(&pairs)
    };
    // compositing.wgsl `opacity_variation`: the running sums of the table's
    // opacity change, read at the entries around [lo, hi].
    let variation = |lo: __m256, hi: __m256, t: &super::PreintTable| -> __m256 {
        let m1 = _mm256_set1_ps(p.lut_size as f32 - 1.0);
        let i0 = _mm256_cvttps_epi32(_mm256_floor_ps(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lo, zero), one), m1)));
        let i1 = _mm256_cvttps_epi32(_mm256_ceil_ps(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(hi, zero), one), m1)));
        // Entry i of the sums, wrapped (`preintegrate::wrapped_rows`): row
        // min(i / (side - 1), rows - 1) after the table's, at i less that
        // row's first entry. The f32 quotient of two integers under 2^24
        // floors right: an exact one is exact, and any other lies at least
        // 1 / (side - 1) below the next integer.
        let (w1, last) = (_mm256_set1_ps(t.side as f32 - 1.0), _mm256_set1_epi32(t.rows as i32 - 1));
        let at = |i: __m256i| {
            let q = _mm256_floor_ps(_mm256_div_ps(_mm256_cvtepi32_ps(i), w1));
            let r = _mm256_min_epi32(_mm256_cvttps_epi32(q), last);
            let col = _mm256_sub_epi32(i, _mm256_mullo_epi32(r, _mm256_set1_epi32(t.side as i32 - 1)));
            let row = _mm256_add_epi32(r, _mm256_set1_epi32(t.side as i32));
            _mm256_slli_epi32::<2>(_mm256_add_epi32(_mm256_mullo_epi32(row, _mm256_set1_epi32(t.side as i32)), col))
        };
        let base = t.texels.as_ptr() as *const f32;
        // SAFETY: i0, i1 < lut_size, so their rows are sums rows (checked
        // against the texels by `march`).
        let (a, b) = unsafe { (_mm256_i32gather_ps::<4>(base, at(i0)), _mm256_i32gather_ps::<4>(base, at(i1))) };
        _mm256_sub_ps(b, a)
    };
    // Single scattering's light at `pos` for lanes `need` (lighting.wgsl
    // `scatter_intensity`): ambient, plus diffuse times the phase function
    // times what a shadow ray to the light through the clip box lets
    // through (midpoint rule at the shadow step, stopped once its optical
    // depth passes SHADOW_TAU_MAX); and the shadow samples each lane took.
    let scatter = |pos: [__m256; 3], need: __m256| -> (__m256, __m256i) {
        let set = _mm256_set1_ps;
        let (travel, defined, reach) = if f.point_light {
            travel_from_light(p, pos)
        } else {
            let valid = if p.light_valid == 1 { as_ps(_mm256_set1_epi32(-1)) } else { zero };
            (light_dir, valid, set(3.0e38))
        };
        let lit = _mm256_and_ps(need, defined);
        let phase = if p.anisotropy == 0.0 {
            one
        } else {
            let g = p.anisotropy;
            let cos = _mm256_sub_ps(zero, dot3(&travel, &rays.d));
            let denom = _mm256_fnmadd_ps(set(2.0 * g), cos, set(1.0 + g * g));
            _mm256_div_ps(set(1.0 - g * g), _mm256_mul_ps(denom, _mm256_sqrt_ps(denom)))
        };
        let to_light = travel.map(|c| _mm256_sub_ps(zero, c));
        let mut exit = set(3.0e38);
        for k in 0..3 {
            let ahead = _mm256_cmp_ps::<_CMP_GT_OQ>(to_light[k], zero);
            let behind = _mm256_cmp_ps::<_CMP_LT_OQ>(to_light[k], zero);
            let wall = _mm256_blendv_ps(set(p.clip_lo[k]), set(p.clip_hi[k]), ahead);
            let t = _mm256_div_ps(_mm256_sub_ps(wall, pos[k]), to_light[k]);
            exit = _mm256_min_ps(exit, _mm256_blendv_ps(set(3.0e38), t, _mm256_or_ps(ahead, behind)));
        }
        // Clip planes (lighting.wgsl): the shadow ray leaves a plane's kept
        // side where its normal points away from the light.
        for q in &p.clip_planes[..p.clip_count as usize] {
            let slope = dot3(&[set(q[0]), set(q[1]), set(q[2])], &to_light);
            let f = _mm256_add_ps(dot3(&[set(q[0]), set(q[1]), set(q[2])], &pos), set(q[3]));
            let t = _mm256_div_ps(_mm256_sub_ps(zero, f), slope);
            let away = _mm256_cmp_ps::<_CMP_LT_OQ>(slope, zero);
            exit = _mm256_blendv_ps(exit, _mm256_min_ps(exit, t), away);
        }
        let len = _mm256_max_ps(_mm256_min_ps(exit, reach), zero);
        let hs = set(p.shadow_step);
        // Counted in integers, as the shader's u32 (an f32 count stops
        // growing at 2^24; the renderer allows up to 30000 steps a ray).
        let steps_n = _mm256_min_ps(_mm256_ceil_ps(_mm256_div_ps(len, hs)), set(2_147_483_520.0));
        let steps_n = _mm256_cvttps_epi32(steps_n);
        let (mut tau, mut count, mut j) = (zero, zi, zi);
        let mut going = _mm256_and_ps(lit, as_ps(_mm256_cmpgt_epi32(steps_n, j)));
        while _mm256_movemask_ps(going) != 0 {
            let s0 = _mm256_mul_ps(_mm256_cvtepi32_ps(j), hs);
            let seg = _mm256_min_ps(hs, _mm256_sub_ps(len, s0));
            going = _mm256_and_ps(going, _mm256_cmp_ps::<_CMP_GT_OQ>(seg, zero));
            let along = _mm256_fmadd_ps(seg, set(0.5), s0);
            let u: [__m256; 3] = std::array::from_fn(|k| {
                let q = _mm256_fmadd_ps(to_light[k], along, pos[k]);
                let tc = _mm256_fmadd_ps(q, set(p.tex_scale[k]), set(p.tex_offset[k]));
                _mm256_fmsub_ps(tc, set(dims[k] as f32), set(0.5))
            });
            let (offs, w) = corners(&u, &hi, &stride);
            let v = _mm256_fmadd_ps(tex.trilinear(&offs, &w)[0], value_scale, value_offset);
            let valid = _mm256_cmp_ps::<_CMP_ORD_Q>(v, v);
            count = _mm256_sub_epi32(count, _mm256_castps_si256(going));
            let a = lut_alpha(_mm256_and_ps(v, valid));
            let sigma = if f.power { neg_log_one_minus(a) } else { a };
            let x = _mm256_mul_ps(sigma, _mm256_mul_ps(seg, seg_unit));
            tau = _mm256_add_ps(tau, _mm256_and_ps(x, _mm256_and_ps(going, valid)));
            let deep = _mm256_cmp_ps::<_CMP_GT_OQ>(tau, set(crate::integrate::SHADOW_TAU_MAX as f32));
            going = _mm256_andnot_ps(deep, going);
            j = _mm256_add_epi32(j, onei);
            going = _mm256_and_ps(going, as_ps(_mm256_cmpgt_epi32(steps_n, j)));
        }
        let through = exp_nonpositive(_mm256_sub_ps(zero, tau));
        let light = _mm256_fmadd_ps(_mm256_mul_ps(diffuse, phase), through, ambient);
        (_mm256_blendv_ps(ambient, light, lit), count)
    };
    let mut steps = 0u32;
    while _mm256_movemask_ps(active) != 0 {
        steps = steps.wrapping_add(1);
        if steps.is_multiple_of(1024) && halt.load(Ordering::Relaxed) {
            break;
        }
        taken = _mm256_sub_epi32(taken, _mm256_castps_si256(active));
        let (start_at, seg) = spans.span(i);
        let mid = _mm256_fmadd_ps(seg, _mm256_set1_ps(0.5), start_at);
        let mut again = zero;
        let coords = |at: __m256| -> [__m256; 3] { std::array::from_fn(|k| _mm256_fmadd_ps(per[k], at, start[k])) };
        // Leaps (compositing.wgsl `cube_leap`, skipping.wgsl `cube_exit`).
        // Plain segments leap from their midpoint: the shader leaps from a
        // segment that came out empty and is centred in an empty cell, and
        // every segment centred there comes out empty, so the cell alone
        // decides, before the volume is read. Pre-integrated ones leap or
        // run from their near end, over the segments inside the cube whole
        // (compositing.wgsl `whole_segments`).
        let mut leap = zero;
        let mut uniform = zero;
        let mut next = i;
        if !radius_grid.is_null() {
            let flag = _mm256_set1_epi32(crate::occupancy::UNIFORM_FLAG as i32);
            // The cell holding ray parameter `at`, and its code.
            let cell_code = |at: __m256| {
                let cell = cells.at(at);
                // SAFETY: the cell is clamped into the grid, whose codes
                // `radius_grid` holds, followed by three bytes.
                let code = unsafe { super::cells::byte(radius_grid, cell.index) };
                (cell, code)
            };
            let lowest = _mm256_cvtepi32_ps(_mm256_add_epi32(i, onei));
            let (cell, code) = cell_code(if f.preint.is_some() { start_at } else { mid });
            // Codes from UNIFORM_FLAG up mark uniform cells, which are not empty.
            let flagged = _mm256_cmpgt_epi32(code, _mm256_sub_epi32(flag, onei));
            let radius = _mm256_andnot_si256(flagged, code);
            if f.skip_empty {
                leap = _mm256_and_ps(active, as_ps(_mm256_cmpgt_epi32(radius, zi)));
            }
            // A cell holds an empty radius or a uniform one: one exit serves both.
            let mut cube = _mm256_and_si256(_mm256_castps_si256(leap), radius);
            if f.uniform_runs {
                let uniform_radius = _mm256_and_si256(flagged, _mm256_sub_epi32(code, flag));
                uniform = _mm256_and_ps(active, as_ps(_mm256_cmpgt_epi32(uniform_radius, zi)));
                cube = _mm256_or_si256(cube, uniform_radius);
            }
            let exit = cells.exit(&cell, cube);
            let kf = if f.preint.is_some() {
                // compositing.wgsl `whole_segments`: on through the empty
                // cubes after the first, each looked up a quarter voxel past
                // the last, to `far`; the first segment reaching past it.
                let mut far = _mm256_add_ps(start_at, exit);
                let mut walking = leap;
                for _ in 1..CHAIN {
                    if _mm256_movemask_ps(walking) == 0 {
                        break;
                    }
                    let (cell, code) = cell_code(_mm256_add_ps(far, nudge));
                    let flagged = _mm256_cmpgt_epi32(code, _mm256_sub_epi32(flag, onei));
                    let radius = _mm256_andnot_si256(flagged, code);
                    walking = _mm256_and_ps(walking, as_ps(_mm256_cmpgt_epi32(radius, zi)));
                    let exit = cells.exit(&cell, radius);
                    far = _mm256_blendv_ps(far, _mm256_add_ps(_mm256_add_ps(far, nudge), exit), walking);
                }
                let kf =
                    _mm256_floor_ps(_mm256_sub_ps(_mm256_div_ps(far, h), _mm256_add_ps(shift, _mm256_set1_ps(1e-3))));
                // Segment i must lie inside.
                let inside = _mm256_cmp_ps::<_CMP_GE_OQ>(kf, lowest);
                leap = _mm256_and_ps(leap, inside);
                uniform = _mm256_and_ps(uniform, inside);
                kf
            } else {
                // compositing.wgsl `segment_past`: a thousandth of a step early.
                _mm256_ceil_ps(_mm256_sub_ps(
                    _mm256_sub_ps(_mm256_div_ps(_mm256_add_ps(mid, exit), h), _mm256_set1_ps(0.5)),
                    _mm256_add_ps(shift, _mm256_set1_ps(1e-3)),
                ))
            };
            // A brick's runs end with its window (compositing.wgsl `whole_segments`, `segment_past`).
            let kf = _mm256_min_ps(_mm256_max_ps(kf, lowest), _mm256_cvtepi32_ps(cap));
            next = _mm256_cvttps_epi32(kf);
        }
        // A full pre-integrated segment fetches its far boundary, or first
        // its near one when that is not carried (`primes`: marched again).
        // A refined one takes the midpoint sample of its next piece. None
        // of this waits for the leap (lanes that leap read nothing): the
        // volume's read then overlaps the cells' lookup.
        let (mut carried, mut primes, mut at, mut in_sub) = (zero, zero, mid, zero);
        let full = _mm256_cmp_ps::<_CMP_EQ_OQ>(seg, h);
        if f.preint.is_some() {
            if refine > 0 {
                in_sub = _mm256_and_ps(
                    _mm256_and_ps(full, as_ps(_mm256_cmpgt_epi32(sub, zi))),
                    as_ps(_mm256_cmpeq_epi32(sub_at, i)),
                );
            }
            carried = _mm256_andnot_ps(in_sub, _mm256_and_ps(full, as_ps(_mm256_cmpeq_epi32(carry_at, i))));
            primes = _mm256_andnot_ps(_mm256_or_ps(carried, in_sub), full);
            let at_sub = _mm256_fmadd_ps(_mm256_sub_ps(_mm256_cvtepi32_ps(sub), _mm256_set1_ps(0.5)), piece, start_at);
            at = _mm256_blendv_ps(_mm256_blendv_ps(mid, start_at, primes), _mm256_add_ps(start_at, h), carried);
            at = _mm256_blendv_ps(at, at_sub, in_sub);
        }
        // Lanes that read the volume: those that do not leap.
        let fetch = _mm256_andnot_ps(leap, active);
        let mut shadow_taken = zi;
        let (x, add) = if _mm256_movemask_ps(fetch) == 0 {
            (zero, [zero; 3])
        } else {
            let u = coords(at);
            let (offs, w) = corners(&u, &hi, &stride);
            if prefetch {
                // The next segment's sample: its four rows of corners (two
                // planes, two rows each) on their way while this one is read.
                let mut o = zi;
                for k in 0..3 {
                    let b = _mm256_cvttps_epi32(_mm256_floor_ps(_mm256_fmadd_ps(per[k], h, u[k])));
                    let b = _mm256_min_epi32(_mm256_max_epi32(b, zi), hi[k]);
                    o = _mm256_add_epi32(o, _mm256_mullo_epi32(b, stride[k]));
                }
                let next_plane = _mm256_add_epi32(o, stride[0]);
                let rows: [[i32; 8]; 4] = std::mem::transmute([
                    o,
                    _mm256_add_epi32(o, stride[1]),
                    next_plane,
                    _mm256_add_epi32(next_plane, stride[1]),
                ]);
                let lanes = _mm256_movemask_ps(fetch);
                let base = tex.base();
                for l in (0..TILE).filter(|l| lanes & (1 << l) != 0) {
                    for r in &rows {
                        // A hint: it never faults, and past the last row it reads nothing the march uses.
                        let at = base.wrapping_add(r[l] as usize * T::UNIT_BYTES);
                        _mm_prefetch::<_MM_HINT_T0>(at as *const i8);
                    }
                }
            }
            // A sample lit by the field's gradient in values alone reads its
            // cell's rows, which the gradient's differences read too.
            let rows = if T::VALUES_ONLY && f.lit && f.gradient { CellRows::read(tex, &u, &hi, &stride) } else { None };
            let texel = match &rows {
                Some(rows) => value_only(rows.value()),
                None => tex.trilinear(&offs, &w),
            };
            // NaN reads as value 0 and opacity 0.
            let v = _mm256_fmadd_ps(texel[0], value_scale, value_offset);
            let valid = _mm256_cmp_ps::<_CMP_ORD_Q>(v, v);
            // The normal lit samples take: the texel's, or the field's gradient.
            // Scattered light comes after the segment's extinction is known.
            // Lanes whose midpoint sample has opacity 0 (asked where the
            // transfer function has such values and midpoint samples are taken).
            let clear_lanes = if clear.lut_has_clear && (f.preint.is_none() || refine > 0) {
                sample_clear(_mm256_and_ps(v, valid))
            } else {
                zero
            };
            // A plain pass whose samples all have opacity 0 adds nothing:
            // no lookup, light or exponential. Nor do a refined segment's
            // samples that all have it; the light is then not needed
            // either where no lane carries a boundary (which keeps its light).
            let nothing = f.preint.is_none() && _mm256_movemask_ps(_mm256_andnot_ps(clear_lanes, fetch)) == 0;
            let sub_nothing = refine > 0 && _mm256_movemask_ps(_mm256_andnot_ps(clear_lanes, in_sub)) == 0;
            let dark = nothing || (sub_nothing && _mm256_movemask_ps(_mm256_andnot_ps(in_sub, fetch)) == 0);
            let light = if scatters || dark {
                one
            } else {
                sample_light(f, tex, &rays, &u, &texel, at, &hi, &stride, rows.as_ref())
            };
            // The midpoint rule (every segment of a plain frame, the shorter
            // end segments of a pre-integrated one): optical depth and colour.
            let midpoint = |seg: __m256| -> (__m256, [__m256; 3]) {
                let rgba = lut_entry(_mm256_and_ps(v, valid));
                let sigma = _mm256_and_ps(rgba[3], valid);
                let sigma = if f.power { _mm256_and_ps(neg_log_one_minus(sigma), valid) } else { sigma };
                let seen =
                    _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(sigma, zero), _mm256_cmp_ps::<_CMP_GT_OQ>(seg, zero));
                let x = _mm256_and_ps(
                    _mm256_min_ps(_mm256_mul_ps(sigma, _mm256_mul_ps(seg, seg_unit)), _mm256_set1_ps(1.0e30)),
                    seen,
                );
                if !emits {
                    return (x, [zero; 3]);
                }
                let k = if emission { x } else { one_minus_exp_neg(x) };
                let k = _mm256_mul_ps(k, light);
                (x, std::array::from_fn(|c| _mm256_mul_ps(k, rgba[c])))
            };
            let (x, add) = match f.preint {
                None if nothing => (zero, [zero; 3]),
                None if scatters => {
                    let (x, add) = midpoint(seg);
                    let need = _mm256_and_ps(fetch, _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero));
                    if _mm256_movemask_ps(need) == 0 {
                        (x, add)
                    } else {
                        let t = _mm256_add_ps(rays.t0, at);
                        let pos = std::array::from_fn(|k| _mm256_fmadd_ps(rays.d[k], t, rays.o[k]));
                        let (light, count) = scatter(pos, need);
                        shadow_taken = count;
                        (x, add.map(|c| _mm256_mul_ps(c, light)))
                    }
                }
                None => midpoint(seg),
                Some(table) => {
                    let (held_v, held_light) = (carry_v, carry_light);
                    let boundary = _mm256_blendv_ps(
                        _mm256_blendv_ps(as_ps(_mm256_set1_epi32(-1)), as_ps(i), primes),
                        as_ps(_mm256_add_epi32(i, onei)),
                        carried,
                    );
                    // A refined segment's samples leave the carried boundary as it was.
                    let moves = _mm256_andnot_ps(in_sub, fetch);
                    carry_at = _mm256_castps_si256(_mm256_blendv_ps(as_ps(carry_at), boundary, moves));
                    carry_v = _mm256_blendv_ps(carry_v, v, moves);
                    carry_light = _mm256_blendv_ps(carry_light, light, moves);
                    let known = _mm256_and_ps(_mm256_cmp_ps::<_CMP_ORD_Q>(held_v, held_v), valid);
                    let mut whole = _mm256_and_ps(_mm256_and_ps(carried, known), fetch);
                    let mut x = zero;
                    let mut add = [zero; 3];
                    if refine > 0 && _mm256_movemask_ps(whole) != 0 {
                        // Where the values may reach an opacity change the
                        // ramp misses, the segment is taken as `refine`
                        // midpoint samples, starting with the next visit.
                        let centre = _mm256_mul_ps(_mm256_set1_ps(0.5), _mm256_add_ps(held_v, v));
                        let change = variation(_mm256_sub_ps(centre, reach), _mm256_add_ps(centre, reach), table);
                        let starts =
                            _mm256_and_ps(whole, _mm256_cmp_ps::<_CMP_GT_OQ>(change, _mm256_set1_ps(REFINE_EPS)));
                        sub_at = _mm256_castps_si256(_mm256_blendv_ps(as_ps(sub_at), as_ps(i), starts));
                        sub = _mm256_castps_si256(_mm256_blendv_ps(as_ps(sub), as_ps(onei), starts));
                        sub_x = _mm256_andnot_ps(starts, sub_x);
                        sub_add = sub_add.map(|c| _mm256_andnot_ps(starts, c));
                        again = _mm256_or_ps(again, starts);
                        whole = _mm256_andnot_ps(starts, whole);
                    }
                    if _mm256_movemask_ps(in_sub) != 0 {
                        let (xm, addm) = if sub_nothing { (zero, [zero; 3]) } else { midpoint(piece) };
                        let behind = exp_nonpositive(_mm256_sub_ps(zero, sub_x));
                        for c in 0..3 {
                            sub_add[c] =
                                _mm256_blendv_ps(sub_add[c], _mm256_fmadd_ps(behind, addm[c], sub_add[c]), in_sub);
                        }
                        sub_x = _mm256_blendv_ps(sub_x, _mm256_add_ps(sub_x, xm), in_sub);
                        let last = _mm256_and_ps(in_sub, as_ps(_mm256_cmpeq_epi32(sub, _mm256_set1_epi32(refine))));
                        let next_sub = _mm256_andnot_si256(_mm256_castps_si256(last), _mm256_add_epi32(sub, onei));
                        sub = _mm256_castps_si256(_mm256_blendv_ps(as_ps(sub), as_ps(next_sub), in_sub));
                        again = _mm256_or_ps(again, _mm256_andnot_ps(last, in_sub));
                        x = _mm256_and_ps(sub_x, last);
                        add = std::array::from_fn(|c| _mm256_and_ps(sub_add[c], last));
                    }
                    if _mm256_movemask_ps(whole) != 0 {
                        let (x0, y0, fx, fy) = table_at(_mm256_and_ps(held_v, known), _mm256_and_ps(v, known), table);
                        let skips = clear.table_has_clear
                            && _mm256_movemask_ps(_mm256_andnot_ps(segment_clear(x0, y0, table), whole)) == 0;
                        let e = if skips { [zero; 4] } else { table_entry(x0, y0, fx, fy, table) };
                        let k = _mm256_mul_ps(_mm256_set1_ps(0.5), _mm256_add_ps(held_light, light));
                        x = _mm256_blendv_ps(x, e[3], whole);
                        add = std::array::from_fn(|c| _mm256_blendv_ps(add[c], _mm256_mul_ps(e[c], k), whole));
                    }
                    let short = _mm256_andnot_ps(full, fetch);
                    if _mm256_movemask_ps(short) != 0 {
                        let (xs, adds) = midpoint(seg);
                        x = _mm256_blendv_ps(x, xs, short);
                        add = std::array::from_fn(|c| _mm256_blendv_ps(add[c], adds[c], short));
                    }
                    (x, add)
                }
            };
            (x, add)
        };

        // A priming segment that does not leap is marched again, now
        // carried; so is a refined one until its last sample.
        let again = _mm256_andnot_ps(leap, _mm256_or_ps(primes, again));
        let blend = _mm256_andnot_ps(_mm256_or_ps(leap, again), active);
        // A full segment with extinction centred in a uniform cell composites
        // the segments after it in the cube of uniform cells as one
        // (compositing.wgsl `uniform_run`): k segments of one colour and
        // extinction, up to where the ray would stop early.
        let (mut x, mut add) = (x, add);
        let mut advance = onei;
        let run =
            _mm256_and_ps(_mm256_and_ps(uniform, blend), _mm256_and_ps(full, _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero)));
        if _mm256_movemask_ps(run) != 0 {
            let last = _mm256_cvtepi32_ps(_mm256_max_epi32(_mm256_sub_epi32(n, onei), zi));
            let mut k = _mm256_sub_ps(_mm256_min_ps(_mm256_cvtepi32_ps(next), last), _mm256_cvtepi32_ps(i));
            if f.early_termination {
                // The first j with 1 - trans e^(-j x) >= threshold (inf at threshold 1).
                let (mut t, mut xs, mut kt) = ([0f32; 8], [0f32; 8], [0f32; 8]);
                _mm256_storeu_ps(t.as_mut_ptr(), trans);
                _mm256_storeu_ps(xs.as_mut_ptr(), x);
                for l in 0..8 {
                    kt[l] = ((t[l] / (1.0 - p.threshold)).ln() / xs[l]).ceil().max(1.0);
                }
                k = _mm256_min_ps(k, _mm256_blendv_ps(k, _mm256_loadu_ps(kt.as_ptr()), run));
            }
            let run = _mm256_and_ps(run, _mm256_cmp_ps::<_CMP_GT_OQ>(k, one));
            let kx = _mm256_min_ps(_mm256_mul_ps(k, x), _mm256_set1_ps(1.0e30));
            let scale = if emission { k } else { _mm256_div_ps(one_minus_exp_neg(kx), one_minus_exp_neg(x)) };
            x = _mm256_blendv_ps(x, kx, run);
            add = std::array::from_fn(|c| _mm256_blendv_ps(add[c], _mm256_mul_ps(add[c], scale), run));
            advance = _mm256_castps_si256(_mm256_blendv_ps(as_ps(onei), as_ps(_mm256_cvttps_epi32(k)), run));
        }
        for c in 0..3 {
            color_b[c] = _mm256_fmadd_ps(_mm256_and_ps(trans, blend), add[c], color_b[c]);
        }
        if !emission {
            tau_b = _mm256_add_ps(tau_b, _mm256_and_ps(x, blend));
        }
        // Partial sums of 2^8 samples (shadow samples included) folded into the totals.
        taken = _mm256_add_epi32(taken, shadow_taken);
        let block = _mm256_srli_epi32::<8>(taken);
        let fold =
            _mm256_and_ps(blend, _mm256_xor_ps(as_ps(_mm256_cmpeq_epi32(block, blocks)), as_ps(_mm256_set1_epi32(-1))));
        if _mm256_movemask_ps(fold) != 0 {
            blocks = _mm256_castps_si256(_mm256_blendv_ps(as_ps(blocks), as_ps(block), fold));
            for c in 0..3 {
                color[c] = _mm256_add_ps(color[c], _mm256_and_ps(color_b[c], fold));
                color_b[c] = _mm256_andnot_ps(fold, color_b[c]);
            }
            tau = _mm256_add_ps(tau, _mm256_and_ps(tau_b, fold));
            tau_b = _mm256_andnot_ps(fold, tau_b);
        }
        if !emission {
            let total = _mm256_add_ps(tau, tau_b);
            trans = _mm256_blendv_ps(trans, exp_nonpositive(_mm256_sub_ps(zero, total)), blend);
            let mut stop = zero;
            if f.early_termination {
                stop = _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(total, zero),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_sub_ps(one, trans), threshold),
                );
            }
            let faded = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(trans, _mm256_set1_ps(1e-30)), blend);
            trans = _mm256_andnot_ps(faded, trans);
            stopped = _mm256_or_ps(stopped, _mm256_and_ps(_mm256_or_ps(stop, faded), blend));
        }
        i = _mm256_castps_si256(_mm256_blendv_ps(
            as_ps(_mm256_add_epi32(i, _mm256_and_si256(_mm256_castps_si256(blend), advance))),
            as_ps(next),
            leap,
        ));
        active = _mm256_andnot_ps(stopped, _mm256_and_ps(active, as_ps(_mm256_cmpgt_epi32(limit, i))));
    }

    let (color, tau) = (std::array::from_fn(|c| _mm256_add_ps(color[c], color_b[c])), _mm256_add_ps(tau, tau_b));
    leave_composited(&rays, taken, stopped, (color, tau, trans), emission, out, stopped_before)
}

/// `leave_row` for compositing marches (`march`, `track`): `ray` is each
/// lane's premultiplied colour, optical depth and transmittance. A whole
/// frame's pixel takes its alpha from them (`ray_alpha`); a brick's state
/// keeps the optical depth.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn leave_composited(
    rays: &super::rays8::Rays,
    taken: __m256i,
    stopped: __m256,
    ray: ([__m256; 3], __m256, __m256),
    emission: bool,
    out: &mut [[f32; 4]; TILE],
    stopped_before: Option<&mut u8>,
) -> Stats {
    let (color, tau, trans) = (ray.0.map(|c| lanes(c)), lanes(ray.1), lanes(ray.2));
    let brick = stopped_before.is_some();
    leave_row(rays, taken, stopped, out, stopped_before, |l| {
        let last = if brick { tau[l] } else { ray_alpha(tau[l], trans[l], emission) };
        [color[0][l], color[1][l], color[2][l], last]
    })
}

/// A finished ray's alpha from its optical depth `tau` and transmittance
/// `trans` (0: stopped opaque): 1 - e^-tau in f64 (for the small depths of
/// faint rays), none for the emission model's additive glow.
pub(super) fn ray_alpha(tau: f32, trans: f32, emission: bool) -> f32 {
    if emission {
        0.0
    } else if trans == 0.0 {
        1.0
    } else if tau.to_bits() == 0 {
        // What the exponential gives, without it: most rays of a sparse
        // scene's frame cross no opacity (8% of a coarse frame's time).
        0.0
    } else {
        crate::integrate::one_minus_exp_neg(tau as f64) as f32
    }
}

/// Bytes of texels between the samples of neighbouring rays from which the
/// march prefetches each next sample's texels: rays that far apart share no
/// cache lines, so each sample waits on its misses (a small pilot of a
/// large volume), where rays under a voxel apart share them.
pub(super) const PREFETCH_SPREAD_BYTES: f32 = 8.0;
/// Storage under this many bytes stays in the caches, where prefetching
/// would only add work.
pub(super) const PREFETCH_MIN_VOLUME_BYTES: usize = 16 << 20;

/// Whether a row of eight rays prefetches: the volume's `texel_bytes`-byte
/// texels outgrow the caches and two neighbouring rays lie at least
/// PREFETCH_SPREAD_BYTES of texels apart halfway along their chords (`per`:
/// voxels per unit of ray parameter along each axis).
#[target_feature(enable = "avx2,fma,f16c")]
pub(super) fn prefetches(rays: &super::rays8::Rays, per: &[__m256; 3], texel_bytes: usize, dims: [usize; 3]) -> bool {
    if dims.iter().product::<usize>() * texel_bytes < PREFETCH_MIN_VOLUME_BYTES {
        return false;
    }
    let hits = _mm256_movemask_ps(rays.hit);
    let Some(l) = (0..TILE - 1).find(|l| hits & (3 << l) == 3 << l) else {
        return false;
    };
    let apart = per.iter().map(|&p| lanes(p)).map(|p| (p[l + 1] - p[l]).powi(2)).sum::<f32>().sqrt();
    let (t0, chord) = (lanes(rays.t0), lanes(rays.chord));
    apart * (t0[l] + 0.5 * chord[l]) * texel_bytes as f32 >= PREFETCH_SPREAD_BYTES
}

#[cfg(test)]
mod tests {
    use super::super::{codes::*, lighting::*, ops::*, sampling::*};
    use super::*;

    /// Eight rays whose voxel coordinates per unit of ray parameter grow by
    /// `spread` from lane to lane along axis 0, with chords from 2 to 4
    /// (the caller checks AVX2, FMA and F16C).
    fn prefetch_for(spread: f32, hits: u8, texel_bytes: usize, dims: [usize; 3]) -> bool {
        // SAFETY: the caller checked AVX2, FMA and F16C.
        unsafe {
            let lane = |l: i32| if hits & (1 << l) != 0 { -1 } else { 0 };
            let hit = _mm256_castsi256_ps(_mm256_setr_epi32(
                lane(0),
                lane(1),
                lane(2),
                lane(3),
                lane(4),
                lane(5),
                lane(6),
                lane(7),
            ));
            let rays = super::super::rays8::Rays {
                o: [_mm256_setzero_ps(); 3],
                d: [_mm256_setzero_ps(); 3],
                t0: _mm256_set1_ps(2.0),
                chord: _mm256_set1_ps(2.0),
                shift: _mm256_setzero_ps(),
                n: _mm256_setzero_si256(),
                needed: _mm256_setzero_ps(),
                lo: _mm256_setzero_si256(),
                hi: _mm256_setzero_si256(),
                hit,
            };
            let ramp = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
            let per = [_mm256_mul_ps(ramp, _mm256_set1_ps(spread)), _mm256_set1_ps(0.5), _mm256_set1_ps(-0.25)];
            prefetches(&rays, &per, texel_bytes, dims)
        }
    }

    #[test]
    fn rays_far_apart_through_a_large_volume_prefetch() {
        if !super::super::avx2_available() {
            return;
        }
        let big = [256, 256, 256];
        // Halfway along the chords the rays lie 3 x spread voxels apart.
        assert!(prefetch_for(0.5, 0xff, 8, big)); // 1.5 voxels of 8 bytes: 12
        assert!(!prefetch_for(0.2, 0xff, 8, big)); // 0.6 voxels: 4.8 bytes
        assert!(!prefetch_for(0.5, 0xff, 2, big)); // 3 bytes
        assert!(prefetch_for(1.5, 0xff, 2, big)); // 9 bytes
                                                  // The first two neighbouring rays that hit the box decide.
        assert!(prefetch_for(0.5, 0b0110_0000, 8, big));
        assert!(!prefetch_for(0.5, 0b0101_0101, 8, big));
        // 2 MiB of texels stay in the caches; 16 MiB do not.
        assert!(!prefetch_for(4.0, 0xff, 8, [64, 64, 64]));
        assert!(prefetch_for(4.0, 0xff, 8, [128, 128, 128]));
    }

    /// Codes and normals apart read as the float32 (code, normal / 127)
    /// texels they stand for, at points all over a small volume: inside,
    /// on its last planes (clamped corners) and past them.
    #[test]
    fn values_and_normals_apart_read_as_packed_texels() {
        if !super::super::avx2_available() {
            return;
        }
        let dims = [5, 6, 7];
        let n: usize = dims.iter().product();
        let code = |i: usize| crate::model::hash32(i as u32) as u8;
        let normal = |i: usize| {
            let h = crate::model::hash32(i as u32 + 1000).to_le_bytes();
            [h[0] as i8, h[1] as i8, (h[2] as i8).max(-127), 0]
        };
        let mut codes: Vec<u8> = (0..n).map(code).collect();
        codes.extend([0; 3]);
        let normals: Vec<[i8; 4]> = (0..n).map(normal).collect();
        let packed: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let m = normal(i);
                [code(i) as f32, m[0] as f32 / 127.0, m[1] as f32 / 127.0, m[2] as f32 / 127.0]
            })
            .collect();
        let apart = Apart(R8Unorm(&codes), &normals);
        let whole = Rgba32Float(&packed);
        let hi: [__m256i; 3] = dims.map(|d| unsafe { _mm256_set1_epi32(d as i32 - 1) });
        let mut k = 0u32;
        for _ in 0..200 {
            let mut u = [[0f32; 8]; 3];
            for (a, axis) in u.iter_mut().enumerate() {
                for x in axis.iter_mut() {
                    k += 1;
                    *x = (crate::model::hash32(k) >> 8) as f32 / 16_777_216.0 * (dims[a] as f32 + 0.5) - 0.25;
                }
            }
            // SAFETY: AVX2, FMA and F16C are available; the corners are clamped into the volume.
            let (got, want) = unsafe {
                let u = u.map(|x| _mm256_loadu_ps(x.as_ptr()));
                let corners_for =
                    |t: &dyn Fn([usize; 3]) -> [i32; 3]| corners(&u, &hi, &t(dims).map(|s| _mm256_set1_epi32(s)));
                let (a, b) = (corners_for(&|d| apart.strides(d)), corners_for(&|d| whole.strides(d)));
                (apart.trilinear(&a.0, &a.1).map(|x| lanes(x)), whole.trilinear(&b.0, &b.1).map(|x| lanes(x)))
            };
            for c in 0..4 {
                for l in 0..8 {
                    // (Codes up to 255: a few of f32's ulps.)
                    let (got, want) = (got[c][l], want[c][l]);
                    let close = (got - want).abs() <= 1e-5 * want.abs().max(1.0);
                    assert!(close, "channel {c}, lane {l}: {got} against {want}");
                }
            }
        }
    }

    #[test]
    fn half_floats_read_every_binary16_exactly() {
        if !super::super::avx2_available() {
            return;
        }
        // As the march's workers run: subnormal results flushed.
        super::super::set_flush_to_zero();
        let codes: Vec<i32> = (0..=0xffff).collect();
        for chunk in codes.chunks(8) {
            // A junk upper half, as a 32-bit read of a code next to another has.
            let words: Vec<i32> = chunk.iter().map(|&c| c | 0x5a5a_0000).collect();
            let mut out = [0.0f32; 8];
            // SAFETY: AVX2, FMA and F16C are available.
            unsafe {
                let x = _mm256_loadu_si256(words.as_ptr() as *const __m256i);
                _mm256_storeu_ps(out.as_mut_ptr(), half_floats(x));
            }
            for (&c, &got) in chunk.iter().zip(&out) {
                // IEEE 754 binary16: sign, 5 exponent bits (bias 15), 10 fraction bits.
                let (e, m) = ((c >> 10) & 0x1f, (c & 0x3ff) as f64);
                let sign = if c & 0x8000 != 0 { -1.0 } else { 1.0 };
                let want = match e {
                    0 => sign * m * 2f64.powi(-24),
                    31 if m == 0.0 => sign * f64::INFINITY,
                    31 => f64::NAN,
                    _ => sign * (1.0 + m / 1024.0) * 2f64.powi(e - 15),
                };
                if want.is_nan() {
                    assert!(got.is_nan(), "{c:#06x}: {got}");
                } else {
                    assert_eq!(got as f64, want, "{c:#06x}");
                    assert_eq!(got.is_sign_negative(), sign < 0.0, "{c:#06x}: sign");
                }
            }
        }
    }

    #[test]
    fn neg_log_one_minus_matches_f64() {
        if !super::super::avx2_available() {
            return;
        }
        // Every 2^-16 of opacity, the series' edge, f32's largest below 1,
        // and the opaque and beyond.
        let mut a: Vec<f32> = (0..=65535).map(|k| k as f32 / 65536.0).collect();
        a.extend([9.99e-4, 1e-3, 1.001e-3, 1.0 - f32::EPSILON / 2.0, 1.0, 1.5]);
        for chunk in a.chunks(8) {
            let mut lanes = [0.0f32; 8];
            lanes[..chunk.len()].copy_from_slice(chunk);
            let mut out = [0.0f32; 8];
            // SAFETY: AVX2, FMA and F16C are available.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), neg_log_one_minus(_mm256_loadu_ps(lanes.as_ptr()))) };
            for (&x, &got) in lanes.iter().zip(&out) {
                if x >= 1.0 {
                    assert_eq!(got, 1.0e30, "{x}");
                    continue;
                }
                let want = -(-(x as f64)).ln_1p();
                // 1 - a rounded to f32 (as the shader rounds it) moves the
                // log by up to 2^-24 / (1 - a); the series below 1e-3 is good to ~a^4 / 4.
                let tol = 4e-7 * want + 6e-8 / (1.0 - x as f64) + (x as f64).powi(4) / 3.0;
                assert!((got as f64 - want).abs() <= tol, "a = {x}: {got} against {want}");
            }
        }
    }

    /// T(u + e_k) - T(u - e_k) in float64 (T: the trilinear interpolant of
    /// `value` at cell-centred coordinates, corners clamped into `dims`).
    fn difference_f64(value: &dyn Fn(usize) -> f64, dims: [usize; 3], u: [f64; 3], k: usize) -> f64 {
        let at = |p: [f64; 3]| {
            let mut sum = 0.0;
            for corner in 0..8 {
                let (mut i, mut weight) = (0, 1.0);
                for a in 0..3 {
                    let b = p[a].floor();
                    let (t, up) = (p[a] - b, (corner >> (2 - a)) & 1);
                    let c = (b as i64 + up as i64).clamp(0, dims[a] as i64 - 1) as usize;
                    i = i * dims[a] + c;
                    weight *= if up == 1 { t } else { 1.0 - t };
                }
                sum += weight * value(i);
            }
            sum
        };
        let (mut up, mut down) = (u, u);
        up[k] += 1.0;
        down[k] -= 1.0;
        at(up) - at(down)
    }

    /// Each values-only storage's central differences, inside the storage
    /// (the shared rows) and across its ends (clamped lanes: six trilinear
    /// reads), against float64.
    #[test]
    fn central_differences_of_every_value_storage_match_f64() {
        if !super::super::avx2_available() {
            return;
        }
        let dims = [6, 7, 9];
        let n: usize = dims.iter().product();
        let bits = |i: usize| crate::model::hash32(i as u32 + 77);
        // Normal binary16 values of either sign, exponents 2^-14 to 2^14.
        let half = |i: usize| (bits(i) as u16 & 0x83ff) | (((bits(i) >> 16) % 29 + 1) as u16) << 10;
        let half_value = |h: u16| {
            let (sign, e, m) = ((h >> 15) as i32, ((h >> 10) & 0x1f) as i32, (h & 0x3ff) as f64);
            (1.0 - 2.0 * sign as f64) * 2f64.powi(e - 15) * (1.0 + m / 1024.0)
        };
        let mut r8: Vec<u8> = (0..n).map(|i| bits(i) as u8).collect();
        r8.extend([0; 3]);
        let r16: Vec<u16> = (0..=n).map(|i| bits(i) as u16).collect();
        let s16: Vec<i16> = (0..=n).map(|i| (bits(i) as i16).max(-32767)).collect();
        let f16: Vec<u16> = (0..=n).map(half).collect();
        let f32s: Vec<f32> = (0..=n).map(|i| bits(i) as f32 / 1024.0 - 2.0e6).collect();
        let mut k = 0u32;
        type Differences<'a> = &'a dyn Fn(&[__m256; 3]) -> [__m256; 3];
        let mut check = |name: &str, tex: Differences, value: &dyn Fn(usize) -> f64, inside: bool| {
            let largest = (0..n).map(|i| value(i).abs()).fold(0.0, f64::max);
            for _ in 0..100 {
                let mut u = [[0f32; 8]; 3];
                for (a, axis) in u.iter_mut().enumerate() {
                    for x in axis.iter_mut() {
                        k += 1;
                        let r = (crate::model::hash32(k) >> 8) as f32 / 16_777_216.0;
                        // Inside: cells b = 1 to d - 3 along the last axis.
                        *x = if inside && a == 2 {
                            1.0 + r * (dims[a] as f32 - 3.0)
                        } else {
                            r * (dims[a] as f32 + 1.0) - 0.5
                        };
                    }
                }
                // SAFETY: AVX2, FMA and F16C are available.
                let got = tex(&unsafe { u.map(|x| _mm256_loadu_ps(x.as_ptr())) }).map(|x| unsafe { lanes(x) });
                for (c, got) in got.iter().enumerate() {
                    for l in 0..8 {
                        let want = difference_f64(value, dims, [0, 1, 2].map(|a| u[a][l] as f64), c);
                        let close = (got[l] as f64 - want).abs() <= 4e-6 * largest;
                        assert!(close, "{name}, axis {c}, lane {l} (inside {inside}): {} against {want}", got[l]);
                    }
                }
            }
        };
        fn with<T: Texels>(tex: &T, dims: [usize; 3]) -> impl Fn(&[__m256; 3]) -> [__m256; 3] + '_ {
            move |u| {
                // SAFETY: AVX2, FMA and F16C are available; the storage holds what its reads need.
                unsafe {
                    let hi = dims.map(|d| _mm256_set1_epi32(d as i32 - 1));
                    let stride = tex.strides(dims).map(|s| _mm256_set1_epi32(s));
                    // The sample's own value from its cell's rows, which the
                    // differences then share: the trilinear read's, bit for bit.
                    let rows = CellRows::read(tex, u, &hi, &stride);
                    if let Some(rows) = &rows {
                        let (offs, w) = corners(u, &hi, &stride);
                        let (got, want) = (lanes(rows.value()), lanes(tex.trilinear(&offs, &w)[0]));
                        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{got:?} against {want:?}");
                    }
                    differences(tex, u, &hi, &stride, rows.as_ref())
                }
            }
        }
        for inside in [true, false] {
            check("R8Unorm", &with(&R8Unorm(&r8), dims), &|i| r8[i] as f64, inside);
            check("R16Unorm", &with(&R16Unorm(&r16), dims), &|i| r16[i] as f64, inside);
            check("R16Snorm", &with(&R16Snorm(&s16), dims), &|i| s16[i] as f64, inside);
            check("R16Float", &with(&R16Float(&f16), dims), &|i| half_value(f16[i]), inside);
            check("R32Float", &with(&R32Float(&f32s), dims), &|i| f32s[i] as f64, inside);
        }
    }
}
