"""Orthographic cameras: parallel rays from the camera's plane.

Pixel (x, y)'s ray starts at position + X (aspect h / 2) right + Y (h / 2) up
(X, Y its centre in [-1, 1]) and runs along the view direction. A
homogeneous box seen so has a closed form per pixel, as in perspective
(test_closed_form.py): alpha = 1 - exp(-a L / ref) for the ray's chord L,
which numpy computes exactly; with clip planes too. Held to 0.5 level at
every preset, both orders, on whichever engine the suite runs.
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera, CameraController, CameraPath
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_clip_planes import MODELS, PLANES, levels, scene
from test_closed_form import A_TF, COLOR, PRESETS, H, W, float64_cube, rays

HALF_LEVEL = 0.5 / 255


def ortho_camera(height=1.6, **kw):
    kw = {"projection": "orthographic", "view_height": height, **kw}
    return Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.25, roll=0.0,
                                 distance=2.5, **kw)


def parallel_rays(cam, w, h):
    """Per pixel (row 0 at the bottom): origin and the shared unit direction."""
    p, up = cam.get_camera_vectors()
    f = np.asarray(cam.target, np.float64) - p
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    half = 0.5 * cam.orthographic_height
    nx, ny = np.meshgrid(2 * (np.arange(w) + 0.5) / w - 1, 2 * (np.arange(h) + 0.5) / h - 1)
    o = p + nx[..., None] * (w / h) * half * r + ny[..., None] * half * u
    return o, f


def box_rays(cam, w=W, h=H, lo=-0.5, hi=0.5):
    """Per pixel, for either projection: origin and direction (h, w, 3)
    and the chord (t0, t1) through the box, t0 clipped at the ray's start
    (NaN on a miss)."""
    if cam.projection != "orthographic":
        p, d, t0, t1 = rays(cam, np.broadcast_to(lo, 3), np.broadcast_to(hi, 3), w, h)
        return np.broadcast_to(p, d.shape), d, t0, t1
    o, d = parallel_rays(cam, w, h)
    d = np.broadcast_to(d, o.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (lo - o) / d, (hi - o) / d
    t0 = np.maximum(np.nanmax(np.minimum(ta, tb), axis=-1), 0)
    t1 = np.nanmin(np.maximum(ta, tb), axis=-1)
    miss = ~(t1 > t0)
    return o, d, np.where(miss, np.nan, t0), np.where(miss, np.nan, t1)


def chords(cam, planes=(), lo=-0.5, hi=0.5):
    o, d, t0, t1 = box_rays(cam, W, H, lo, hi)
    d = d[0, 0]
    for point, normal in planes:
        n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
        f0 = (o - np.asarray(point, np.float64)) @ n
        slope = float(d @ n)
        if slope > 0:
            t0 = np.maximum(t0, -f0 / slope)
        elif slope < 0:
            t1 = np.minimum(t1, -f0 / slope)
        else:
            t1 = np.where(f0 < 0, -np.inf, t1)
    return np.nan_to_num(np.maximum(t1 - t0, 0.0))


def expected_alpha(L, cfg):
    return 1 - np.exp(-np.float64(np.float32(A_TF)) * L / cfg.reference_step_size)


def cube(preset="balanced", camera=None, order="front_to_back", planes=(), **kw):
    step = getattr(RenderConfig, preset)().step_size
    cfg = RenderConfig(step_size=step, max_steps=10_000, early_ray_termination=False, opacity_threshold=1.0,
                       order=order)
    r = VolumeRenderer(W, H, config=cfg, light=Light.ambient_only(1.0), **kw)
    r.load_volume(Volume(np.full((8, 8, 8), 0.5, np.float32)))
    r.set_camera(camera or ortho_camera())
    r.set_transfer_functions(ColorTransferFunction.single_color(COLOR), OpacityTransferFunction.linear(A_TF, A_TF))
    r.set_clip_planes(planes)
    return r, cfg


@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("preset", PRESETS)
def test_a_homogeneous_box_seen_with_parallel_rays(preset, order):
    cam = ortho_camera()
    r, cfg = cube(preset, cam, order)
    img = r.render(dtype=np.float32)
    L = chords(cam)
    expect = expected_alpha(L, cfg)
    # The box is seen whole with a margin, and its chords vary.
    assert expect[0].max() == 0 and expect[-1].max() == 0 and expect.max() > 0.2
    assert np.abs(img[..., 3] - expect).max() < HALF_LEVEL
    shown = expect > 0.01
    for c in range(3):
        assert np.all(np.abs(img[..., c][shown] - COLOR[c]) < HALF_LEVEL)


@pytest.mark.parametrize("cut", [False, True])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e4])
def test_a_box_of_any_size_and_shape(scale, cut):
    # Lengths in the engines are in units of the box's longest side: the
    # view's height must be too (a unit cube alone would not show it).
    lo, hi = np.array([-2.0, -1.0, -0.5]) * scale, np.array([2.0, 1.0, 0.5]) * scale
    cam = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.25, roll=0.0,
                                distance=6.0 * scale, projection="orthographic", view_height=3.0 * scale)
    cfg = RenderConfig(step_size=0.01 * scale, reference_step_size=0.01 * scale, max_steps=10_000,
                       early_ray_termination=False)
    r = VolumeRenderer(W, H, config=cfg, light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((8, 8, 8), 0.5, np.float32), min_bounds=lo.astype(np.float32),
                         max_bounds=hi.astype(np.float32)))
    r.set_camera(cam)
    r.set_transfer_functions(ColorTransferFunction.single_color(COLOR), OpacityTransferFunction.linear(A_TF, A_TF))
    planes = [((0.3 * scale, 0.0, 0.1 * scale), (1.0, 0.5, -0.3))] if cut else []
    r.set_clip_planes(planes)
    expect = 1 - np.exp(-np.float64(np.float32(A_TF)) * chords(cam, planes, lo, hi) / cfg.reference_step_size)
    assert expect.max() > 0.3 and expect[:, 0].max() == 0
    assert np.abs(r.render(dtype=np.float32)[..., 3] - expect).max() < HALF_LEVEL


@pytest.mark.parametrize("name", ["oblique", "wedge", "facing_the_eye", "along_an_axis"])
@pytest.mark.parametrize("preset", ["preview", "balanced", "ultra_quality"])
def test_a_clipped_box_seen_with_parallel_rays(preset, name):
    cam = ortho_camera()
    r, cfg = cube(preset, cam, planes=PLANES[name])
    img = r.render(dtype=np.float32)
    expect = expected_alpha(chords(cam, PLANES[name]), cfg)
    assert np.abs(expected_alpha(chords(cam), cfg) - expect).max() > 0.1, "the planes cut what is seen"
    assert np.abs(img[..., 3] - expect).max() < HALF_LEVEL


def test_looking_along_an_axis_every_ray_crosses_the_whole_depth():
    # Along an axis with the box centred, each ray that meets the box
    # crosses its whole depth of 1 (perspective rays cross less off centre).
    cam = Camera.front_view(distance=2.5)
    cam.projection, cam.view_height = "orthographic", 2.0
    r, cfg = cube("balanced", cam)
    alpha = r.render(dtype=np.float32)[..., 3]
    L = chords(cam)
    assert np.all((L == 0) | (np.abs(L - 1.0) < 1e-12))
    assert 0.2 < (L > 0).mean() < 0.3  # the unit face in a view 2 high, 2.4 wide
    assert np.abs(alpha - expected_alpha(L, cfg)).max() < HALF_LEVEL


def test_the_float64_integrator_matches_the_closed_form():
    cam = ortho_camera()
    _, cfg = cube("fast", cam)
    img, _ = float64_cube(cam, cfg)  # the core's camera with its view height: parallel rays
    assert np.abs(img[..., 3] - expected_alpha(chords(cam), cfg)).max() < 1e-6


@pytest.mark.parametrize("config", [*MODELS.values(), RenderConfig(step_size=0.01, jitter=True)],
                         ids=[*MODELS, "jitter"])
def test_every_model_sees_as_the_float64_integrator_does(config):
    r = scene(config, [], ortho_camera(height=1.3))
    img = r.render(dtype=np.float32)
    perspective = scene(config, [], ortho_camera(fov=0.55, projection="perspective"))
    assert levels(perspective.render(dtype=np.float32), img) > 20, "parallel rays show another picture"
    assert levels(img, r.render_float64()) < 0.05


def test_a_camera_inside_the_volume_sees_from_its_plane():
    cam = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, roll=0.0,
                                distance=0.2, projection="orthographic", view_height=0.8)
    r = scene(RenderConfig.balanced(), [], cam)
    img = r.render(dtype=np.float32)
    assert img[..., 3].min() > 0.05  # every ray starts inside the volume
    assert levels(img, r.render_float64()) < 0.05


def test_bricked_volumes_see_as_whole_ones():
    cam = ortho_camera(height=1.3)
    whole = scene(RenderConfig.balanced(), [], cam).render(dtype=np.float32)
    bricked = scene(RenderConfig.balanced(), [], cam, brick_shape=(16, 16, 16))
    assert levels(bricked.render(dtype=np.float32), whole) < 0.5


@pytest.mark.parametrize("aspect", [1.0, 2.0, 0.5])
def test_fit_frames_the_box_for_both_projections(aspect):
    box = (np.array([-2.0, -1.0, -0.5]), np.array([2.0, 1.0, 0.5]))
    w, h = (int(64 * aspect), 64) if aspect >= 1 else (64, int(64 / aspect))
    for projection in ("perspective", "orthographic"):
        cam = Camera.fit(box, azimuth=0.5, elevation=0.4, aspect=w / h, projection=projection)
        assert cam.projection == projection
        r = VolumeRenderer(w, h, config=RenderConfig.fast(), light=Light.ambient_only(1.0))
        r.load_volume(Volume(np.ones((4, 4, 4), np.float32), min_bounds=box[0], max_bounds=box[1]))
        r.set_camera(cam)
        r.set_transfer_functions(ColorTransferFunction.single_color((1, 1, 1)), OpacityTransferFunction.linear(1, 1))
        seen = r.render(dtype=np.float32)[..., 3] > 0
        rows, cols = np.nonzero(seen.any(axis=1))[0], np.nonzero(seen.any(axis=0))[0]
        # Inside the image with room to spare, and filling much of it.
        assert rows.min() > 0 and cols.min() > 0 and rows.max() < h - 1 and cols.max() < w - 1
        assert max((rows.max() - rows.min()) / h, (cols.max() - cols.min()) / w) > 0.5


def test_the_camera_keeps_its_projection():
    cam = ortho_camera(height=None)
    assert cam.orthographic_height == pytest.approx(2 * 2.5 * np.tan(np.pi / 8))
    again = Camera.from_dict(cam.to_dict())
    assert (again.projection, again.view_height) == ("orthographic", None)
    assert "orthographic" in repr(cam)
    # Zooming in shows less, as a perspective view's does.
    c = CameraController(ortho_camera(height=1.6))
    c.zoom(0.5)
    assert c.params.view_height == pytest.approx(0.8)
    c.reset_to_preset("top")
    assert c.params.projection == "orthographic"
    path = CameraPath([ortho_camera(height=1.0), ortho_camera(height=2.0)])
    mid = path.interpolate(0.5)
    assert mid.projection == "orthographic" and mid.view_height == pytest.approx(1.5)
    # The projection matrix maps the view's half height at any depth to 1.
    m = cam.get_projection_matrix(1.0)
    top = np.array([0.0, 0.5 * cam.orthographic_height, -1.7, 1.0])
    assert (m @ top)[1] == pytest.approx(1.0)


@pytest.mark.parametrize(("kw", "message"), [
    ({"projection": "fisheye"}, "projection must be one of perspective, orthographic"),
    ({"projection": "orthographic", "view_height": 0.0}, "view_height must be a finite number > 0"),
    ({"projection": "orthographic", "view_height": float("inf")}, "view_height must be a finite number > 0"),
])
def test_bad_projections_are_refused(kw, message):
    with pytest.raises(ValueError, match=message):
        Camera(**kw)


def test_a_camera_changed_into_a_bad_projection_is_refused_when_set():
    r = VolumeRenderer(8, 8)
    cam = ortho_camera()
    cam.projection = "fish"
    with pytest.raises(ValueError, match="projection must be one of perspective, orthographic, got 'fish'"):
        r.set_camera(cam)
    cam.projection, cam.view_height = "orthographic", -1.0
    with pytest.raises(ValueError, match="view_height must be a finite number > 0"):
        r.set_camera(cam)
