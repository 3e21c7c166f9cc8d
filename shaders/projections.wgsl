// Projections of the sampled values: maximum, minimum and average intensity.

// Maximum, minimum and average intensity of the samples (NaN skipped);
// the pixel is the transfer function's premultiplied RGBA of that value.
// The table clamps values to [0, 1], so a ray whose maximum reaches 1 (whose
// minimum reaches 0) has its pixel and stops, as an opaque one does (one
// texture: bricks combine their rays' partial states afterwards).
fn march_project(r: Ray) {
    // (best or length-weighted sum, 1 if any sample or summed length, -, -)
    var st = vec4<f32>(0.0);
    if (P.first_pass == 0u) {
        st = ray_state[r.idx];
    }
    let stops = P.bricked == 0u && MODEL != MODEL_AVERAGE;
    // A maximum (minimum) projection's ray that has read a value leaps a
    // cell whose values cannot pass it, and the cube of cells around it
    // where their bound cannot either. `occupancy` then holds each cell's
    // bound and its cube's (src/renderer/resources/stored.rs `ProjectionBounds`).
    let leaps = SKIP_EMPTY && MODEL != MODEL_AVERAGE;
    var stopped = false;
    var taken = 0u;
    for (var i = r.begin; i < r.end; i++) {
        let sp = span(r, i);
        if (!(sp.y > 0.0)) {
            continue;
        }
        let mid = sp.x + 0.5 * sp.y;
        let tc = tex_of(point_at(r, mid));
        if (leaps && st.y > 0.0) {
            let bound = bitcast<vec2<f32>>(textureLoad(occupancy, cell_of(voxel_coords(tc)), 0).rg);
            // The value so far, less 1e-6 of the f32 mapping's terms
            // (src/occupancy.rs `value_bounds`).
            let slack = (abs(st.x) + abs(P.value_offset)) * 1e-6;
            var passed = bound >= vec2<f32>(st.x - slack);
            if (MODEL == MODEL_MIP) {
                passed = bound <= vec2<f32>(st.x + slack);
            }
            if (passed.x) {
                let exit = exit_of_cube(tc, r.d, select(1u, PROJECTION_CUBE, passed.y));
                i = segment_past(r, i, i, mid, exit) - 1u;
                continue;
            }
        }
        let v = value_at(tc);
        taken += 1u;
        if (is_nan(v)) {
            continue;
        }
        if (MODEL == MODEL_AVERAGE) {
            st.x += v * sp.y;
            st.y += sp.y;
        } else if (st.y == 0.0) {
            st = vec4<f32>(v, 1.0, 0.0, 0.0);
        } else if (MODEL == MODEL_MIP) {
            st.x = max(st.x, v);
        } else {
            st.x = min(st.x, v);
        }
        if (stops && select(st.x <= 0.0, st.x >= 1.0, MODEL == MODEL_MIP)) {
            stopped = true;
            break;
        }
    }
    count_samples(taken);
    if (!stopped && r.end < r.n) {
        suspend(r, st);
        return;
    }
    if (!stopped) {
        report_truncation(r);
    }
    if (P.keep_state == 1u) {
        // A partial image: the state itself, combined across bricks later.
        finish(r, st);
        return;
    }
    if (!(st.y > 0.0)) {
        finish(r, vec4<f32>(0.0));
        return;
    }
    var v = st.x;
    if (MODEL == MODEL_AVERAGE) {
        v = st.x / st.y;
    }
    let c = eval_lut(v);
    finish(r, vec4<f32>(c.rgb * c.a, c.a));
}
