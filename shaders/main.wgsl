// Entry point: one invocation per pixel builds its ray, clips it to the
// (cropped) box and the clip planes and runs the model's march. The marching rule is the one in
// src/integrate.rs (the f64 oracle): the chord through the box is cut into
// step-long segments (the last one shorter, and with jitter the first one
// too), each sampled at its midpoint and weighted by its own length.

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {
    // A brick's dispatch covers only the pixels its box can cover.
    let gid = group_origin(wg.xy, groups.x) + lid.xy + vec2<u32>(P.tile_x, P.tile_y);
    if (gid.x >= P.width || gid.y >= P.height) {
        return;
    }
    // Row 0 is the bottom of the image, as pyvr returns it.
    let idx = gid.y * P.width + gid.x;
    if (P.first_pass == 0u && ray_done[idx] != 0u) {
        return;
    }
    // (2x + 1 - W) / W: the numerator is an exact integer, so the centre
    // pixel's 0 stays 0 however the division rounds (WGSL allows 2.5 ulp;
    // 2(x + 0.5) / W - 1 cancels that error into 6e-8, which a field of view
    // near pi, tan(fov / 2) = 2e6, turns into a 7 degree turn).
    let ndc = vec2<f32>(
        (2.0 * f32(gid.x) + 1.0 - f32(P.width)) / f32(P.width),
        (2.0 * f32(gid.y) + 1.0 - f32(P.height)) / f32(P.height),
    );
    var o = P.cam_pos.xyz;
    var d = P.cam_fwd.xyz;
    if (P.orthographic == 1u) {
        o = o + ndc.x * P.cam_right.xyz + ndc.y * P.cam_up.xyz;
    } else {
        d = normalize(d + ndc.x * P.cam_right.xyz + ndc.y * P.cam_up.xyz);
    }

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
    // Clip planes: along the ray n . p + c is f0 + t (n . d).
    for (var k = 0u; k < P.clip_count; k++) {
        let q = P.clip_planes[k];
        let f0 = dot(q.xyz, o) + q.w;
        let slope = dot(q.xyz, d);
        if (slope > 0.0) {
            t0 = max(t0, -f0 / slope);
        } else if (slope < 0.0) {
            t1 = min(t1, -f0 / slope);
        } else if (f0 < 0.0) {
            hit = false;
        }
    }
    if (P.depth_in == 1u) {
        t1 = min(t1, textureLoad(opaque_depth, vec2<i32>(gid), 0).r);
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
    // The segments this dispatch's brick holds, as march indices (which
    // run from the far end when marching back to front).
    var w = vec2<u32>(0u, r.n);
    r.entry = true;
    if (P.bricked == 1u) {
        w = brick_window(r, t1);
        r.entry = w.y > w.x && w.x == 0u;
        if (w.y <= w.x) {
            // No segments here: the ray waits for its other bricks (a window
            // at the ray's end would otherwise finish it before them).
            w = vec2<u32>(0u);
        } else if (BACK_TO_FRONT) {
            w = vec2<u32>(r.n - w.y, r.n - w.x);
        }
    }
    r.begin = w.x + P.pass_start;
    r.end = w.y;
    if (P.last_pass == 0u) {
        r.end = min(w.y, r.begin + P.pass_steps);
    }
    if (P.resolve == 1u) {
        // Every ray not finished yet ends here, from its state.
        r.begin = r.n;
        r.end = r.n;
        r.entry = false;
    }
    if (MODEL == MODEL_ISOSURFACE) {
        march_iso(r);
    } else if (MODEL == MODEL_MIP || MODEL == MODEL_MINIP || MODEL == MODEL_AVERAGE) {
        march_project(r);
    } else {
        march_integrate(r);
    }
}

// The first pixel of workgroup `wg` of a dispatch `groups_x` workgroups
// wide (a multiple of GROUP_TILE). A CPU device runs workgroups in the order
// of their index, x fastest; consecutive indices here cover tiles of
// GROUP_TILE x GROUP_TILE workgroups, row by row within a tile and tile by
// tile, instead of rows of the whole image, so that the rays marched close
// in time cross nearby voxels, which are then still in the caches.
fn group_origin(wg: vec2<u32>, groups_x: u32) -> vec2<u32> {
    let index = wg.x + wg.y * groups_x;
    let per_tile = GROUP_TILE * GROUP_TILE;
    let tile = index / per_tile;
    let within = index % per_tile;
    let tiles_x = groups_x / GROUP_TILE;
    let group = vec2<u32>(tile % tiles_x, tile / tiles_x) * GROUP_TILE + vec2<u32>(within % GROUP_TILE, within / GROUP_TILE);
    return group * 8u;
}

// A brick holds the segments whose nominal midpoints (i + shift + 1/2) steps
// past the entry lie in its core box [core_lo, core_hi) (faces on the
// volume's boundary are pushed out to infinity); the first segment belongs
// to the brick holding the entry, the last to the one holding the exit.
// Neighbouring bricks compute the shared face's ray parameter from the same
// f32 plane, so their windows tile the ray: every segment is marched once.
// Returns segment indices [lo, hi); (0, 0) when the ray misses the brick.
fn brick_window(r: Ray, t1: f32) -> vec2<u32> {
    var a0 = r.t0;
    var a1 = t1;
    for (var a = 0; a < 3; a++) {
        if (r.d[a] == 0.0) {
            if (r.o[a] < P.core_lo[a] || r.o[a] >= P.core_hi[a]) {
                return vec2<u32>(0u);
            }
        } else {
            let inv = 1.0 / r.d[a];
            let ta = (P.core_lo[a] - r.o[a]) * inv;
            let tb = (P.core_hi[a] - r.o[a]) * inv;
            a0 = max(a0, min(ta, tb));
            a1 = min(a1, max(ta, tb));
        }
    }
    if (!(a1 > a0)) {
        return vec2<u32>(0u);
    }
    var lo = 0u;
    if (a0 > r.t0) {
        lo = segment_at(r, a0);
    }
    var hi = r.n;
    if (a1 < t1) {
        hi = segment_at(r, a1);
    }
    return vec2<u32>(min(lo, r.n), min(hi, r.n));
}

// The first segment whose nominal midpoint is at or past ray parameter t.
fn segment_at(r: Ray, t: f32) -> u32 {
    let k = ceil((t - r.t0) / P.step_size - r.shift - 0.5);
    return u32(clamp(k, 0.0, 4.0e9));
}
