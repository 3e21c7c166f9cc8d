// Beer–Lambert models (emission–absorption, absorption, emission, single
// scattering): optical depth summed along the ray, colour composited front
// to back or back to front, optionally from pre-integrated segments.

// Samples per partial sum: 2^BLOCK_SHIFT.
const BLOCK_SHIFT: u32 = 8u;

fn one_minus_exp_neg(x: f32) -> f32 {
    // Series below 1e-3, where 1 - exp(-x) would cancel.
    let series = x * (1.0 - x * (0.5 - x * (1.0 / 6.0)));
    return select(1.0 - exp(-x), series, x < 1e-3);
}

// -ln(1 - a) for a in [0, 1), with a series below 1e-3 where 1 - a rounds.
fn neg_log_one_minus(a: f32) -> f32 {
    let series = a * (1.0 + a * (0.5 + a * (1.0 / 3.0)));
    return select(-log(1.0 - a), series, a < 1e-3);
}

// Extinction per reference step for a transfer-function opacity `a`:
// exponential form sigma = a; power form sigma = -ln(1 - a) (inf at a = 1).
fn extinction(a: f32) -> f32 {
    if (POWER_CORRECTION) {
        if (a >= 1.0) {
            // Opaque; a huge finite value, since shaders need not honour inf.
            return 1.0e30;
        }
        return neg_log_one_minus(a);
    }
    return a;
}

// Where the pre-integration texture holds a full segment's entry (front and
// back values, a side x side table in its first rows and columns).
fn preint_uv(vf: f32, vb: f32) -> vec2<f32> {
    let m = P.preint_side;
    let size = vec2<f32>(textureDimensions(preint));
    return (clamp(vec2<f32>(vf, vb), vec2<f32>(0.0), vec2<f32>(1.0)) * (m - 1.0) + 0.5) / size;
}

// The table's bilinear lookup at uv, clamped at the texture's edges; with
// EXACT_TABLES by hand with f32 weights (texture units' are 8-bit).
fn preint_entry(uv: vec2<f32>) -> vec4<f32> {
    if (!EXACT_TABLES) {
        return textureSampleLevel(preint, linear_sampler, uv, 0.0);
    }
    let size = vec2<i32>(textureDimensions(preint));
    let p = uv * vec2<f32>(size) - 0.5;
    let f = floor(p);
    let w = p - f;
    let a = clamp(vec2<i32>(f), vec2<i32>(0), size - 1);
    let b = clamp(vec2<i32>(f) + 1, vec2<i32>(0), size - 1);
    let c00 = textureLoad(preint, a, 0);
    let c10 = textureLoad(preint, vec2<i32>(b.x, a.y), 0);
    let c01 = textureLoad(preint, vec2<i32>(a.x, b.y), 0);
    let c11 = textureLoad(preint, b, 0);
    let y0 = c00 + (c10 - c00) * w.x;
    let y1 = c01 + (c11 - c01) * w.x;
    return y0 + (y1 - y0) * w.y;
}

// The opacity the transfer function gains and loses over the values in
// [a, b], from its entries ⌊a(m-1)⌋ to ⌈b(m-1)⌉: the rows below the table
// hold the running sum of |opacity change| from entry to entry.
fn opacity_variation(a: f32, b: f32) -> f32 {
    let m = f32(P.lut_size);
    let i0 = i32(floor(clamp(a, 0.0, 1.0) * (m - 1.0)));
    let i1 = i32(ceil(clamp(b, 0.0, 1.0) * (m - 1.0)));
    return textureLoad(preint, preint_sum_at(i1), 0).r - textureLoad(preint, preint_sum_at(i0), 0).r;
}

// The rows below the table hold the running sums, then the transfer
// function, each wrapped into P.preint_rows rows as wide as the table
// (src/preintegrate.rs `wrapped_rows`): row r holds entries r (w - 1) to
// r (w - 1) + w - 1.
fn preint_sum_at(i: i32) -> vec2<i32> {
    let w1 = i32(P.preint_side) - 1;
    let r = min(i / w1, i32(P.preint_rows) - 1);
    return vec2<i32>(i - r * w1, i32(P.preint_side) + r);
}

// Where it holds the transfer function's entry for value v: each of its
// rows comes twice, and is read between the two, where filtering mixes
// that row with nothing but itself.
fn preint_lut_uv(v: f32) -> vec2<f32> {
    let w = P.preint_side;
    let x = clamp(v, 0.0, 1.0) * (f32(P.lut_size) - 1.0);
    let r = min(floor(x / (w - 1.0)), P.preint_rows - 1.0);
    let row = w + P.preint_rows + 2.0 * r + 1.0;
    return vec2<f32>((x - r * (w - 1.0) + 0.5) / w, row / f32(textureDimensions(preint).y));
}

// What a Beer–Lambert march carries from segment to segment.
// Transmittance is exp(-tau) of the optical depth summed so far, not a
// running product of (1 - alpha): a product loses every segment whose alpha
// is below f32's half-ulp of 1 (6e-8), which tiny steps produce. Sums are
// blocked: 2^BLOCK_SHIFT samples add into a small partial sum (color_b,
// tau_b) that is folded into the total, so a million tiny terms keep their
// precision (compensated sums would be undone by compilers that reassociate).
struct Integration {
    color: vec3<f32>,
    tau: f32,
    color_b: vec3<f32>,
    tau_b: f32,
    trans: f32,
    // Partial sums folded so far (samples taken >> BLOCK_SHIFT).
    blocks: u32,
    // The value and the light at segment boundary `carry_at`
    // (pre-integration shares each boundary between two segments).
    carry_at: u32,
    carry_v: f32,
    carry_light: f32,
    // A refined segment (REFINE) in progress: segment `sub_at` has taken
    // its first `sub - 1` samples (sub = 0: none in progress), whose
    // optical depth and colour composited front to back along the ray are
    // (sub_x, sub_add).
    sub_at: u32,
    sub: u32,
    sub_x: f32,
    sub_add: vec3<f32>,
};

// One segment before lighting: its optical depth x, the colour it emits,
// and the volume's texel at its midpoint when that was fetched.
struct Segment {
    x: f32,
    add: vec3<f32>,
    texel: vec4<f32>,
    have_texel: bool,
};

fn start_integration(r: Ray) -> Integration {
    var s: Integration;
    s.color = vec3<f32>(0.0);
    s.tau = 0.0;
    if (P.first_pass == 0u) {
        let st = ray_state[r.idx];
        s.color = st.xyz;
        s.tau = st.w;
    }
    s.color_b = vec3<f32>(0.0);
    s.tau_b = 0.0;
    s.trans = exp(-s.tau);
    s.blocks = 0u;
    s.carry_at = 0xffffffffu;
    s.carry_v = 0.0;
    s.carry_light = 0.0;
    s.sub_at = 0xffffffffu;
    s.sub = 0u;
    s.sub_x = 0.0;
    s.sub_add = vec3<f32>(0.0);
    return s;
}

// A pre-integrated segment from one volume fetch, lit. A full-length
// segment whose near boundary value is carried from the segment before
// reads its far boundary and looks up the table of (front, back) values; one
// without it (the ray's first, or the first after a leap or a shorter
// segment) fetches that boundary instead and sets `again`, so that the
// caller marches the segment once more; a shorter segment (at the chord's
// ends) uses the midpoint rule. A full segment that needs refining
// (`needs_refining`) sets `again` too and is then marched REFINE times more,
// one midpoint sample of its REFINE pieces each time (in ray order, in
// either march order), and comes out whole after the last. One volume fetch
// and one table fetch per call, each chosen by select: llvmpipe runs both
// sides of a branch under a lane mask whenever any lane takes each side, so
// fetches in alternative branches would all be paid on every segment (so
// a shorter segment's own transfer-function lookup reads the
// pre-integration texture, and refined samples share the segment's loop).
// A full segment's light is the mean of the light at its two ends
// (as in the f64 integrator), each computed once from the texel fetched
// there: normals packed with the values then cost no fetch of their own.
fn preintegrated_segment(r: Ray, si: u32, sp: vec2<f32>, s: ptr<function, Integration>,
                         again: ptr<function, bool>) -> Segment {
    let h = P.step_size;
    let full = sp.y == h;
    // Boundary b is the front of segment b; the march comes from `near`.
    var near = si;
    var far = si + 1u;
    var at_near = sp.x;
    var at_far = sp.x + h;
    if (BACK_TO_FRONT) {
        near = si + 1u;
        far = si;
        at_near = sp.x + h;
        at_far = sp.x;
    }
    let piece = h / f32(max(REFINE, 1u));
    let sub = REFINE > 0u && full && (*s).sub > 0u && (*s).sub_at == si;
    let carried = full && !sub && (*s).carry_at == near;
    let primes = full && !sub && !carried;
    let at_sub = sp.x + (f32((*s).sub) - 0.5) * piece;
    let at = select(select(select(sp.x + 0.5 * sp.y, at_near, primes), at_far, carried), at_sub, sub);
    let here = point_at(r, at);
    let texel = volume_texel(tex_of(here));
    let v = tf_value(texel.r);
    let light = surface_intensity_with(here, texel);
    let held = (*s).carry_v;
    let held_light = (*s).carry_light;
    // A refined segment's samples leave the carried boundary as it was.
    (*s).carry_at = select(select(select(0xffffffffu, near, primes), far, carried), (*s).carry_at, sub);
    (*s).carry_v = select(v, held, sub);
    (*s).carry_light = select(light, held_light, sub);
    *again = primes;
    var vf = held;
    var vb = v;
    if (BACK_TO_FRONT) {
        vf = v;
        vb = held;
    }
    let known = !is_nan(vf) && !is_nan(vb);
    let uv = select(preint_uv(select(0.0, vf, known), select(0.0, vb, known)),
                    preint_lut_uv(select(0.0, v, !is_nan(v))), !full || sub);
    let e = preint_entry(uv);
    if (!full) {
        var m = midpoint_segment_from(texel, e, sp.y);
        m.add *= light;
        return m;
    }
    var g: Segment;
    g.x = 0.0;
    g.add = vec3<f32>(0.0);
    g.have_texel = false;
    if (sub) {
        let m = midpoint_segment_from(texel, e, piece);
        (*s).sub_add += exp(-(*s).sub_x) * m.add * light;
        (*s).sub_x += m.x;
        let last = (*s).sub == REFINE;
        (*s).sub = select((*s).sub + 1u, 0u, last);
        *again = !last;
        g.x = select(0.0, (*s).sub_x, last);
        g.add = select(vec3<f32>(0.0), (*s).sub_add, last);
        return g;
    }
    if (carried && known) {
        if (REFINE > 0u && needs_refining(r, vf, vb)) {
            (*s).sub_at = si;
            (*s).sub = 1u;
            (*s).sub_x = 0.0;
            (*s).sub_add = vec3<f32>(0.0);
            *again = true;
            return g;
        }
        g.x = e.a;
        g.add = e.rgb * (0.5 * (held_light + light));
    }
    return g;
}

// Whether a full segment from value vf to vb may reach values whose opacity
// its ramp does not see. Trilinear values change by at most P.slopes per
// voxel along each texture axis, so along the ray by at most l per unit
// length; a segment of length h starting at vf and ending at vb then stays
// within (vf + vb -/+ l h) / 2. It is refined where the transfer function's
// opacity varies by more than REFINE_EPS over that range (the ramp's own
// range included: where the values curve, the ramp puts an opacity change
// at the wrong place along the segment).
fn needs_refining(r: Ray, vf: f32, vb: f32) -> bool {
    let du = (r.d * P.tex_scale.xyz).zyx * vec3<f32>(textureDimensions(volume));
    let reach = 0.5 * dot(P.slopes.xyz, abs(du)) * P.step_size;
    let mid = 0.5 * (vf + vb);
    return opacity_variation(mid - reach, mid + reach) > REFINE_EPS;
}

// A segment from its midpoint texel.
fn midpoint_segment(texel: vec4<f32>, seg: f32) -> Segment {
    let v = tf_value(texel.r);
    return midpoint_segment_from(texel, eval_lut(select(0.0, v, !is_nan(v))), seg);
}

// A segment from its midpoint texel and the table's entry for its value.
fn midpoint_segment_from(texel: vec4<f32>, rgba: vec4<f32>, seg: f32) -> Segment {
    let valid = !is_nan(tf_value(texel.r));
    let sigma = extinction(select(0.0, rgba.a, valid));
    var g: Segment;
    g.x = select(0.0, min(sigma * (seg * P.inv_ref), 1.0e30), sigma > 0.0 && seg > 0.0);
    g.add = emitted_colour(g.x, rgba.rgb);
    g.texel = texel;
    g.have_texel = true;
    return g;
}

// Colour emitted over a segment of optical depth x with table colour c.
fn emitted_colour(x: f32, c: vec3<f32>) -> vec3<f32> {
    if (MODEL == MODEL_EMISSION) {
        return x * c;
    } else if (MODEL != MODEL_ABSORPTION) {
        return one_minus_exp_neg(x) * c;
    }
    return vec3<f32>(0.0);
}

// The march index of the first segment whose midpoint lies past `exit`
// (ray parameter from `mid`, in the march's direction), within [i + 1,
// r.end]: a thousandth of a step early, so that rounding can never skip a
// sample of the next cell.
fn segment_past(r: Ray, i: u32, si: u32, mid: f32, exit: f32) -> u32 {
    let h = P.step_size;
    if (BACK_TO_FRONT) {
        // Highest segment whose midpoint lies before the cell's near side.
        let k = ceil((mid - exit) / h - 0.5 - r.shift + 1e-3) - 1.0;
        let ki = i32(clamp(k, -1.0, f32(si) - 1.0));
        return u32(clamp(i32(r.n) - 1 - ki, i32(i) + 1, i32(r.end)));
    }
    let k = ceil((mid + exit) / h - 0.5 - r.shift - 1e-3);
    return u32(clamp(k, f32(i + 1u), f32(r.end)));
}

// Where segment i (midpoint `mid`, texture coordinate `tc`) may leap: the
// index of the first segment past the cube around its cell, or 0xffffffff.
// An empty segment looks for an empty cube; a full segment with extinction
// for a uniform one. One lookup serves both, so lanes of either kind run it
// together.
fn cube_leap(r: Ray, i: u32, si: u32, mid: f32, tc: vec3<f32>, empty: bool) -> u32 {
    var dir = r.d;
    if (BACK_TO_FRONT) {
        dir = -r.d;
    }
    let exit = cube_exit(tc, dir, !empty);
    if (exit < 0.0) {
        return 0xffffffffu;
    }
    return segment_past(r, i, si, mid, exit);
}

// Where pre-integrated segment i (span `sp`) may leap or run: from its
// near end (in the march's direction), the uniform cube around that end's
// cell, or the empty cubes the ray crosses from there (up to CHAIN of
// them, each looked up a quarter voxel past the last: a cell's range holds
// every value within half a voxel of it), and the march index of the first
// segment not inside them whole, ends and ramp between them (so a cell
// needs only its own range, however long the step). (that index, 1 for a
// uniform cube) where segment i itself lies inside, (0xffffffff, 0) where
// not. Segments are nominal, from (k + shift) to (k + shift + 1) steps past
// the entry, compared a thousandth of a step generously.
fn whole_segments(r: Ray, i: u32, sp: vec2<f32>) -> vec2<u32> {
    var dir = r.d;
    var near = sp.x;
    var sign = 1.0;
    if (BACK_TO_FRONT) {
        dir = -r.d;
        near = sp.x + sp.y;
        sign = -1.0;
    }
    let du = (dir * P.tex_scale.xyz).zyx * vec3<f32>(textureDimensions(volume));
    let nudge = 0.25 / max(abs(du.x), max(abs(du.y), abs(du.z)));
    var t = near;
    var far = near;
    var uniform = false;
    for (var c = 0u; c < CHAIN; c++) {
        let tc = tex_of(point_at(r, t));
        let code = cell_code(tc);
        let flagged = code >= UNIFORM_FLAG;
        let first = c == 0u;
        uniform = first && flagged && UNIFORM_CELLS;
        let radius = select(select(0u, code, SKIP_EMPTY && !flagged), code - UNIFORM_FLAG, uniform);
        let exit = exit_of_cube(tc, dir, radius);
        if (exit < 0.0) {
            break;
        }
        far = t + sign * exit;
        t = far + sign * nudge;
        if (uniform) {
            break;
        }
    }
    let h = P.step_size;
    // The first segment reaching past `far`, in march order.
    var k = floor(far / h - r.shift - 1e-3);
    if (BACK_TO_FRONT) {
        k = f32(r.n) - ceil(far / h - r.shift + 1e-3);
    }
    if (!(k > f32(i))) {
        return vec2<u32>(0xffffffffu, 0u);
    }
    return vec2<u32>(u32(min(k, f32(r.end))), u32(uniform));
}

// A full segment centred in a uniform cell, taken together with the
// segments after it whose midpoints lie in the cube of uniform cells around
// that cell: all have its colour and extinction, so k of them composite as
// one segment k steps long (the same sums in exact arithmetic, with one
// fetch). The run stops before the chord's last segment, which may be
// shorter, and, when the ray may stop early, at the segment where the
// march one segment at a time would stop. Returns the run's length, 1
// where the cell is not uniform.
fn uniform_run(r: Ray, i: u32, next: u32, g: ptr<function, Segment>, trans: f32) -> u32 {
    var k = f32(min(next, max(r.n, 1u) - 1u)) - f32(i);
    let x = (*g).x;
    if (EARLY_TERMINATION && !BACK_TO_FRONT) {
        // The first j with 1 - trans exp(-j x) >= threshold (inf at threshold 1).
        k = min(k, max(ceil(log(trans / (1.0 - P.threshold)) / x), 1.0));
    }
    if (!(k > 1.0)) {
        return 1u;
    }
    let kx = min(k * x, 1.0e30);
    var scale = k;
    if (MODEL != MODEL_EMISSION) {
        scale = one_minus_exp_neg(kx) / one_minus_exp_neg(x);
    }
    (*g).x = kx;
    (*g).add *= scale;
    return u32(k);
}

// The emitted colour scaled by the light reaching the segment's midpoint p
// (pre-integrated segments come lit).
fn lit(g: Segment, p: vec3<f32>, d: vec3<f32>, taken: ptr<function, u32>) -> vec3<f32> {
    if (MODEL == MODEL_ABSORPTION || PRE_INTEGRATED || !(g.x > 0.0)) {
        return g.add;
    }
    if (MODEL == MODEL_SINGLE_SCATTERING) {
        return g.add * scatter_intensity(p, d, taken);
    } else if (SHADING != SHADING_AMBIENT_ONLY && g.have_texel) {
        return g.add * surface_intensity_with(p, g.texel);
    } else if (SHADING != SHADING_AMBIENT_ONLY) {
        return g.add * surface_intensity(p);
    }
    return g.add * P.ambient;
}

// Adds a segment to the ray's sums, `taken` samples in; true once the ray may stop.
fn composite(s: ptr<function, Integration>, x: f32, add: vec3<f32>, taken: u32) -> bool {
    if (BACK_TO_FRONT) {
        // From the far end: C = c_i + exp(-x_i) C. No early stop.
        if (MODEL == MODEL_EMISSION) {
            (*s).color += add;
        } else {
            (*s).color = add + exp(-x) * (*s).color;
        }
    } else {
        (*s).color_b += (*s).trans * add;
    }
    if (MODEL == MODEL_EMISSION) {
        if ((taken >> BLOCK_SHIFT) != (*s).blocks) {
            (*s).blocks = taken >> BLOCK_SHIFT;
            (*s).color += (*s).color_b;
            (*s).color_b = vec3<f32>(0.0);
        }
        return false;
    }
    (*s).tau_b += x;
    if ((taken >> BLOCK_SHIFT) != (*s).blocks) {
        (*s).blocks = taken >> BLOCK_SHIFT;
        (*s).color += (*s).color_b;
        (*s).tau += (*s).tau_b;
        (*s).color_b = vec3<f32>(0.0);
        (*s).tau_b = 0.0;
    }
    if (!BACK_TO_FRONT) {
        (*s).trans = exp(-((*s).tau + (*s).tau_b));
        // Threshold 0 means: stop at the first sample that is not empty.
        if (EARLY_TERMINATION && (*s).tau + (*s).tau_b > 0.0 && 1.0 - (*s).trans >= P.threshold) {
            return true;
        }
        // Below this nothing behind can show in 8 bits or even float.
        if ((*s).trans < 1e-30) {
            (*s).trans = 0.0;
            return true;
        }
    }
    return false;
}

// Folds the last partial sums and writes the pixel, or the ray's state when
// a later pass continues it.
fn end_integration(r: Ray, s: ptr<function, Integration>, stopped: bool, taken: u32) {
    (*s).color += (*s).color_b;
    (*s).tau += (*s).tau_b;
    count_samples(taken);
    if (!stopped && r.end < r.n) {
        suspend(r, vec4<f32>((*s).color, (*s).tau));
        return;
    }
    if (!stopped) {
        report_truncation(r);
    }
    if (P.keep_state == 1u) {
        // A partial image: premultiplied colour and optical depth.
        finish(r, vec4<f32>((*s).color, (*s).tau));
        return;
    }
    // 1 - exp(-tau) without cancellation: a faint ray keeps its alpha (and
    // so its straight colour C / alpha) instead of rounding to 0.
    var alpha = select(one_minus_exp_neg((*s).tau), 1.0, (*s).trans == 0.0);
    if (MODEL == MODEL_EMISSION) {
        alpha = 0.0;
    }
    finish(r, vec4<f32>((*s).color, alpha));
}

// Emission–absorption, absorption, emission and single scattering: the
// optical depth is summed along the ray (tau), transmittance is exp(-tau).
fn march_integrate(r: Ray) {
    if (UNBIASED) {
        march_tracking(r);
        return;
    }
    var s = start_integration(r);
    var stopped = false;
    var taken = 0u;
    // Past the window of occupied cells the ray is done: it ends as if it
    // had marched every segment (and reports a cut short by max_steps so).
    // (Pre-integrated segments count from end to end.)
    let window = occupied_window(r, select(0.0, 0.5, PRE_INTEGRATED));
    var ray = r;
    if (max(r.begin, window.x) >= window.y) {
        ray.end = r.n;
    }
    for (var i = max(r.begin, window.x); i < ray.end; i++) {
        if (i >= window.y) {
            ray.end = r.n;
            break;
        }
        var si = i;
        if (BACK_TO_FRONT) {
            si = r.n - 1u - i;
        }
        let sp = span(r, si);
        let mid = sp.x + 0.5 * sp.y;
        let p = point_at(r, mid);
        let tc = tex_of(p);
        var g: Segment;
        taken += 1u;
        var again = false;
        var run = 0xffffffffu;
        if (PRE_INTEGRATED) {
            // Decided from the cells alone, before the volume is read.
            if (SKIP_EMPTY || UNIFORM_CELLS) {
                let cube = whole_segments(r, i, sp);
                if (cube.x != 0xffffffffu && cube.y == 0u) {
                    i = cube.x - 1u;
                    continue;
                }
                run = cube.x;
            }
            g = preintegrated_segment(r, si, sp, &s, &again);
            if (!(g.x > 0.0) || sp.y != P.step_size) {
                run = 0xffffffffu;
            }
        } else {
            g = midpoint_segment(volume_texel(tc), sp.y);
            let empty = !(g.x > 0.0);
            if ((SKIP_EMPTY && empty) || (UNIFORM_CELLS && !empty && sp.y == P.step_size)) {
                let next = cube_leap(r, i, si, mid, tc, empty);
                if (empty && next != 0xffffffffu) {
                    i = next - 1u;
                    continue;
                }
                run = next;
            }
        }
        if (again) {
            // The same segment again, now with its near value (u32
            // arithmetic wraps, so i = 0 comes back to 0).
            i -= 1u;
            continue;
        }
        if (UNIFORM_CELLS && run != 0xffffffffu) {
            i += uniform_run(r, i, run, &g, s.trans) - 1u;
        }
        let add = lit(g, p, r.d, &taken);
        if (composite(&s, g.x, add, taken)) {
            stopped = true;
            break;
        }
    }
    end_integration(ray, &s, stopped, taken);
}
