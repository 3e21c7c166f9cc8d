// The first crossing of the iso value, located by bisection and a secant step.

fn below_iso(v: f32) -> bool {
    // NaN counts as outside.
    return !(v >= P.iso_value);
}

// First point where the value reaches iso_value: the entry, each segment's
// midpoint and the exit are tested; the crossing is then bracketed by
// bisection and placed by a secant step. The hit's ray parameter goes to
// ray_state.x (infinity on a miss) for the depth image.
fn march_iso(r: Ray) {
    var prev = 0.0;
    var prev_v = 0.0;
    var prev_known = true;
    var taken = 0u;
    var found = false;
    var hit = 0.0;
    // State: (previous offset, its value, 1 if that value is known, 1 once
    // the ray has been started).
    var started = false;
    if (P.first_pass == 0u) {
        let st = ray_state[r.idx];
        prev = st.x;
        prev_v = st.y;
        prev_known = st.z != 0.0;
        started = st.w != 0.0;
    }
    if (!started && (r.begin < r.end || (r.entry && P.pass_start == 0u))) {
        started = true;
        if (r.entry) {
            prev = 0.0;
            prev_v = value_at(tex_of(point_at(r, 0.0)));
            if (!below_iso(prev_v)) {
                found = true;
            }
        } else {
            // A brick past the entry, reached first (the bricks before it
            // were skipped as unable to reach the iso value, or are rendered
            // elsewhere): the last midpoint before its window brackets the
            // crossing, read from its ghost voxels.
            let sp = span(r, r.begin - 1u);
            prev = sp.x + 0.5 * sp.y;
            prev_v = value_at(tex_of(point_at(r, prev)));
        }
        prev_known = true;
        taken += 1u;
    }
    var i = r.begin;
    loop {
        if (found) {
            break;
        }
        var at: f32;
        if (i < r.end) {
            let sp = span(r, i);
            at = sp.x + 0.5 * sp.y;
        } else if (i == r.n && r.n == r.needed && started && P.resolve == 0u) {
            at = r.chord;
        } else {
            break;
        }
        i += 1u;
        let v = value_at(tex_of(point_at(r, at)));
        taken += 1u;
        if (!below_iso(v)) {
            if (!prev_known) {
                prev_v = value_at(tex_of(point_at(r, prev)));
                taken += 1u;
            }
            hit = locate_crossing(r, prev, at, prev_v, v);
            taken += ISO_BISECTIONS;
            found = true;
            break;
        }
        if (SKIP_EMPTY && i <= r.end) {
            // Below iso_value here; if no value in this cell reaches it,
            // leap to the first midpoint past the cell, keeping as the
            // bracket's lower end the last midpoint inside it.
            let next = iso_leap(r, i, at);
            if (next > i) {
                let sp = span(r, next - 1u);
                prev = sp.x + 0.5 * sp.y;
                // Sampled only if the next sample hits (below).
                prev_known = false;
                i = next;
                continue;
            }
        }
        prev = at;
        prev_v = v;
        prev_known = true;
    }
    count_samples(taken);
    if (!found && r.end < r.n) {
        suspend(r, vec4<f32>(prev, prev_v, select(0.0, 1.0, prev_known), select(0.0, 1.0, started)));
        return;
    }
    if (!found) {
        report_truncation(r);
        ray_state[r.idx] = vec4<f32>(bitcast<f32>(0x7f800000u), 0.0, 0.0, 0.0);
        finish(r, vec4<f32>(0.0));
        return;
    }
    shade_hit(r, hit);
}

// Bisection between offsets lo (below the iso value) and hi (reaching it),
// then a secant step between the last bracket's values: the hit's offset.
fn locate_crossing(r: Ray, lo0: f32, hi0: f32, vlo0: f32, vhi0: f32) -> f32 {
    var lo = lo0;
    var hi = hi0;
    var vlo = vlo0;
    var vhi = vhi0;
    for (var k = 0u; k < ISO_BISECTIONS; k++) {
        let m = 0.5 * (lo + hi);
        let vm = value_at(tex_of(point_at(r, m)));
        if (below_iso(vm)) {
            lo = m;
            vlo = vm;
        } else {
            hi = m;
            vhi = vm;
        }
    }
    var hit = hi;
    if (!is_nan(vlo) && vhi > vlo) {
        hit = lo + (hi - lo) * clamp((P.iso_value - vlo) / (vhi - vlo), 0.0, 1.0);
    }
    return hit;
}

// The first segment index past the empty cell holding offset `at` (never
// before segment i), or i when the cell may reach the iso value.
fn iso_leap(r: Ray, i: u32, at: f32) -> u32 {
    let exit = empty_cell_exit(tex_of(point_at(r, at)), r.d);
    if (exit < 0.0) {
        return i;
    }
    let k = ceil((at + exit) / P.step_size - 0.5 - r.shift - 1e-3);
    return u32(clamp(k, f32(i), f32(r.end)));
}

// The surface's colour, lit, and its distance for the depth image.
fn shade_hit(r: Ray, hit: f32) {
    let p = point_at(r, hit);
    let c = eval_lut(P.iso_value);
    ray_state[r.idx] = vec4<f32>(r.t0 + hit, 0.0, 0.0, 0.0);
    finish(r, vec4<f32>(c.rgb * surface_intensity(p), 1.0));
}
