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

fn preint_lookup(vf: f32, vb: f32) -> vec4<f32> {
    let m = P.preint_side;
    let uv = (clamp(vec2<f32>(vf, vb), vec2<f32>(0.0), vec2<f32>(1.0)) * (m - 1.0) + 0.5) / m;
    return textureSampleLevel(preint, linear_sampler, uv, 0.0);
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
            if (MODEL == MODEL_EMISSION) {
                add = x * rgba.rgb;
            } else if (MODEL != MODEL_ABSORPTION) {
                add = one_minus_exp_neg(x) * rgba.rgb;
            }
        }
        if (MODEL != MODEL_ABSORPTION && x > 0.0) {
            if (MODEL == MODEL_SINGLE_SCATTERING) {
                add *= scatter_intensity(p, r.d, &taken);
            } else if (SHADING != SHADING_AMBIENT_ONLY && have_texel) {
                add *= surface_intensity_with(p, texel);
            } else if (SHADING != SHADING_AMBIENT_ONLY) {
                add *= surface_intensity(p);
            } else {
                add *= P.ambient;
            }
        }
        if (BACK_TO_FRONT) {
            // From the far end: C = c_i + exp(-x_i) C. No early stop.
            if (MODEL == MODEL_EMISSION) {
                color += add;
            } else {
                color = add + exp(-x) * color;
            }
        } else {
            color_b += trans * add;
        }
        if (MODEL == MODEL_EMISSION) {
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
    if (MODEL == MODEL_EMISSION) {
        alpha = 0.0;
    }
    finish(r, vec4<f32>(color, alpha));
}
