// Entry point: one invocation per pixel builds its ray, clips it to the
// (cropped) box and runs the model's march. The marching rule is the one in
// src/integrate.rs (the f64 oracle): the chord through the box is cut into
// step-long segments (the last one shorter, and with jitter the first one
// too), each sampled at its midpoint and weighted by its own length.

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.width || gid.y >= P.height) {
        return;
    }
    // Row 0 is the bottom of the image, as pyvr returns it.
    let idx = gid.y * P.width + gid.x;
    if (P.first_pass == 0u && ray_done[idx] != 0u) {
        return;
    }
    let ndc = vec2<f32>(
        2.0 * (f32(gid.x) + 0.5) / f32(P.width) - 1.0,
        2.0 * (f32(gid.y) + 0.5) / f32(P.height) - 1.0,
    );
    let o = P.cam_pos.xyz;
    let d = normalize(P.cam_fwd.xyz + ndc.x * P.cam_right.xyz + ndc.y * P.cam_up.xyz);

    // Slab test; a zero direction component never divides.
    var t0 = -3.0e38;
    var t1 = 3.0e38;
    var hit = true;
    for (var a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < P.clip_lo[a] || o[a] > P.clip_hi[a]) {
                hit = false;
            }
        } else {
            let inv = 1.0 / d[a];
            let ta = (P.clip_lo[a] - o[a]) * inv;
            let tb = (P.clip_hi[a] - o[a]) * inv;
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    var r: Ray;
    r.idx = idx;
    if (!hit || t0 > t1 || t1 <= 0.0) {
        if (MODEL == MODEL_ISOSURFACE) {
            ray_state[idx] = vec4<f32>(bitcast<f32>(0x7f800000u), 0.0, 0.0, 0.0);
        }
        finish(r, vec4<f32>(0.0));
        return;
    }
    t0 = max(t0, 0.0);
    r.o = o;
    r.d = d;
    r.t0 = t0;
    r.chord = t1 - t0;
    r.shift = 0.0;
    if (JITTER) {
        r.shift = jitter_shift(gid.x, gid.y);
    }
    let needed_f = ceil(r.chord / P.step_size - r.shift);
    r.needed = u32(min(needed_f, 4.0e9));
    r.n = min(r.needed, P.max_steps);
    r.begin = P.pass_start;
    r.end = r.n;
    if (P.last_pass == 0u) {
        r.end = min(r.n, P.pass_start + P.pass_steps);
    }
    if (MODEL == MODEL_ISOSURFACE) {
        march_iso(r);
    } else if (MODEL == MODEL_MIP || MODEL == MODEL_MINIP || MODEL == MODEL_AVERAGE) {
        march_project(r);
    } else {
        march_integrate(r);
    }
}
