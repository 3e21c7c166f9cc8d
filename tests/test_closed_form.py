"""Closed-form checks: a homogeneous cube with a constant transfer function.

Every pixel's ray crosses the box along a chord of length L that numpy
computes exactly; Beer–Lambert gives alpha = 1 - exp(-a L / ref) and straight
colour = c * I. This is the opacity-correction design's promise: the same
TF looks the same at every preset's step size. Tolerance 1/255 (the cross-validation bound);
the f64 integrator is held to 1e-6.
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, _core
from pyvr._scene import _camera_tuple
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

W, H = 48, 40
A_TF = 0.004
COLOR = (0.9, 0.5, 0.2)
PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]


def rays(cam, bmin, bmax, w, h):
    """Per pixel (row 0 at the bottom): origin, unit direction, and the chord's
    ray parameters t0, t1 through the box (t0 clipped at the eye; nan on a miss)."""
    p, up = cam.get_camera_vectors()
    f = cam.target - p
    f = f / np.linalg.norm(f)
    rt = np.cross(f, up)
    rt /= np.linalg.norm(rt)
    u = np.cross(rt, f)
    t = np.tan(cam.fov / 2)
    nx, ny = np.meshgrid(2 * (np.arange(w) + 0.5) / w - 1, 2 * (np.arange(h) + 0.5) / h - 1)
    d = f + nx[..., None] * (w / h) * t * rt + ny[..., None] * t * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (bmin - p) / d, (bmax - p) / d
    t0 = np.maximum(np.nanmax(np.minimum(ta, tb), axis=-1), 0)
    t1 = np.nanmin(np.maximum(ta, tb), axis=-1)
    miss = ~(t1 > t0)
    return p, d, np.where(miss, np.nan, t0), np.where(miss, np.nan, t1)


def chords(camera, bmin, bmax, width, height):
    """Each pixel's chord length through the box (0 on a miss)."""
    _, _, t0, t1 = rays(camera, bmin, bmax, width, height)
    return np.nan_to_num(t1 - t0)


def cube_scene(preset):
    cfg = getattr(RenderConfig, preset)()
    cfg = RenderConfig(step_size=cfg.step_size, max_steps=10_000, early_ray_termination=False,
                       opacity_threshold=1.0)
    vol = Volume(np.full((8, 8, 8), 0.5, np.float32))
    ctf = ColorTransferFunction.single_color(COLOR)
    otf = OpacityTransferFunction.linear(A_TF, A_TF)
    cam = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.2, elevation=0.15, roll=0.0,
                                distance=2.5)
    return vol, ctf, otf, cam, Light.ambient_only(1.0), cfg


@pytest.mark.parametrize("preset", PRESETS)
def test_homogeneous_cube_at_every_preset_step(preset):
    vol, ctf, otf, cam, light, cfg = cube_scene(preset)
    r = VolumeRenderer(W, H, config=cfg, light=light)
    r.load_volume(vol)
    r.set_camera(cam)
    r.set_transfer_functions(ctf, otf)
    img = r.render(dtype=np.float32)  # straight RGBA
    L = chords(cam, vol.min_bounds.astype(np.float64), vol.max_bounds.astype(np.float64), W, H)
    expect_a = 1 - np.exp(-np.float32(A_TF).astype(np.float64) * L / cfg.reference_step_size)
    assert expect_a.max() > 0.3, "thick enough to test"
    assert np.abs(img[..., 3] - expect_a).max() < 1 / 255
    inside = expect_a > 0.01
    for c in range(3):
        assert np.abs(img[..., c][inside] - COLOR[c]).max() < 1 / 255
    u8 = r.render()
    assert np.abs(u8[..., 3].astype(float) - np.round(expect_a * 255)).max() <= 1


def float64_cube(cam, cfg, **kw):
    """The f64 integrator's frame of the homogeneous cube (ambient light,
    the constant table), straight from the core: (image, steps needed)."""
    lut = np.zeros((2, 4), np.float32)
    lut[:, :3] = COLOR
    lut[:, 3] = A_TF
    img, needed, _ = _core.integrate_reference(
        np.full((8, 8, 8), 0.5, np.float32), None, (-0.5,) * 3, (0.5,) * 3, lut, _camera_tuple(cam),
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0, 0.0, "directional"), cfg, W, H, **kw,
    )
    return img, needed


@pytest.mark.parametrize("preset", PRESETS)
def test_f64_integrator_matches_closed_form(preset):
    _, _, _, cam, _, cfg = cube_scene(preset)
    img, needed = float64_cube(cam, cfg)
    L = chords(cam, np.full(3, -0.5), np.full(3, 0.5), W, H)
    a = np.float64(np.float32(A_TF))
    expect = 1 - np.exp(-a * L / cfg.reference_step_size)
    assert needed == 0
    assert np.abs(img[..., 3] - expect).max() < 1e-6
    assert np.abs(img[..., 0] - np.float32(COLOR[0]) * expect).max() < 1e-6


def test_power_form_closed_form():
    vol, ctf, otf, cam, light, _ = cube_scene("fast")
    cfg = RenderConfig(step_size=0.013, max_steps=10000, early_ray_termination=False,
                       opacity_correction="power")
    r = VolumeRenderer(W, H, config=cfg, light=light)
    r.load_volume(vol)
    r.set_camera(cam)
    r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.05, 0.05))
    img = r.render(dtype=np.float32)
    L = chords(cam, np.full(3, -0.5), np.full(3, 0.5), W, H)
    expect = 1 - (1 - np.float64(np.float32(0.05))) ** (L / 0.01)
    assert np.abs(img[..., 3] - expect).max() < 1 / 255
