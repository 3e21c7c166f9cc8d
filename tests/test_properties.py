"""Invariants of the renderer, property-tested with hypothesis on the GPU
path (and the f64 integrator where an order or closed form is involved).

Tolerance 1.5/255 on premultiplied RGBA unless said: the GPU computes in f32
and the transformed scenes differ in rounding, not in their maths."""

import warnings

import numpy as np
import pytest
from scenes import frame, make_renderer
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

TOL = 1.5 / 255
W, H = 12, 10
SETTINGS = dict(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])

f32 = lambda *v: np.array(v, dtype=np.float32)  # noqa: E731


@st.composite
def volumes(draw, lo=1, hi=6, special=False):
    shape = tuple(draw(st.integers(lo, hi)) for _ in range(3))
    seed = draw(st.integers(0, 2**31 - 1))
    data = np.random.default_rng(seed).random(shape, dtype=np.float32)
    if special:
        flat = data.reshape(-1)
        picks = draw(st.lists(st.sampled_from([np.nan, np.inf, -np.inf, 1e30, -1e30, 1e-40, 5.0, -2.0]),
                              max_size=4))
        for n, v in enumerate(picks):
            flat[(n * 7919) % flat.size] = v
    return data


@st.composite
def tfs(draw):
    k = draw(st.integers(2, 5))
    xs = sorted({0.0, 1.0, *draw(st.lists(st.floats(0, 1), min_size=k - 2, max_size=k - 2))})
    alphas = [draw(st.floats(0, 1)) for _ in xs]
    colors = [tuple(draw(st.floats(0, 1)) for _ in range(3)) for _ in xs]
    return ColorTransferFunction(list(zip(xs, colors))), OpacityTransferFunction(list(zip(xs, alphas)))


@st.composite
def cameras(draw, distance=(0.2, 5.0)):
    return Camera(azimuth=draw(st.floats(-np.pi, np.pi)), elevation=draw(st.floats(-1.5, 1.5)),
                  roll=draw(st.floats(-np.pi, np.pi)), distance=draw(st.floats(*distance)),
                  fov=draw(st.floats(0.05, 2.5)))


def render(vol, ctf, otf, cam, light, cfg, **kw):
    r = make_renderer(vol, size=(W, H), config=cfg, light=light, camera=cam, ctf=ctf, otf=otf)
    return r, frame(r, **kw)


@settings(**SETTINGS)
@given(data=volumes(special=True), tf=tfs(), cam=cameras(), step=st.floats(1e-3, 1.0),
       threshold=st.floats(0, 1), early=st.booleans(), ambient=st.floats(0, 1), diffuse=st.floats(0, 1))
def test_output_is_finite_and_in_range(data, tf, cam, step, threshold, early, ambient, diffuse):
    cfg = RenderConfig(step_size=step, max_steps=4000, early_ray_termination=early, opacity_threshold=threshold)
    _, img = render(Volume(data), *tf, cam, Light(ambient_intensity=ambient, diffuse_intensity=diffuse), cfg)
    assert np.isfinite(img).all()
    assert img.min() >= 0 and img[..., 3].max() <= 1
    assert np.all(img[..., :3] <= 2 * img[..., 3:4] + 1e-6)  # colour <= (ambient + diffuse) * alpha


@settings(**SETTINGS)
@given(data=volumes(2, 6), tf=tfs(), cam=cameras(distance=(1.0, 4.0)), step=st.floats(0.005, 0.1),
       lit=st.booleans())
def test_front_to_back_equals_back_to_front(data, tf, cam, step, lit):
    cfg = RenderConfig(step_size=step, max_steps=1000, early_ray_termination=False)
    light = Light.default() if lit else Light.ambient_only(0.8)
    r, gpu = render(Volume(data), *tf, cam, light, cfg)
    b2f = r.render_float64(premultiplied=True, order="back_to_front")
    f2b = r.render_float64(premultiplied=True)
    assert np.abs(b2f - f2b).max() < 1e-9
    assert np.abs(gpu - b2f).max() < TOL


@settings(**SETTINGS)
@given(data=volumes(2, 6), tf=tfs(), az=st.floats(-np.pi, np.pi), el=st.floats(-1.2, 1.2),
       dist=st.floats(1.0, 4.0), ext=st.tuples(*[st.floats(0.3, 2.0)] * 3))
def test_rotating_axes_together_with_bounds_and_camera_keeps_the_image(data, tf, az, el, dist, ext):
    # New world p' = (p.y, p.z, p.x): a rotation. data[i, j, k] at (x_i, y_j, z_k)
    # becomes data'[j, k, i]; bounds, camera and light are rotated alike.
    rot = lambda v: np.array([v[1], v[2], v[0]], np.float32)  # noqa: E731
    lo = -np.array(ext, np.float32) / 2
    vol = Volume(data, None, lo, -lo)
    cam = Camera(azimuth=az, elevation=el, distance=dist)
    light = Light.directional([0.3, -1.0, 0.5])
    cfg = RenderConfig(step_size=0.02, max_steps=1000)
    _, a = render(vol, *tf, cam, light, cfg)
    vol2 = Volume(np.ascontiguousarray(data.transpose(1, 2, 0)), None, rot(lo), rot(-lo))
    cam2 = Camera(target=rot(cam.target), azimuth=az, elevation=el, distance=dist,
                  init_pos=rot(cam.init_pos), init_up=rot(cam.init_up))
    light2 = Light(position=rot(light.position), target=rot(light.target))
    _, b = render(vol2, *tf, cam2, light2, cfg)
    assert np.abs(a - b).max() < TOL


@settings(**SETTINGS)
@given(a=st.floats(1e-4, 1.0), thickness=st.floats(0.05, 2.0), step=st.floats(1e-3, 0.2),
       ref=st.floats(1e-3, 1.0))
def test_doubling_a_slab_squares_its_transmittance(a, thickness, step, ref):
    def alpha(t):
        vol = Volume(np.full((3, 3, 3), 0.5, np.float32), None, f32(-t / 2, -1, -1), f32(t / 2, 1, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # max_steps "very large" is intended
            cfg = RenderConfig(step_size=step, max_steps=100_000, early_ray_termination=False,
                               reference_step_size=ref)
            r = VolumeRenderer(3, 3, config=cfg, light=Light.ambient_only(1.0))
            r.load_volume(vol)
            r.set_camera(Camera.front_view(distance=5.0))
            r.set_transfer_functions(ColorTransferFunction.grayscale(), OpacityTransferFunction.linear(a, a))
            return float(r.render(dtype=np.float32)[1, 1, 3])

    t1, t2 = 1 - alpha(thickness), 1 - alpha(2 * thickness)
    assert t2 == pytest.approx(t1 * t1, abs=1 / 255)


@settings(**SETTINGS)
@given(data=volumes(2, 6), tf=tfs(), cam=cameras(distance=(1.0, 4.0)), scale=st.floats(1e-3, 1e3),
       lit=st.booleans())
def test_scaling_the_whole_scene_keeps_the_image(data, tf, cam, scale, lit):
    light = Light.default() if lit else Light.ambient_only(0.9)

    def scene(s):
        vol = Volume(data, None, f32(-0.5, -0.5, -0.5) * s, f32(0.5, 0.5, 0.5) * s)
        c = Camera(azimuth=cam.azimuth, elevation=cam.elevation, roll=cam.roll, distance=cam.distance * s,
                   fov=cam.fov, init_pos=cam.init_pos * np.float32(s))
        cfg = RenderConfig(step_size=0.01 * s, reference_step_size=0.01 * s, max_steps=1000)
        return render(vol, *tf, c, light, cfg)[1]

    assert np.abs(scene(1.0) - scene(scale)).max() < TOL
