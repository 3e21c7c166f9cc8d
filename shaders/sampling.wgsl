// Reading the volume, its normals and the transfer-function table.

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
    return trilinear(tc * vec3<f32>(textureDimensions(volume)) - 0.5);
}

// The sampled value as the transfer function (and the iso value) sees it.
fn tf_value(raw: f32) -> f32 {
    return (raw * P.value_prescale) * P.value_scale + P.value_offset;
}

fn value_at(tc: vec3<f32>) -> f32 {
    return tf_value(volume_texel(tc).r);
}

// Unmapped, for gradients: the map's positive scale leaves their direction alone.
fn raw_value_at(tc: vec3<f32>) -> f32 {
    return volume_texel(tc).r;
}

// Cell-centred trilinear interpolation with clamp-to-edge, done by hand so it
// works for every stored format and keeps full float weights. Whole texels:
// with NORMALS_IN_VOLUME they hold the normal too (unused lanes are dead code).
fn trilinear(u: vec3<f32>) -> vec4<f32> {
    let hi = vec3<i32>(textureDimensions(volume)) - 1;
    let f = floor(u);
    let w = u - f;
    let a = clamp(vec3<i32>(f), vec3<i32>(0), hi);
    let b = clamp(vec3<i32>(f) + 1, vec3<i32>(0), hi);
    let c000 = textureLoad(volume, vec3<i32>(a.x, a.y, a.z), 0);
    let c100 = textureLoad(volume, vec3<i32>(b.x, a.y, a.z), 0);
    let c010 = textureLoad(volume, vec3<i32>(a.x, b.y, a.z), 0);
    let c110 = textureLoad(volume, vec3<i32>(b.x, b.y, a.z), 0);
    let c001 = textureLoad(volume, vec3<i32>(a.x, a.y, b.z), 0);
    let c101 = textureLoad(volume, vec3<i32>(b.x, a.y, b.z), 0);
    let c011 = textureLoad(volume, vec3<i32>(a.x, b.y, b.z), 0);
    let c111 = textureLoad(volume, vec3<i32>(b.x, b.y, b.z), 0);
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

// The direction of central differences one voxel apart, per world unit;
// texture axes are (z, y, x). Zero (no diffuse light) where a neighbour is
// NaN, as in the f64 integrator. Only the direction is used, so the
// differences are first scaled into [-1, 1]: values near f32's range (fill
// values such as 1e20 or 9.97e36, infinities stored as f32::MAX / 16) would
// otherwise overflow the spacing factor or the length.
fn gradient(tc: vec3<f32>) -> vec3<f32> {
    let h = 1.0 / vec3<f32>(textureDimensions(volume));
    let gx = raw_value_at(tc + vec3<f32>(0.0, 0.0, h.z)) - raw_value_at(tc - vec3<f32>(0.0, 0.0, h.z));
    let gy = raw_value_at(tc + vec3<f32>(0.0, h.y, 0.0)) - raw_value_at(tc - vec3<f32>(0.0, h.y, 0.0));
    let gz = raw_value_at(tc + vec3<f32>(h.x, 0.0, 0.0)) - raw_value_at(tc - vec3<f32>(h.x, 0.0, 0.0));
    if (is_nan(gx) || is_nan(gy) || is_nan(gz)) {
        return vec3<f32>(0.0);
    }
    let m = max(max(abs(gx), abs(gy)), abs(gz));
    if (!(m > 0.0)) {
        return vec3<f32>(0.0);
    }
    return over_largest(vec3<f32>(gx, gy, gz), m) * P.inv_two_spacing.xyz;
}

// v / m, where m > 0 is v's largest |component|. GPUs may divide through a
// reciprocal, which flushes to 0 for m above 2^126 (gradients of values
// near f32's range): such m are scaled by 2^-64 first.
fn over_largest(v: vec3<f32>, m: f32) -> vec3<f32> {
    let s = select(1.0, 5.421010862e-20, m > 1.0e30);
    return (v * s) / (m * s);
}

// v's unit direction and its length (w), or w < 0 for a zero vector; scaled
// first so that lengths beyond sqrt(f32::MAX) do not overflow.
fn direction_and_length(v: vec3<f32>) -> vec4<f32> {
    let m = max(max(abs(v.x), abs(v.y)), abs(v.z));
    if (!(m > 0.0)) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let u = over_largest(v, m);
    let l = length(u);
    return vec4<f32>(u / l, m * l);
}

// Table entries sit at scalars m / (M - 1); texel centres at (m + 0.5) / M.
fn eval_lut(v: f32) -> vec4<f32> {
    let m = f32(P.lut_size);
    let x = clamp(v, 0.0, 1.0) * (m - 1.0);
    if (EXACT_TABLES) {
        let i = min(u32(x), P.lut_size - 1u);
        let a = textureLoad(lut, vec2<u32>(i, 0u), 0);
        let b = textureLoad(lut, vec2<u32>(min(i + 1u, P.lut_size - 1u), 0u), 0);
        return a + (b - a) * (x - f32(i));
    }
    return textureSampleLevel(lut, linear_sampler, vec2<f32>((x + 0.5) / m, 0.5), 0.0);
}
