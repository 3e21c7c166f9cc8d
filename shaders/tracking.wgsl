// Unbiased frames (RenderConfig.unbiased): ratio tracking (Novák, Selle and
// Jarosz 2014) on the segment grid. Each segment holds the points of a
// Poisson process whose rate is a majorant of the extinction over the
// segment, and each point is composited like a segment of opacity
// sigma / rate. For a Poisson process E[prod (1 - sigma(x_k) / rate)] =
// exp(-integral of sigma), and the emitted colour sums the same way, so a
// frame's expectation is the exact integral whatever the step; the step
// only sets the least density of points (one a step on average).
// Averaged frames converge to the integral, where jittered midpoint frames
// converge to the mean over grid offsets, which compositing (not linear in
// the offset) keeps away from it. The points of a block of segments come
// from a stream seeded by the pixel, the block and the seed, so passes,
// bricks and leaps all see the same points; points in an empty cell add
// nothing, so leaping over them changes no estimate. Early termination
// becomes Russian roulette, which keeps the expectation.

// Uniform in (0, 1); the stream advances.
fn stream_uniform(state: ptr<function, u32>) -> f32 {
    *state = *state * 747796405u + 2891336453u;
    return (f32(hash32(*state) >> 8u) + 0.5) * (1.0 / 16777216.0);
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
    let c0 = cell_of(voxel_coords(tex_of(point_at(r, sp.x + 0.5 * sp.y))));
    let q = textureLoad(occupancy, c0, 0).r;
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

// Segments per stream. A stream whose block of segments ends without
// another point still costs a pass of the loop, so blocks of 8 take an
// eighth of those; segments with their own rate (CELL_RATES) keep one each.
fn block_size() -> u32 {
    return select(8u, 1u, CELL_RATES);
}

fn block_stream(r: Ray, k: u32) -> u32 {
    return hash32(r.idx ^ hash32(k ^ hash32(P.jitter_seed ^ 0x68e31da4u)));
}

// Block k's (start offset, length): segments [kB, min((k + 1)B, n)).
fn block_span(r: Ray, k: u32) -> vec2<f32> {
    let first = span(r, k * block_size());
    let last = span(r, min((k + 1u) * block_size(), r.n) - 1u);
    return vec2<f32>(first.x, last.x + last.y - first.x);
}

// The block holding ray offset t.
fn block_at(r: Ray, t: f32) -> u32 {
    return u32(clamp(floor(t / P.step_size - r.shift), 0.0, f32(r.n) - 1.0)) / block_size();
}

// Emission–absorption, absorption and emission from Poisson points. Each
// block of segments has its stream (a hash of pixel, block and seed), so
// passes and bricks, which march windows of whole segments, and leaps all
// see the same points: a window takes its blocks' points that lie in it.
// One fetch per pass of the outer loop; the inner loop moves on to the next
// point (past exhausted blocks, and points before the window or in a leapt
// cell) without one.
fn march_tracking(r: Ray) {
    var s = start_integration(r);
    var stopped = false;
    var taken = 0u;
    if (r.begin >= r.end) {
        end_integration(r, &s, stopped, taken);
        return;
    }
    var dir = r.d;
    // The window's segments in grid order and its offsets [w_lo, w_hi).
    var si_lo = r.begin;
    var si_hi = r.end - 1u;
    if (BACK_TO_FRONT) {
        dir = -r.d;
        si_lo = r.n - r.end;
        si_hi = r.n - 1u - r.begin;
    }
    // Points outside the segments that reach occupied cells lie in empty
    // ones and add nothing: the walk keeps to those segments (in grid order).
    var occupied = occupied_window(r, 0.5);
    if (BACK_TO_FRONT) {
        occupied = vec2<u32>(r.n - occupied.y, r.n - occupied.x);
    }
    if (occupied.y == 0u || max(si_lo, occupied.x) > min(si_hi, occupied.y - 1u)) {
        end_integration(r, &s, stopped, taken);
        return;
    }
    si_lo = max(si_lo, occupied.x);
    si_hi = min(si_hi, occupied.y - 1u);
    let w_lo = span(r, si_lo).x;
    let hi_span = span(r, si_hi);
    let w_hi = hi_span.x + hi_span.y;
    // The current block, its span, stream and rate; its next point at
    // distance u from the block's start in the march direction; points
    // before offset `skip_to` (in the march direction) are passed.
    var k = si_lo / block_size();
    var skip_to = w_lo;
    if (BACK_TO_FRONT) {
        k = si_hi / block_size();
        skip_to = w_hi;
    }
    var bsp = vec2<f32>(0.0);
    var state = 0u;
    var rate = 0.0;
    var u = 0.0;
    var at = 0.0;
    var entered = false;
    var done = false;
    loop {
        loop {
            if (!entered) {
                bsp = block_span(r, k);
                state = block_stream(r, k);
                rate = segment_rate(r, bsp);
                // No points in an empty segment: it is passed at once.
                u = 3.0e38;
                if (rate > 0.0) {
                    u = next_gap(&state, rate);
                }
                entered = true;
            }
            if (u >= bsp.y) {
                // The block is exhausted: the next one, unless past the window.
                if (BACK_TO_FRONT) {
                    done = k * block_size() <= si_lo;
                    k -= select(1u, 0u, done);
                } else {
                    done = (k + 1u) * block_size() > si_hi;
                    k += 1u;
                }
                if (done) {
                    break;
                }
                entered = false;
                continue;
            }
            at = bsp.x + u;
            if (BACK_TO_FRONT) {
                at = bsp.x + bsp.y - u;
            }
            let past = select(at >= w_hi, at < w_lo, BACK_TO_FRONT);
            if (past) {
                done = true;
                break;
            }
            if (select(at >= skip_to, at < skip_to, BACK_TO_FRONT)) {
                break;
            }
            u += next_gap(&state, rate);
        }
        if (done) {
            break;
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
                skip_to = at + exit - back;
                var next = max(block_at(r, skip_to), k);
                if (BACK_TO_FRONT) {
                    skip_to = at - exit + back;
                    next = min(block_at(r, skip_to), k);
                }
                if (next != k) {
                    k = next;
                    entered = false;
                }
                continue;
            }
        }
        let add = lit(g, p, r.d, &taken);
        if (composite(&s, g.x, add, taken)) {
            // Russian roulette below transmittance q: on with probability
            // T / q at weight q, else stopped (T = 0). Its number comes from
            // the point, not the block's stream: a window that starts inside
            // the block must draw the same points after it.
            let q = 1.0 - P.threshold;
            let roll = hash32(bitcast<u32>(at) ^ hash32(r.idx ^ hash32(P.jitter_seed ^ 0x2545f491u)));
            let xi = (f32(roll >> 8u) + 0.5) * (1.0 / 16777216.0);
            if (s.trans > 0.0 && q > 0.0 && xi * q < s.trans) {
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
