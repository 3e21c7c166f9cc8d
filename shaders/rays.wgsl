// One ray: its segments, jitter, sample counting, and where its result
// (or its state between passes) goes.

// 64-bit sample count from two words: a carry when the low word wraps.
fn count_samples(k: u32) {
    if (k == 0u) {
        return;
    }
    let old = atomicAdd(&stats[1], k);
    if (old > 0xffffffffu - k) {
        atomicAdd(&stats[2], 1u);
    }
}

// src/model.rs: hash32 and jitter_shift, bit for bit.
fn hash32(x0: u32) -> u32 {
    var x = x0;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

fn jitter_shift(col: u32, row: u32) -> f32 {
    let h = hash32(col ^ hash32(row ^ hash32(P.jitter_seed)));
    return -f32(h >> 8u) * (1.0 / 16777216.0);
}

// One ray: its chord [t0, t0 + chord] and segment grid (shift in (-1, 0]
// steps), and the segments this pass marches, [begin, end).
struct Ray {
    idx: u32,
    o: vec3<f32>,
    d: vec3<f32>,
    t0: f32,
    chord: f32,
    shift: f32,
    n: u32,
    needed: u32,
    begin: u32,
    end: u32,
    // This dispatch's segments start at the ray's entry.
    entry: bool,
};

// Segment i: (offset of its start from t0, its length).
fn span(r: Ray, i: u32) -> vec2<f32> {
    let h = P.step_size;
    let a = f32(i) * h + r.shift * h;
    if (a < 0.0) {
        return vec2<f32>(0.0, min((1.0 + r.shift) * h, r.chord));
    }
    return vec2<f32>(a, max(min(h, r.chord - a), 0.0));
}

fn point_at(r: Ray, offset: f32) -> vec3<f32> {
    return r.o + r.d * (r.t0 + offset);
}

// A position's coordinates in the bound volume texture (the whole volume,
// or one brick of it with its ghost voxels).
fn tex_of(p: vec3<f32>) -> vec3<f32> {
    return (p * P.tex_scale.xyz + P.tex_offset.xyz).zyx;
}

// Where a finished ray's pixel goes; rays that continue keep their state.
fn finish(r: Ray, rgba: vec4<f32>) {
    out_rgba[r.idx] = rgba;
    if (P.only_dispatch == 0u) {
        ray_done[r.idx] = 1u;
    }
}

fn suspend(r: Ray, state: vec4<f32>) {
    ray_state[r.idx] = state;
    if (P.first_pass == 1u) {
        ray_done[r.idx] = 0u;
    }
}

fn report_truncation(r: Ray) {
    if (r.n < r.needed) {
        atomicMax(&stats[0], r.needed);
    }
}
