"""Independent reference renderer: the same semantics in GLSL, run through
moderngl on a headless EGL context (Mesa llvmpipe), read back as floats.

It shares no code with the engine: the camera basis is computed here with
numpy, interpolation uses OpenGL's own trilinear filtering, and the lookup
table is a GL texture. Semantics (README, "Rendering model"): the ray's
chord through the box is cut into step-long segments, the last one shorter,
each sampled at its midpoint; a = 1 - exp(-a_tf * len / ref) (or the power
form); C += T * a * I * rgb; T *= 1 - a; stop when 1 - T >= threshold.
The other models (README, "Optical models") follow their definitions
directly: absorption and emission as the same loop without colour or
without attenuation, single scattering with a shadow ray per sample,
projections over the midpoint samples, and the isosurface by bisection.

Output: float32 (H, W, 4) premultiplied RGBA, row 0 at the bottom.
"""

import numpy as np

VERTEX = """
#version 330
in vec2 pos;
void main() { gl_Position = vec4(pos, 0.0, 1.0); }
"""

FRAGMENT = """
#version 330
uniform sampler3D vol;
uniform sampler3D nrm;
uniform sampler2D lut;
uniform vec3 eye;        // relative to box min
uniform vec3 fwd;
uniform vec3 right;      // scaled by aspect * tan(fov/2)
uniform vec3 upv;        // scaled by tan(fov/2)
uniform vec3 ext;
uniform vec3 dims;       // numpy shape (s0, s1, s2)
uniform vec2 viewport;
uniform float step_size;
uniform float ref_step;
uniform int max_steps;
uniform int early;
uniform float threshold;
uniform int power_form;
uniform int shading;     // 0 ambient, 1 normals, 2 gradient
uniform int point_light;
uniform vec3 light_pos;  // relative to box min
uniform vec3 light_dir;
uniform float ambient;
uniform float diffuse;
uniform float lut_size;
uniform int model;       // pyvr's model order: 0 EA, 1 abs, 2 em, 3 scatter, 4 mip, 5 minip, 6 avg, 7 iso
uniform float iso_value;
uniform float hg_g;
uniform float shadow_step;
out vec4 frag;

// numpy axis 0 is world x; the texture's s axis is numpy axis 2.
vec3 tex_of(vec3 q) { return q.zyx; }

float value(vec3 q) { return texture(vol, tex_of(q)).r; }

vec4 tf(float v) {
    float x = clamp(v, 0.0, 1.0) * (lut_size - 1.0);
    return texture(lut, vec2((x + 0.5) / lut_size, 0.5));
}

float seg_alpha(float a, float r) {
    if (a <= 0.0) return 0.0;
    float sigma = a;
    if (power_form == 1) {
        if (a >= 1.0) return 1.0;
        sigma = -log(1.0 - a);
    }
    float x = sigma * r;
    return x < 1e-4 ? x - 0.5 * x * x : 1.0 - exp(-x);
}

float lighting(vec3 q, vec3 p) {
    if (shading == 0) return ambient;
    vec3 n;
    if (shading == 1) {
        n = texture(nrm, tex_of(q)).xyz;
    } else {
        vec3 h = 1.0 / dims;
        vec3 sp = ext / dims;
        n = vec3(
            (value(q + vec3(h.x, 0, 0)) - value(q - vec3(h.x, 0, 0))) / (2.0 * sp.x),
            (value(q + vec3(0, h.y, 0)) - value(q - vec3(0, h.y, 0))) / (2.0 * sp.y),
            (value(q + vec3(0, 0, h.z)) - value(q - vec3(0, 0, h.z))) / (2.0 * sp.z));
    }
    float ln = length(n);
    if (!(ln > 0.0)) return ambient;
    vec3 L = light_dir;
    if (point_light == 1) {
        vec3 d = p - light_pos;
        if (!(length(d) > 0.0)) return ambient;
        L = normalize(d);
    } else if (!(length(L) > 0.0)) {
        return ambient;
    }
    return ambient + diffuse * max(dot(n / ln, L), 0.0);
}

float sigma_of(float v) {
    float a = tf(v).a;
    if (a <= 0.0) return 0.0;
    if (power_form == 1) return a >= 1.0 ? 1e30 : -log(1.0 - a);
    return a;
}

// Light left after the shadow ray from p to the light (or the box's side).
float shadow(vec3 p) {
    vec3 L;
    float reach = 1e30;
    if (point_light == 1) {
        vec3 v = light_pos - p;
        reach = length(v);
        if (!(reach > 0.0)) return 1.0;
        L = v / reach;
    } else {
        L = -light_dir;
    }
    float exit_t = 1e30;
    for (int a = 0; a < 3; a++) {
        if (L[a] > 0.0) exit_t = min(exit_t, (ext[a] - p[a]) / L[a]);
        if (L[a] < 0.0) exit_t = min(exit_t, -p[a] / L[a]);
    }
    float len = min(exit_t, reach);
    float tau = 0.0;
    for (float s = 0.0; s < len; s += shadow_step) {
        float seg = min(shadow_step, len - s);
        float v = value((p + L * (s + 0.5 * seg)) / ext);
        if (isnan(v)) continue;
        tau += sigma_of(v) * seg / ref_step;
        if (tau > 16.0) break;
    }
    return exp(-tau);
}

float scatter_light(vec3 p, vec3 d) {
    if (diffuse == 0.0) return ambient;
    vec3 l = light_dir;
    if (point_light == 1) {
        vec3 v = p - light_pos;
        if (!(length(v) > 0.0)) return ambient;
        l = normalize(v);
    } else if (!(length(l) > 0.0)) {
        return ambient;
    }
    float ph = 1.0;
    if (hg_g != 0.0) {
        float c = dot(l, -d);
        float den = 1.0 + hg_g * hg_g - 2.0 * hg_g * c;
        ph = (1.0 - hg_g * hg_g) / (den * sqrt(den));
    }
    return ambient + diffuse * ph * shadow(p);
}

void main() {
    vec2 ndc = 2.0 * gl_FragCoord.xy / viewport - 1.0;
    vec3 d = normalize(fwd + ndc.x * right + ndc.y * upv);
    float t0 = -1e30, t1 = 1e30;
    for (int a = 0; a < 3; a++) {
        if (abs(d[a]) < 1e-30) {
            if (eye[a] < 0.0 || eye[a] > ext[a]) { frag = vec4(0.0); return; }
        } else {
            float ta = -eye[a] / d[a];
            float tb = (ext[a] - eye[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    if (t0 > t1 || t1 <= 0.0) { frag = vec4(0.0); return; }
    t0 = max(t0, 0.0);
    int needed = int(ceil((t1 - t0) / step_size));
    int n = min(needed, max_steps);
    if (model >= 4 && model <= 6) {
        float best = 0.0, sum = 0.0, len_sum = 0.0;
        bool any = false;
        for (int i = 0; i < n; i++) {
            float s = t0 + float(i) * step_size;
            float len = min(step_size, t1 - s);
            if (len <= 0.0) break;
            float v = value((eye + d * (s + 0.5 * len)) / ext);
            if (isnan(v)) continue;
            if (model == 6) { sum += v * len; len_sum += len; any = true; }
            else if (!any) { best = v; any = true; }
            else if (model == 4) best = max(best, v);
            else best = min(best, v);
        }
        if (!any) { frag = vec4(0.0); return; }
        if (model == 6) best = sum / len_sum;
        vec4 c = tf(best);
        frag = vec4(c.rgb * c.a, c.a);
        return;
    }
    if (model == 7) {
        // Sample points: entry, midpoints, exit; bisection between the
        // last point below iso_value and the first at or above it.
        float prev = t0;
        float hit = -1.0;
        if (value((eye + d * t0) / ext) >= iso_value) hit = t0;
        for (int i = 0; i <= n && hit < 0.0; i++) {
            float at;
            if (i < n) {
                float s = t0 + float(i) * step_size;
                at = s + 0.5 * min(step_size, t1 - s);
            } else if (n == needed) {
                at = t1;
            } else {
                break;
            }
            if (value((eye + d * at) / ext) >= iso_value) {
                float lo = prev, hi = at;
                for (int k = 0; k < 40; k++) {
                    float m = 0.5 * (lo + hi);
                    if (value((eye + d * m) / ext) >= iso_value) hi = m; else lo = m;
                }
                hit = 0.5 * (lo + hi);
            }
            prev = at;
        }
        if (hit < 0.0) { frag = vec4(0.0); return; }
        vec3 p = eye + d * hit;
        frag = vec4(tf(iso_value).rgb * lighting(p / ext, p), 1.0);
        return;
    }
    vec3 C = vec3(0.0);
    float T = 1.0;
    for (int i = 0; i < n; i++) {
        float s = t0 + float(i) * step_size;
        float len = min(step_size, t1 - s);
        if (len <= 0.0) break;
        vec3 p = eye + d * (s + 0.5 * len);
        vec3 q = p / ext;
        float v = value(q);
        if (isnan(v)) continue;
        vec4 c = tf(v);
        float a = seg_alpha(c.a, len / ref_step);
        if (a <= 0.0) continue;
        if (model == 2) {
            // Emission only: sigma * len / ref of colour, nothing absorbed.
            C += sigma_of(v) * (len / ref_step) * lighting(q, p) * c.rgb;
            continue;
        }
        if (model == 0) C += T * a * lighting(q, p) * c.rgb;
        if (model == 3) C += T * a * scatter_light(p, d) * c.rgb;
        T *= 1.0 - a;
        if (early == 1 && 1.0 - T >= threshold) break;
        if (T < 1e-30) { T = 0.0; break; }
    }
    frag = vec4(C, model == 2 ? 0.0 : 1.0 - T);
}
"""

_CTX = None


def _context():
    global _CTX
    if _CTX is None:
        import moderngl

        _CTX = moderngl.create_context(standalone=True, backend="egl")
    return _CTX


def _basis(camera, width, height):
    p, up = camera.get_camera_vectors()
    p = np.asarray(p, np.float64)
    f = np.asarray(camera.target, np.float64) - p
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    t = np.tan(camera.fov / 2.0)
    return p, f, r * (width / height) * t, u * t


class ReferenceRenderer:
    """Uploads a volume and transfer function once; renders frames on demand
    (so benchmarks can time frames apart from uploads)."""

    def __init__(self, volume, ctf, otf, width, height, lut_size=None):
        import moderngl

        ctx = self.ctx = _context()
        self.width, self.height = width, height
        self.volume = volume
        self.prog = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        data = np.asarray(volume.data)
        if data.dtype == np.uint8:
            vals = data.astype(np.float32) / 255.0
        elif data.dtype == np.uint16:
            vals = data.astype(np.float32) / 65535.0
        else:
            vals = data.astype(np.float32)
        vals = np.where(np.isinf(vals), np.sign(vals) * np.float32(1e30), vals).astype(np.float32)
        s0, s1, s2 = self.dims = vals.shape
        self.vol = ctx.texture3d((s2, s1, s0), 1, np.ascontiguousarray(vals).tobytes(), dtype="f4")
        if volume.normals is not None:
            nr = np.ascontiguousarray(volume.normals, dtype=np.float32)
            self.nrm = ctx.texture3d((s2, s1, s0), 3, nr.tobytes(), dtype="f4")
        else:
            self.nrm = ctx.texture3d((1, 1, 1), 3, np.zeros(3, np.float32).tobytes(), dtype="f4")
        m = self.lut_size = lut_size or max(ctf.lut_size, otf.lut_size)
        table = np.zeros((m, 4), np.float32)
        table[:, :3] = ctf.to_lut(m)
        table[:, 3] = otf.to_lut(m)
        self.lut = ctx.texture((m, 1), 4, table.tobytes(), dtype="f4")
        for tex in (self.vol, self.nrm, self.lut):
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = False
        for tex in (self.vol, self.nrm):
            tex.repeat_z = False
        self.quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], np.float32).tobytes())
        self.vao = ctx.vertex_array(self.prog, [(self.quad, "2f", "pos")])
        self.color = ctx.texture((width, height), 4, dtype="f4")
        self.fbo = ctx.framebuffer([self.color])

    def render(self, camera, light, config):
        import moderngl

        ctx, volume = self.ctx, self.volume
        width, height = self.width, self.height
        s0, s1, s2 = self.dims
        self.vol.use(0)
        self.nrm.use(1)
        self.lut.use(2)
        bmin = np.asarray(volume.min_bounds, np.float64)
        ext = np.asarray(volume.max_bounds, np.float64) - bmin
        eye, f, r, u = _basis(camera, width, height)
        diffuse = float(light.diffuse_intensity)
        shading = 0 if diffuse == 0 else (1 if volume.normals is not None else 2)
        model = getattr(config, "model", "emission_absorption")
        models = ["emission_absorption", "absorption", "emission", "single_scattering", "mip", "minip", "average",
                  "isosurface"]
        ldir = np.asarray(light.target, np.float64) - np.asarray(light.position, np.float64)
        ln = np.linalg.norm(ldir)
        ldir = ldir / ln if ln > 0 else np.zeros(3)
        uniforms = {
            "vol": 0, "nrm": 1, "lut": 2,
            "eye": tuple(eye - bmin), "fwd": tuple(f), "right": tuple(r), "upv": tuple(u),
            "ext": tuple(ext), "dims": (float(s0), float(s1), float(s2)),
            "viewport": (float(width), float(height)),
            "step_size": float(config.step_size), "ref_step": float(config.reference_step_size),
            "max_steps": int(config.max_steps), "early": int(bool(config.early_ray_termination)),
            "threshold": float(config.opacity_threshold),
            "power_form": int(getattr(config, "opacity_correction", "exponential") == "power"),
            "shading": shading, "point_light": int(getattr(light, "kind", "directional") == "point"),
            "light_pos": tuple(np.asarray(light.position, np.float64) - bmin), "light_dir": tuple(ldir),
            "ambient": float(light.ambient_intensity), "diffuse": diffuse, "lut_size": float(self.lut_size),
            "model": models.index(model), "iso_value": float(getattr(config, "iso_value", 0.5)),
            "hg_g": float(getattr(config, "anisotropy", 0.0)),
            "shadow_step": float(getattr(config, "shadow_step_size", 0.0) or config.step_size),
        }
        for k, v in uniforms.items():
            if k in self.prog:
                self.prog[k].value = v
        self.fbo.use()
        ctx.disable(moderngl.BLEND)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        self.vao.render(moderngl.TRIANGLE_STRIP)
        raw = self.fbo.read(components=4, dtype="f4")
        return np.frombuffer(raw, np.float32).reshape(height, width, 4).copy()

    def release(self):
        for obj in (self.vao, self.quad, self.fbo, self.color, self.vol, self.nrm, self.lut, self.prog):
            obj.release()


def render_reference(volume, ctf, otf, camera, light, config, width, height, lut_size=None):
    ref = ReferenceRenderer(volume, ctf, otf, width, height, lut_size)
    try:
        return ref.render(camera, light, config)
    finally:
        ref.release()
