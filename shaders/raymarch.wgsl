// Ray marching, one invocation per pixel, for every model of src/model.rs.
// The marching rule is the one in src/integrate.rs (the f64 oracle): the chord
// through the box is cut into step-long segments (the last one shorter, and
// with jitter the first one too), each sampled at its midpoint and weighted
// by its own length.

// src/model.rs order: 0 emission_absorption, 1 absorption, 2 emission,
// 3 single_scattering, 4 mip, 5 minip, 6 average, 7 isosurface.
override MODEL: u32 = 0u;
override BACK_TO_FRONT: bool = false;
override JITTER: bool = false;
// Emission–absorption from the (front, back) table instead of the midpoint.
override PRE_INTEGRATED: bool = false;

// 0: ambient only (no normals read), 1: supplied normals, 2: on-the-fly gradient.
// Single scattering reads no normals: there 0 means no diffuse term, else lit.
override SHADING: u32 = 0u;
override POINT_LIGHT: bool = false;
override EARLY_TERMINATION: bool = true;
override POWER_CORRECTION: bool = false;
// true: the volume's format is filterable and the sampler interpolates;
// false: trilinear by hand from textureLoad (R32Float without FLOAT32_FILTERABLE).
override HW_FILTER: bool = true;
// true: each volume texel is (value, normal x, y, z) (Rgba16Float), so a lit
// sample fetches once; `normals` is then a placeholder.
override NORMALS_IN_VOLUME: bool = false;

// Skip cells of the occupancy grid that the transfer function leaves empty.
override SKIP_EMPTY: bool = true;

// Samples per partial sum: 2^BLOCK_SHIFT.
const BLOCK_SHIFT: u32 = 8u;
// Voxels per occupancy cell along each axis (src/occupancy.rs).
const CELL: f32 = 8.0;

struct Params {
    // Positions are relative to the box's min corner: the box is [0, extent].
    cam_pos: vec4<f32>,
    cam_fwd: vec4<f32>,
    cam_right: vec4<f32>,   // scaled by aspect * tan(fov / 2)
    cam_up: vec4<f32>,      // scaled by tan(fov / 2)
    extent: vec4<f32>,
    inv_extent: vec4<f32>,
    inv_two_spacing: vec4<f32>,  // 1 / (2 * voxel spacing), world axes
    light_pos: vec4<f32>,
    light_dir: vec4<f32>,   // directional: unit direction the light travels
    step_size: f32,
    inv_ref: f32,
    ambient: f32,
    diffuse: f32,
    threshold: f32,
    max_steps: u32,
    width: u32,
    height: u32,
    lut_size: u32,
    light_valid: u32,       // directional light with a defined direction
    // Long rays are marched over several dispatches of at most pass_steps
    // steps each (drivers cap loop trip counts and dispatch durations);
    // between passes each ray's state waits in `ray_state`.
    pass_start: u32,
    pass_steps: u32,
    first_pass: u32,
    last_pass: u32,
    // Mip levels of `occupancy` (passed in: textureNumLevels is not reliable
    // on every driver).
    occ_levels: u32,
    jitter_seed: u32,
    // (iso_value, Henyey–Greenstein g, shadow step, pre-integration table side)
    model_params: vec4<f32>,
    // (scale, offset, -, -): sampled value -> transfer-function domain
    // (a value range in data units; identity by default).
    value_map: vec4<f32>,
    // The box rays march in (a crop, or [0, extent]), same frame as positions.
    clip_lo: vec4<f32>,
    clip_hi: vec4<f32>,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var normals: texture_3d<f32>;
@group(0) @binding(3) var lut: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> out_rgba: array<vec4<f32>>;
// [0]: largest step count a ray needed when max_steps cut it short;
// [1], [2]: samples taken (low and high words).
@group(0) @binding(5) var<storage, read_write> stats: array<atomic<u32>, 3>;
// Filtering when HW_FILTER, non-filtering otherwise (then never sampled).
@group(0) @binding(6) var volume_sampler: sampler;
// Always filtering: normals are stored as Rgba8Snorm.
@group(0) @binding(7) var linear_sampler: sampler;
// Per pixel, between passes: (colour, tau).
@group(0) @binding(8) var<storage, read_write> ray_state: array<vec4<f32>>;
// Per pixel: 1 once the ray is finished (written by every ray in the first pass).
@group(0) @binding(9) var<storage, read_write> ray_done: array<u32>;
// 1 where a cell of CELL^3 voxels may be visible under the current transfer
// function; mip level l holds the same for cells of (CELL * 2^l)^3 voxels.
@group(0) @binding(10) var occupancy: texture_3d<u32>;
// Pre-integrated segments (src/preintegrate.rs): x = front value, y = back
// value; rgb = premultiplied colour, a = optical depth of one full step.
@group(0) @binding(11) var preint: texture_2d<f32>;

// Ray parameter at which the ray leaves the largest empty occupancy cell
// holding texture coordinate `tc`, measured from that point, or -1 if its
// finest cell is occupied. Mip level l of `occupancy` has cells of CELL * 2^l
// voxels; the last cell along an axis may extend further, so exiting at its
// nominal size is early, never late.
// The level-l cell above level-0 cell c0 (the last one absorbs remainders).
fn level_cell(c0: vec3<i32>, l: u32) -> vec3<i32> {
    return min(c0 >> vec3<u32>(l), vec3<i32>(textureDimensions(occupancy, l)) - 1);
}

fn level_empty(c0: vec3<i32>, l: u32) -> bool {
    return textureLoad(occupancy, level_cell(c0, l), l).r == 0u;
}

fn empty_cell_exit(tc: vec3<f32>, d: vec3<f32>) -> f32 {
    let dims = vec3<f32>(textureDimensions(volume));
    let u = tc * dims;
    let c0 = max(vec3<i32>(floor(u / CELL)), vec3<i32>(0));
    let levels = i32(P.occ_levels);
    // Levels unrolled: a loop here is run wrongly by lavapipe (rays skipped
    // occupied cells), while straight-line code is right on every driver.
    var size = 0.0;
    var lo = vec3<f32>(0.0);
    if (level_empty(c0, 0u)) {
        size = CELL;
        lo = vec3<f32>(level_cell(c0, 0u)) * size;
        if (levels > 1 && level_empty(c0, 1u)) {
            size = 2.0 * CELL;
            lo = vec3<f32>(level_cell(c0, 1u)) * size;
            if (levels > 2 && level_empty(c0, 2u)) {
                size = 4.0 * CELL;
                lo = vec3<f32>(level_cell(c0, 2u)) * size;
                if (levels > 3 && level_empty(c0, 3u)) {
                    size = 8.0 * CELL;
                    lo = vec3<f32>(level_cell(c0, 3u)) * size;
                }
            }
        }
    }
    if (size == 0.0) {
        return -1.0;
    }
    // Voxel units per unit of t along the ray, in texture axis order.
    let du = (d * P.inv_extent.xyz).zyx * dims;
    var exit = 3.0e38;
    for (var a = 0; a < 3; a++) {
        if (du[a] > 0.0) {
            exit = min(exit, (lo[a] + size - u[a]) / du[a]);
        } else if (du[a] < 0.0) {
            exit = min(exit, (lo[a] - u[a]) / du[a]);
        }
    }
    return max(exit, 0.0);
}

fn is_nan(v: f32) -> bool {
    // Bit test: compilers may fold `v != v` away under fast-math assumptions.
    return (bitcast<u32>(v) & 0x7fffffffu) > 0x7f800000u;
}

// Texture coordinates put numpy axis 2 (world z) on the texture's x axis.
// The value is .r; with NORMALS_IN_VOLUME the normal is .gba.
fn volume_texel(tc: vec3<f32>) -> vec4<f32> {
    if (HW_FILTER) {
        return textureSampleLevel(volume, volume_sampler, tc, 0.0);
    }
    return vec4<f32>(trilinear(tc * vec3<f32>(textureDimensions(volume)) - 0.5), 0.0, 0.0, 0.0);
}

// The sampled value as the transfer function (and the iso value) sees it.
fn tf_value(raw: f32) -> f32 {
    return raw * P.value_map.x + P.value_map.y;
}

fn value_at(tc: vec3<f32>) -> f32 {
    return tf_value(volume_texel(tc).r);
}

// Unmapped, for gradients: the map's positive scale leaves their direction alone.
fn raw_value_at(tc: vec3<f32>) -> f32 {
    return volume_texel(tc).r;
}

// Cell-centred trilinear interpolation with clamp-to-edge, done by hand so it
// works for every stored format and keeps full float weights.
fn trilinear(u: vec3<f32>) -> f32 {
    let hi = vec3<i32>(textureDimensions(volume)) - 1;
    let f = floor(u);
    let w = u - f;
    let a = clamp(vec3<i32>(f), vec3<i32>(0), hi);
    let b = clamp(vec3<i32>(f) + 1, vec3<i32>(0), hi);
    let c000 = textureLoad(volume, vec3<i32>(a.x, a.y, a.z), 0).r;
    let c100 = textureLoad(volume, vec3<i32>(b.x, a.y, a.z), 0).r;
    let c010 = textureLoad(volume, vec3<i32>(a.x, b.y, a.z), 0).r;
    let c110 = textureLoad(volume, vec3<i32>(b.x, b.y, a.z), 0).r;
    let c001 = textureLoad(volume, vec3<i32>(a.x, a.y, b.z), 0).r;
    let c101 = textureLoad(volume, vec3<i32>(b.x, a.y, b.z), 0).r;
    let c011 = textureLoad(volume, vec3<i32>(a.x, b.y, b.z), 0).r;
    let c111 = textureLoad(volume, vec3<i32>(b.x, b.y, b.z), 0).r;
    let x00 = c000 + (c100 - c000) * w.x;
    let x10 = c010 + (c110 - c010) * w.x;
    let x01 = c001 + (c101 - c001) * w.x;
    let x11 = c011 + (c111 - c011) * w.x;
    let y0 = x00 + (x10 - x00) * w.y;
    let y1 = x01 + (x11 - x01) * w.y;
    return y0 + (y1 - y0) * w.z;
}

fn supplied_normal(tc: vec3<f32>) -> vec3<f32> {
    if (NORMALS_IN_VOLUME) {
        return volume_texel(tc).gba;
    }
    return textureSampleLevel(normals, linear_sampler, tc, 0.0).xyz;
}

// Central differences one voxel apart, in world units; texture axes are (z, y, x).
fn gradient(tc: vec3<f32>) -> vec3<f32> {
    let h = 1.0 / vec3<f32>(textureDimensions(volume));
    let gx = raw_value_at(tc + vec3<f32>(0.0, 0.0, h.z)) - raw_value_at(tc - vec3<f32>(0.0, 0.0, h.z));
    let gy = raw_value_at(tc + vec3<f32>(0.0, h.y, 0.0)) - raw_value_at(tc - vec3<f32>(0.0, h.y, 0.0));
    let gz = raw_value_at(tc + vec3<f32>(h.x, 0.0, 0.0)) - raw_value_at(tc - vec3<f32>(h.x, 0.0, 0.0));
    return vec3<f32>(gx, gy, gz) * P.inv_two_spacing.xyz;
}

// Table entries sit at scalars m / (M - 1); texel centres at (m + 0.5) / M.
fn eval_lut(v: f32) -> vec4<f32> {
    let m = f32(P.lut_size);
    let x = clamp(v, 0.0, 1.0) * (m - 1.0);
    return textureSampleLevel(lut, linear_sampler, vec2<f32>((x + 0.5) / m, 0.5), 0.0);
}

fn one_minus_exp_neg(x: f32) -> f32 {
    // Series below 1e-3, where 1 - exp(-x) would cancel.
    let series = x * (1.0 - x * (0.5 - x * (1.0 / 6.0)));
    return select(1.0 - exp(-x), series, x < 1e-3);
}

// Extinction per reference step for a transfer-function opacity `a`:
// exponential form sigma = a; power form sigma = -ln(1 - a) (inf at a = 1).
fn extinction(a: f32) -> f32 {
    if (POWER_CORRECTION) {
        if (a >= 1.0) {
            // Opaque; a huge finite value, since shaders need not honour inf.
            return 1.0e30;
        }
        let series = a * (1.0 + a * (0.5 + a * (1.0 / 3.0)));
        return select(-log(1.0 - a), series, a < 1e-3);
    }
    return a;
}

// The unit direction light travels at p, and the distance back to a point
// light (3e38 for a directional one); w < 0 where the direction is undefined.
fn light_travel(p: vec3<f32>) -> vec4<f32> {
    if (POINT_LIGHT) {
        let v = p - P.light_pos.xyz;
        let dl = length(v);
        if (!(dl > 0.0)) {
            return vec4<f32>(0.0, 0.0, 0.0, -1.0);
        }
        return vec4<f32>(v / dl, dl);
    }
    if (P.light_valid == 0u) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    return vec4<f32>(P.light_dir.xyz, 3.0e38);
}

fn light_intensity(n: vec3<f32>, p: vec3<f32>) -> f32 {
    let ln = length(n);
    let l = light_travel(p);
    if (!(ln > 0.0) || l.w < 0.0) {
        return P.ambient;
    }
    return P.ambient + P.diffuse * max(dot(n / ln, l.xyz), 0.0);
}

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

fn tex_of(p: vec3<f32>) -> vec3<f32> {
    return (p * P.inv_extent.xyz).zyx;
}

// 4π p(cos θ) of Henyey–Greenstein (1 when g = 0: isotropic).
fn phase_4pi(cos_theta: f32) -> f32 {
    let g = P.model_params.y;
    if (g == 0.0) {
        return 1.0;
    }
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (denom * sqrt(denom));
}

// Light reaching p through the (cropped) volume along the shadow ray (midpoint rule,
// shadow step, stopping once its optical depth passes 16). Adds the samples
// it took to `taken`.
fn light_transmittance(p: vec3<f32>, taken: ptr<function, u32>) -> f32 {
    let travel = light_travel(p);
    if (travel.w < 0.0) {
        return 1.0;
    }
    let to_light = -travel.xyz;
    let reach = travel.w;
    var exit = 3.0e38;
    for (var a = 0; a < 3; a++) {
        if (to_light[a] > 0.0) {
            exit = min(exit, (P.clip_hi[a] - p[a]) / to_light[a]);
        } else if (to_light[a] < 0.0) {
            exit = min(exit, (P.clip_lo[a] - p[a]) / to_light[a]);
        }
    }
    let len = max(min(exit, reach), 0.0);
    let hs = P.model_params.z;
    let n = u32(ceil(len / hs));
    var tau = 0.0;
    var k = 0u;
    for (var j = 0u; j < n; j++) {
        let s0 = f32(j) * hs;
        let seg = min(hs, len - s0);
        if (seg <= 0.0) {
            break;
        }
        let v = value_at(tex_of(p + to_light * (s0 + 0.5 * seg)));
        k += 1u;
        if (is_nan(v)) {
            continue;
        }
        // No empty-space leaps here: on lavapipe they made shadow rays
        // slower (1348 vs 868 ms on fuel.vti at 256^2) though they took
        // 36% fewer samples.
        tau += extinction(eval_lut(v).a) * (seg * P.inv_ref);
        if (tau > 16.0) {
            break;
        }
    }
    *taken += k;
    return exp(-tau);
}

// Single scattering: ambient + diffuse * phase * light transmittance.
fn scatter_intensity(p: vec3<f32>, d: vec3<f32>, taken: ptr<function, u32>) -> f32 {
    let l = light_travel(p);
    if (SHADING == 0u || l.w < 0.0) {
        return P.ambient;
    }
    return P.ambient + P.diffuse * phase_4pi(dot(l.xyz, -d)) * light_transmittance(p, taken);
}

// surface_intensity where the volume's texel at p is already fetched.
fn surface_intensity_with(p: vec3<f32>, texel: vec4<f32>) -> f32 {
    if (SHADING == 1u && NORMALS_IN_VOLUME) {
        return light_intensity(texel.gba, p);
    }
    return surface_intensity(p);
}

fn surface_intensity(p: vec3<f32>) -> f32 {
    if (SHADING == 1u) {
        return light_intensity(supplied_normal(tex_of(p)), p);
    }
    if (SHADING == 2u) {
        return light_intensity(gradient(tex_of(p)), p);
    }
    return P.ambient;
}

fn preint_lookup(vf: f32, vb: f32) -> vec4<f32> {
    let m = P.model_params.w;
    let uv = (clamp(vec2<f32>(vf, vb), vec2<f32>(0.0), vec2<f32>(1.0)) * (m - 1.0) + 0.5) / m;
    return textureSampleLevel(preint, linear_sampler, uv, 0.0);
}

// Where a finished ray's pixel goes; rays that continue keep their state.
fn finish(r: Ray, rgba: vec4<f32>) {
    out_rgba[r.idx] = rgba;
    if (!(P.first_pass == 1u && P.last_pass == 1u)) {
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

// Emission–absorption, absorption, emission and single scattering: the
// optical depth is summed along the ray (tau), transmittance is exp(-tau).
fn march_integrate(r: Ray) {
    // Transmittance is exp(-tau) of the optical depth summed so far, not a
    // running product of (1 - alpha): a product loses every segment whose
    // alpha is below f32's half-ulp of 1 (6e-8), which tiny steps produce.
    // Sums are blocked: 2^BLOCK_SHIFT samples add into a small partial sum that is
    // folded into the total, so a million tiny terms keep their precision
    // (compensated sums would be undone by compilers that reassociate).
    var color = vec3<f32>(0.0);
    var tau = 0.0;
    if (P.first_pass == 0u) {
        let st = ray_state[r.idx];
        color = st.xyz;
        tau = st.w;
    }
    var color_b = vec3<f32>(0.0);
    var tau_b = 0.0;
    var trans = exp(-tau);
    var stopped = false;
    var taken = 0u;
    var blocks = 0u;
    // The value at segment boundary `carry_at` (pre-integration shares each
    // boundary between two segments).
    var carry_at = 0xffffffffu;
    var carry_v = 0.0;
    let h = P.step_size;
    for (var i = r.begin; i < r.end; i++) {
        var si = i;
        if (BACK_TO_FRONT) {
            si = r.n - 1u - i;
        }
        let sp = span(r, si);
        let lo = sp.x;
        let seg = sp.y;
        let mid = lo + 0.5 * seg;
        let p = point_at(r, mid);
        let tc = tex_of(p);
        var x = 0.0;
        var add = vec3<f32>(0.0);
        // The volume's texel at p, when this segment fetched it.
        var texel = vec4<f32>(0.0);
        var have_texel = false;
        if (PRE_INTEGRATED && seg == h) {
            var vf: f32;
            var vb: f32;
            // Branches, not select(): select evaluates (samples) both sides.
            if (BACK_TO_FRONT) {
                if (carry_at == si + 1u) {
                    vb = carry_v;
                } else {
                    vb = value_at(tex_of(point_at(r, lo + h)));
                }
                vf = value_at(tex_of(point_at(r, lo)));
                carry_at = si;
                carry_v = vf;
            } else {
                if (carry_at == si) {
                    vf = carry_v;
                } else {
                    vf = value_at(tex_of(point_at(r, lo)));
                }
                vb = value_at(tex_of(point_at(r, lo + h)));
                carry_at = si + 1u;
                carry_v = vb;
            }
            taken += 1u;
            if (!is_nan(vf) && !is_nan(vb)) {
                let e = preint_lookup(vf, vb);
                x = e.a;
                add = e.rgb;
            }
        } else {
            texel = volume_texel(tc);
            have_texel = true;
            let v = tf_value(texel.r);
            let valid = !is_nan(v);
            let rgba = eval_lut(select(0.0, v, valid));
            let sigma = extinction(select(0.0, rgba.a, valid));
            x = select(0.0, min(sigma * (seg * P.inv_ref), 1.0e30), sigma > 0.0 && seg > 0.0);
            if (SKIP_EMPTY && !(x > 0.0)) {
                // This sample is empty; if its whole cell is, jump to the first
                // sample past the cell (a thousandth of a step early, so that
                // rounding can never skip a sample of the next cell).
                var dir = r.d;
                if (BACK_TO_FRONT) {
                    dir = -r.d;
                }
                let exit = empty_cell_exit(tc, dir);
                if (exit >= 0.0) {
                    taken += 1u;
                    var next: u32;
                    if (BACK_TO_FRONT) {
                        // Highest segment whose midpoint lies before the cell's near side.
                        let k = ceil((mid - exit) / h - 0.5 - r.shift + 1e-3) - 1.0;
                        let ki = i32(clamp(k, -1.0, f32(si) - 1.0));
                        next = u32(clamp(i32(r.n) - 1 - ki, i32(i) + 1, i32(r.end)));
                    } else {
                        let k = ceil((mid + exit) / h - 0.5 - r.shift - 1e-3);
                        next = u32(clamp(k, f32(i + 1u), f32(r.end)));
                    }
                    i = next - 1u;
                    continue;
                }
            }
            taken += 1u;
            if (MODEL == 2u) {
                add = x * rgba.rgb;
            } else if (MODEL != 1u) {
                add = one_minus_exp_neg(x) * rgba.rgb;
            }
        }
        if (MODEL != 1u && x > 0.0) {
            if (MODEL == 3u) {
                add *= scatter_intensity(p, r.d, &taken);
            } else if (SHADING != 0u && have_texel) {
                add *= surface_intensity_with(p, texel);
            } else if (SHADING != 0u) {
                add *= surface_intensity(p);
            } else {
                add *= P.ambient;
            }
        }
        if (BACK_TO_FRONT) {
            // From the far end: C = c_i + exp(-x_i) C. No early stop.
            if (MODEL == 2u) {
                color += add;
            } else {
                color = add + exp(-x) * color;
            }
        } else {
            color_b += trans * add;
        }
        if (MODEL == 2u) {
            if ((taken >> BLOCK_SHIFT) != blocks) {
                blocks = taken >> BLOCK_SHIFT;
                color += color_b;
                color_b = vec3<f32>(0.0);
            }
            continue;
        }
        tau_b += x;
        if ((taken >> BLOCK_SHIFT) != blocks) {
            blocks = taken >> BLOCK_SHIFT;
            color += color_b;
            tau += tau_b;
            color_b = vec3<f32>(0.0);
            tau_b = 0.0;
        }
        if (!BACK_TO_FRONT) {
            trans = exp(-(tau + tau_b));
            // Threshold 0 means: stop at the first sample that is not empty.
            if (EARLY_TERMINATION && tau + tau_b > 0.0 && 1.0 - trans >= P.threshold) {
                stopped = true;
                break;
            }
            // Below this nothing behind can show in 8 bits or even float.
            if (trans < 1e-30) {
                trans = 0.0;
                stopped = true;
                break;
            }
        }
    }
    color += color_b;
    tau += tau_b;
    count_samples(taken);
    if (!stopped && r.end < r.n) {
        suspend(r, vec4<f32>(color, tau));
        return;
    }
    if (!stopped) {
        report_truncation(r);
    }
    // 1 - exp(-tau) without cancellation: a faint ray keeps its alpha (and
    // so its straight colour C / alpha) instead of rounding to 0.
    var alpha = select(one_minus_exp_neg(tau), 1.0, trans == 0.0);
    if (MODEL == 2u) {
        alpha = 0.0;
    }
    finish(r, vec4<f32>(color, alpha));
}

// Maximum, minimum and average intensity of the samples (NaN skipped);
// the pixel is the transfer function's premultiplied RGBA of that value.
fn march_project(r: Ray) {
    // (best or length-weighted sum, 1 if any sample or summed length, -, -)
    var st = vec4<f32>(0.0);
    if (P.first_pass == 0u) {
        st = ray_state[r.idx];
    }
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
        if (MODEL == 6u) {
            st.x += v * sp.y;
            st.y += sp.y;
        } else if (st.y == 0.0) {
            st = vec4<f32>(v, 1.0, 0.0, 0.0);
        } else if (MODEL == 4u) {
            st.x = max(st.x, v);
        } else {
            st.x = min(st.x, v);
        }
    }
    count_samples(taken);
    if (r.end < r.n) {
        suspend(r, st);
        return;
    }
    report_truncation(r);
    if (!(st.y > 0.0)) {
        finish(r, vec4<f32>(0.0));
        return;
    }
    var v = st.x;
    if (MODEL == 6u) {
        v = st.x / st.y;
    }
    let c = eval_lut(v);
    finish(r, vec4<f32>(c.rgb * c.a, c.a));
}

fn below_iso(v: f32) -> bool {
    // NaN counts as outside.
    return !(v >= P.model_params.x);
}

// First point where the value reaches iso_value: the entry, each segment's
// midpoint and the exit are tested; the crossing is then bracketed by
// bisection and placed by a secant step. The hit's ray parameter goes to
// ray_state.x (infinity on a miss) for the depth image.
fn march_iso(r: Ray) {
    let iso = P.model_params.x;
    var prev = 0.0;
    var prev_v = 0.0;
    var prev_known = true;
    var taken = 0u;
    var found = false;
    var hit = 0.0;
    if (P.first_pass == 0u) {
        let st = ray_state[r.idx];
        prev = st.x;
        prev_v = st.y;
        prev_known = st.z != 0.0;
    } else {
        prev_v = value_at(tex_of(point_at(r, 0.0)));
        taken += 1u;
        if (!below_iso(prev_v)) {
            found = true;
        }
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
        } else if (i == r.n && r.n == r.needed) {
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
            var lo = prev;
            var hi = at;
            var vlo = prev_v;
            var vhi = v;
            for (var k = 0u; k < 8u; k++) {
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
            taken += 8u;
            hit = hi;
            if (!is_nan(vlo) && vhi > vlo) {
                hit = lo + (hi - lo) * clamp((iso - vlo) / (vhi - vlo), 0.0, 1.0);
            }
            found = true;
            break;
        }
        if (SKIP_EMPTY && i <= r.end) {
            // Below iso_value here; if no value in this cell reaches it,
            // leap to the first midpoint past the cell, keeping as the
            // bracket's lower end the last midpoint inside it.
            let exit = empty_cell_exit(tex_of(point_at(r, at)), r.d);
            if (exit >= 0.0) {
                let k = ceil((at + exit) / P.step_size - 0.5 - r.shift - 1e-3);
                let next = u32(clamp(k, f32(i), f32(r.end)));
                if (next > i) {
                    let sp = span(r, next - 1u);
                    prev = sp.x + 0.5 * sp.y;
                    // Sampled only if the next sample hits (below).
                    prev_known = false;
                    i = next;
                    continue;
                }
            }
        }
        prev = at;
        prev_v = v;
        prev_known = true;
    }
    count_samples(taken);
    if (!found && r.end < r.n) {
        suspend(r, vec4<f32>(prev, prev_v, select(0.0, 1.0, prev_known), 0.0));
        return;
    }
    if (!found) {
        report_truncation(r);
        ray_state[r.idx] = vec4<f32>(bitcast<f32>(0x7f800000u), 0.0, 0.0, 0.0);
        finish(r, vec4<f32>(0.0));
        return;
    }
    let p = point_at(r, hit);
    let c = eval_lut(iso);
    ray_state[r.idx] = vec4<f32>(r.t0 + hit, 0.0, 0.0, 0.0);
    finish(r, vec4<f32>(c.rgb * surface_intensity(p), 1.0));
}

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
        if (MODEL == 7u) {
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
    if (MODEL <= 3u) {
        march_integrate(r);
    } else if (MODEL <= 6u) {
        march_project(r);
    } else {
        march_iso(r);
    }
}
