// Light at a sample: surface shading (ambient + diffuse with normals or
// gradients) and single scattering (phase function and shadow rays).

// The unit direction light travels at p, and the distance back to a point
// light (3e38 for a directional one); w < 0 where the direction is undefined.
fn light_travel(p: vec3<f32>) -> vec4<f32> {
    if (POINT_LIGHT) {
        return direction_and_length(p - P.light_pos.xyz);
    }
    if (P.light_valid == 0u) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    return vec4<f32>(P.light_dir.xyz, 3.0e38);
}

// `n` is a decoded unit normal, a gradient already scaled into a safe
// range (sampling.wgsl), or an interpolated gradient texel, whose
// components may reach 1e38: it is scaled by its largest component before
// its length is taken, which would otherwise overflow.
fn light_intensity(n: vec3<f32>, p: vec3<f32>) -> f32 {
    let m = max(max(abs(n.x), abs(n.y)), abs(n.z));
    let l = light_travel(p);
    if (!(m > 0.0) || l.w < 0.0) {
        return P.ambient;
    }
    let u = over_largest(n, m);
    return P.ambient + P.diffuse * max(dot(u / length(u), l.xyz), 0.0);
}

// 4π p(cos θ) of Henyey–Greenstein (1 when g = 0: isotropic).
fn phase_4pi(cos_theta: f32) -> f32 {
    let g = P.anisotropy;
    if (g == 0.0) {
        return 1.0;
    }
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (denom * sqrt(denom));
}

// Light reaching p through the (cropped, clipped) volume along the shadow ray (midpoint rule,
// shadow step, stopping once its optical depth passes SHADOW_TAU_MAX). Adds the samples
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
    // p is on every plane's kept side: the ray leaves a plane's where n
    // points away from the light.
    for (var k = 0u; k < P.clip_count; k++) {
        let q = P.clip_planes[k];
        let slope = dot(q.xyz, to_light);
        if (slope < 0.0) {
            exit = min(exit, -(dot(q.xyz, p) + q.w) / slope);
        }
    }
    let len = max(min(exit, reach), 0.0);
    let hs = P.shadow_step;
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
        // No empty-space leaps here: they take fewer samples but make a
        // shadow ray's loop heavier, and cost more than they save.
        tau += extinction(eval_lut(v).a) * (seg * P.inv_ref);
        if (tau > SHADOW_TAU_MAX) {
            break;
        }
    }
    *taken += k;
    return exp(-tau);
}

// Single scattering: ambient + diffuse * phase * light transmittance.
fn scatter_intensity(p: vec3<f32>, d: vec3<f32>, taken: ptr<function, u32>) -> f32 {
    let l = light_travel(p);
    if (SHADING == SHADING_AMBIENT_ONLY || l.w < 0.0) {
        return P.ambient;
    }
    return P.ambient + P.diffuse * phase_4pi(dot(l.xyz, -d)) * light_transmittance(p, taken);
}

// surface_intensity where the volume's texel at p is already fetched.
fn surface_intensity_with(p: vec3<f32>, texel: vec4<f32>) -> f32 {
    if (SHADING == SHADING_NORMALS && NORMALS_IN_VOLUME) {
        return light_intensity(texel.gba, p);
    }
    return surface_intensity(p);
}

fn surface_intensity(p: vec3<f32>) -> f32 {
    if (SHADING == SHADING_NORMALS) {
        return light_intensity(supplied_normal(tex_of(p)), p);
    }
    if (SHADING == SHADING_GRADIENT) {
        return light_intensity(gradient(tex_of(p)), p);
    }
    return P.ambient;
}
