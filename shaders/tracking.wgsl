// Unbiased frames (RenderConfig.unbiased): ratio tracking (Novák, Selle and
// Jarosz 2014) on the segment grid. Each segment holds the points of a
// Poisson process whose rate is a majorant of the extinction over the
// segment, and each point is composited like a segment of opacity
// sigma / rate. For a Poisson process E[prod (1 - sigma(x_k) / rate)] =
// exp(-integral of sigma), and the emitted colour sums the same way, so a
// frame's expectation is the exact integral whatever the step; the step
// only sets the least density of points (one a step on average). Averaged frames converge to the integral,
// where jittered midpoint frames converge to the mean over grid offsets,
// which compositing (not linear in the offset) keeps away from it.
// A segment's points come from a stream seeded by the pixel, the segment and
// the seed, so passes, bricks and leaps all see the same points; points in
// an empty cell add nothing, so leaping over them changes no estimate.
// Early termination becomes Russian roulette, which keeps the expectation.

// Uniform in (0, 1); the stream advances.
fn stream_uniform(state: ptr<function, u32>) -> f32 {
    *state = *state * 747796405u + 2891336453u;
    return (f32(hash32(*state) >> 8u) + 0.5) * (1.0 / 16777216.0);
}

fn segment_stream(r: Ray, si: u32) -> u32 {
    return hash32(r.idx ^ hash32(si ^ hash32(P.jitter_seed ^ 0x68e31da4u)));
}

// The distance from one point of the process to the next.
fn next_gap(state: ptr<function, u32>, rate: f32) -> f32 {
    return -log(stream_uniform(state)) / rate;
}

// A segment's rate: the majorant its midpoint's occupancy cell holds (the
// largest extinction over every segment centred in the cell, coded by
// MinMaxGrid::majorants, 4.4% steps), at least one point a step and at most
// the frame's rate (the transfer function's largest extinction, capped at
// MAX_POINTS_PER_STEP a step). Cost then follows the extinction where rays
// are, not the densest material anywhere. 0 for an empty cell when leaping:
// its points would all add nothing (leaps pass such segments anyway).
fn segment_rate(r: Ray, sp: vec2<f32>) -> f32 {
    if (!CELL_RATES) {
        // The frame's rate is the least one: no cell can lower it.
        return P.track_rate;
    }
    let least = 1.0 / P.step_size;
    let u = tex_of(point_at(r, sp.x + 0.5 * sp.y)) * vec3<f32>(textureDimensions(volume));
    let c0 = max(vec3<i32>(floor(u / CELL)), vec3<i32>(0));
    let q = textureLoad(occupancy, level_cell(c0, 0u), 0).r;
    let cell = select(exp2((f32(q) - 128.0) / 16.0) * P.inv_ref, P.track_rate, q >= 255u || q == 0u);
    let rate = clamp(cell, least, P.track_rate);
    return select(rate, 0.0, SKIP_EMPTY && q == 0u);
}

// A point as a segment of opacity o = sigma / rate (optical depth
// -ln(1 - o)); the emission model, which never absorbs, adds sigma / rate of
// the colour. Extinction beyond the rate (where the frame's rate is capped
// at MAX_POINTS_PER_STEP a step, src/config.rs) is taken as opaque.
fn tracked_point(texel: vec4<f32>, rate: f32) -> Segment {
    let v = tf_value(texel.r);
    let valid = !is_nan(v);
    let rgba = eval_lut(select(0.0, v, valid));
    let a = extinction(select(0.0, rgba.a, valid)) * P.inv_ref / rate;
    var g: Segment;
    g.texel = texel;
    g.have_texel = true;
    if (MODEL == MODEL_EMISSION) {
        g.x = min(a, 1.0e30);
        g.add = g.x * rgba.rgb;
        return g;
    }
    let o = min(a, 1.0);
    g.x = select(neg_log_one_minus(o), 1.0e30, o >= 1.0);
    g.add = select(o * rgba.rgb, vec3<f32>(0.0), MODEL == MODEL_ABSORPTION);
    return g;
}

// The segment holding ray offset t, as a march index at or past i.
fn march_index_at(r: Ray, i: u32, t: f32) -> u32 {
    let k = u32(clamp(floor(t / P.step_size - r.shift), 0.0, f32(r.n) - 1.0));
    if (BACK_TO_FRONT) {
        return max(r.n - 1u - k, i);
    }
    return max(k, i);
}

// Emission–absorption, absorption and emission from Poisson points. One
// fetch per pass of the outer loop; the inner loop moves on to the next
// point (past exhausted segments and points in a leapt cell) without one.
fn march_tracking(r: Ray) {
    var s = start_integration(r);
    var stopped = false;
    var taken = 0u;
    var dir = r.d;
    if (BACK_TO_FRONT) {
        dir = -r.d;
    }
    // The current segment (march index i, grid index si, span sp), its
    // stream, its next point at distance u from the segment's start in the
    // march direction, and the distance before which its points are leapt.
    var i = r.begin;
    var si = 0u;
    var sp = vec2<f32>(0.0);
    var state = 0u;
    var rate = 0.0;
    var u = 0.0;
    var skip_below = 0.0;
    var entered = false;
    loop {
        loop {
            if (i >= r.end) {
                break;
            }
            if (!entered) {
                si = i;
                if (BACK_TO_FRONT) {
                    si = r.n - 1u - i;
                }
                sp = span(r, si);
                state = segment_stream(r, si);
                rate = segment_rate(r, sp);
                // No points in an empty segment: it is passed at once.
                u = 3.0e38;
                if (rate > 0.0) {
                    u = next_gap(&state, rate);
                }
                entered = true;
            }
            if (u >= sp.y) {
                i += 1u;
                entered = false;
                skip_below = 0.0;
                continue;
            }
            if (u >= skip_below) {
                break;
            }
            u += next_gap(&state, rate);
        }
        if (i >= r.end) {
            break;
        }
        var at = sp.x + u;
        if (BACK_TO_FRONT) {
            at = sp.x + sp.y - u;
        }
        let p = point_at(r, at);
        let tc = tex_of(p);
        taken += 1u;
        let g = tracked_point(volume_texel(tc), rate);
        u += next_gap(&state, rate);
        if (SKIP_EMPTY && !(g.x > 0.0)) {
            let exit = empty_cell_exit(tc, dir);
            if (exit >= 0.0) {
                // Resume at the cell's far side (a thousandth of a step early:
                // rounding must never pass over an occupied point).
                let back = 1e-3 * P.step_size;
                var resume = at + exit - back;
                if (BACK_TO_FRONT) {
                    resume = at - exit + back;
                }
                let k = march_index_at(r, i, resume);
                if (k != i) {
                    i = k;
                    entered = false;
                    if (i < r.end) {
                        var ks = i;
                        if (BACK_TO_FRONT) {
                            ks = r.n - 1u - i;
                        }
                        let ksp = span(r, ks);
                        skip_below = select(resume - ksp.x, ksp.x + ksp.y - resume, BACK_TO_FRONT);
                    }
                } else {
                    skip_below = select(resume - sp.x, sp.x + sp.y - resume, BACK_TO_FRONT);
                }
                continue;
            }
        }
        let add = lit(g, p, r.d, &taken);
        if (composite(&s, g.x, add, taken)) {
            // Russian roulette below transmittance q: on with probability
            // T / q at weight q, else stopped (T = 0).
            let q = 1.0 - P.threshold;
            if (s.trans > 0.0 && q > 0.0 && stream_uniform(&state) * q < s.trans) {
                s.color += s.color_b;
                s.color_b = vec3<f32>(0.0);
                s.tau = -log(q);
                s.tau_b = 0.0;
                s.trans = q;
            } else {
                s.tau = 1.0e30;
                s.tau_b = 0.0;
                s.trans = 0.0;
                stopped = true;
                break;
            }
        }
    }
    end_integration(r, &s, stopped, taken);
}
