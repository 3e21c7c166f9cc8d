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
    var stopped = false;
    var taken = 0u;
    for (var i = r.begin; i < r.end; i++) {
        let sp = span(r, i);
        if (!(sp.y > 0.0)) {
            continue;
        }
        let v = value_at(tex_of(point_at(r, sp.x + 0.5 * sp.y)));
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
