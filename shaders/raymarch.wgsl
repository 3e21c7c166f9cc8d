// Emission–absorption ray marching, one invocation per pixel.
// The marching rule is the one in src/integrate.rs (the f64 oracle): the chord
// through the box is cut into step-long segments (the last one shorter), each
// sampled at its midpoint and weighted by its own length.

// 0: ambient only (no normals read), 1: supplied normals, 2: on-the-fly gradient.
override SHADING: u32 = 0u;
override POINT_LIGHT: bool = false;
override EARLY_TERMINATION: bool = true;
override POWER_CORRECTION: bool = false;
// true: the volume's format is filterable and the sampler interpolates;
// false: trilinear by hand from textureLoad (R32Float without FLOAT32_FILTERABLE).
override HW_FILTER: bool = true;

// Skip cells of the occupancy grid that the transfer function leaves empty.
override SKIP_EMPTY: bool = true;

// Samples per partial sum (a power of two).
const BLOCK: u32 = 256u;
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
    _pad1: u32,
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
// Always filtering: normals are stored as Rgba16Float.
@group(0) @binding(7) var linear_sampler: sampler;
// Per pixel, between passes: (colour, tau).
@group(0) @binding(8) var<storage, read_write> ray_state: array<vec4<f32>>;
// Per pixel: 1 once the ray is finished (written by every ray in the first pass).
@group(0) @binding(9) var<storage, read_write> ray_done: array<u32>;
// 1 where a cell of CELL^3 voxels may be visible under the current transfer
// function; mip level l holds the same for cells of (CELL * 2^l)^3 voxels.
@group(0) @binding(10) var occupancy: texture_3d<u32>;

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
fn value_at(tc: vec3<f32>) -> f32 {
    if (HW_FILTER) {
        return textureSampleLevel(volume, volume_sampler, tc, 0.0).r;
    }
    return trilinear(tc * vec3<f32>(textureDimensions(volume)) - 0.5);
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
    return textureSampleLevel(normals, linear_sampler, tc, 0.0).xyz;
}

// Central differences one voxel apart, in world units; texture axes are (z, y, x).
fn gradient(tc: vec3<f32>) -> vec3<f32> {
    let h = 1.0 / vec3<f32>(textureDimensions(volume));
    let gx = value_at(tc + vec3<f32>(0.0, 0.0, h.z)) - value_at(tc - vec3<f32>(0.0, 0.0, h.z));
    let gy = value_at(tc + vec3<f32>(0.0, h.y, 0.0)) - value_at(tc - vec3<f32>(0.0, h.y, 0.0));
    let gz = value_at(tc + vec3<f32>(h.x, 0.0, 0.0)) - value_at(tc - vec3<f32>(h.x, 0.0, 0.0));
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

fn light_intensity(n: vec3<f32>, p: vec3<f32>) -> f32 {
    let ln = length(n);
    if (!(ln > 0.0)) {
        return P.ambient;
    }
    var l: vec3<f32>;
    if (POINT_LIGHT) {
        let d = p - P.light_pos.xyz;
        let dl = length(d);
        if (!(dl > 0.0)) {
            return P.ambient;
        }
        l = d / dl;
    } else {
        if (P.light_valid == 0u) {
            return P.ambient;
        }
        l = P.light_dir.xyz;
    }
    return P.ambient + P.diffuse * max(dot(n / ln, l), 0.0);
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

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.width || gid.y >= P.height) {
        return;
    }
    // Row 0 is the bottom of the image, as pyvr returns it.
    let idx = gid.y * P.width + gid.x;
    let ndc = vec2<f32>(
        2.0 * (f32(gid.x) + 0.5) / f32(P.width) - 1.0,
        2.0 * (f32(gid.y) + 0.5) / f32(P.height) - 1.0,
    );
    let o = P.cam_pos.xyz;
    let d = normalize(P.cam_fwd.xyz + ndc.x * P.cam_right.xyz + ndc.y * P.cam_up.xyz);
    let ext = P.extent.xyz;

    // Slab test; a zero direction component never divides.
    var t0 = -3.0e38;
    var t1 = 3.0e38;
    var hit = true;
    for (var a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < 0.0 || o[a] > ext[a]) {
                hit = false;
            }
        } else {
            let inv = 1.0 / d[a];
            let ta = (0.0 - o[a]) * inv;
            let tb = (ext[a] - o[a]) * inv;
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    let single_pass = P.first_pass == 1u && P.last_pass == 1u;
    if (P.first_pass == 0u && ray_done[idx] != 0u) {
        return;
    }
    if (!hit || t0 > t1 || t1 <= 0.0) {
        out_rgba[idx] = vec4<f32>(0.0);
        if (!single_pass) {
            ray_done[idx] = 1u;
        }
        return;
    }
    t0 = max(t0, 0.0);
    let chord = t1 - t0;
    let needed_f = ceil(chord / P.step_size);
    let needed = u32(min(needed_f, 4.0e9));
    let n = min(needed, P.max_steps);

    // Transmittance is exp(-tau) of the optical depth summed so far, not a
    // running product of (1 - alpha): a product loses every segment whose
    // alpha is below f32's half-ulp of 1 (6e-8), which tiny steps produce.
    // Sums are blocked: BLOCK samples add into a small partial sum that is
    // folded into the total, so a million tiny terms keep their precision
    // (compensated sums would be undone by compilers that reassociate).
    var color = vec3<f32>(0.0);
    var tau = 0.0;
    if (P.first_pass == 0u) {
        let st = ray_state[idx];
        color = st.xyz;
        tau = st.w;
    }
    var color_b = vec3<f32>(0.0);
    var tau_b = 0.0;
    var trans = exp(-tau);
    var stopped = false;
    var end = n;
    if (P.last_pass == 0u) {
        end = min(n, P.pass_start + P.pass_steps);
    }
    var taken = 0u;
    for (var i = P.pass_start; i < end; i++) {
        let s0 = t0 + f32(i) * P.step_size;
        let seg = max(min(P.step_size, t1 - s0), 0.0);
        let p = o + d * (s0 + 0.5 * seg);
        let tc = (p * P.inv_extent.xyz).zyx;
        let v = value_at(tc);
        let valid = !is_nan(v);
        let rgba = eval_lut(select(0.0, v, valid));
        let sigma = extinction(select(0.0, rgba.a, valid));
        let x = select(0.0, min(sigma * (seg * P.inv_ref), 1.0e30), sigma > 0.0 && seg > 0.0);
        let alpha = one_minus_exp_neg(x);
        if (SKIP_EMPTY && !(alpha > 0.0)) {
            // This sample is empty; if its whole cell is, jump to the first
            // sample past the cell (a thousandth of a step early, so that
            // rounding can never skip a sample of the next cell).
            let exit = empty_cell_exit(tc, d);
            if (exit >= 0.0) {
                let t_exit = s0 + 0.5 * seg + exit;
                let first_outside = ceil((t_exit - t0) / P.step_size - 0.5 - 1e-3);
                let next = u32(clamp(first_outside, f32(i + 1u), f32(end)));
                taken += 1u;
                i = next - 1u;
                continue;
            }
        }
        taken += 1u;
        var intensity = P.ambient;
        if (SHADING != 0u && alpha > 0.0) {
            if (SHADING == 1u) {
                intensity = light_intensity(supplied_normal(tc), p);
            } else {
                intensity = light_intensity(gradient(tc), p);
            }
        }
        color_b += (trans * alpha * intensity) * rgba.rgb;
        tau_b += x;
        if ((taken & (BLOCK - 1u)) == 0u) {
            color += color_b;
            tau += tau_b;
            color_b = vec3<f32>(0.0);
            tau_b = 0.0;
        }
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
    color += color_b;
    count_samples(taken);
    if (!stopped && end < n) {
        // Continues in the next pass.
        ray_state[idx] = vec4<f32>(color, tau + tau_b);
        if (P.first_pass == 1u) {
            ray_done[idx] = 0u;
        }
        return;
    }
    if (!single_pass) {
        ray_done[idx] = 1u;
    }
    if (!stopped && n < needed) {
        atomicMax(&stats[0], needed);
    }
    out_rgba[idx] = vec4<f32>(color, 1.0 - trans);
}
