"""render(depth=, color=): an opaque scene inside the volume.

Closed form: a homogeneous box with an opaque square on the plane x = c
through it. A
pixel's ray crosses the box from t0 and meets the plane at tp; the volume
in front has alpha a_v = 1 - exp(-a L / ref) with L = min(t1, tp) - t0, and
the pixel is the volume's colour times a_v plus the plane's colour times
1 - a_v, opaque. Held to 0.5 level, both projections and orders."""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, scene_depth
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_closed_form import COLOR, H, W
from test_orthographic import box_rays

HALF_LEVEL = 0.5 / 255
PLANE_X = 0.1
PLANE_COLOR = np.array([0.2, 0.4, 0.6])
A = 0.01  # an alpha per reference step that lets the plane show through, dimmed

CAMERAS = {
    "perspective": Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, roll=0.0,
                                         distance=2.5),
    "orthographic": Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, roll=0.0,
                                          distance=2.5, projection="orthographic", view_height=1.6),
}


def geometry(camera):
    """Per pixel: the box chord (t0, t1) and the plane's ray parameter tp."""
    o, d, t0, t1 = box_rays(camera, W, H)
    tp = (PLANE_X - o[..., 0]) / d[..., 0]
    # A square of the plane, 0.6 a side: some rays pass it by.
    hit = o + d * tp[..., None]
    on = (tp > 0) & (np.abs(hit[..., 1]) <= 0.3) & (np.abs(hit[..., 2]) <= 0.3)
    return t0, t1, np.where(on, tp, np.inf)


def box(camera, config=None):
    r = VolumeRenderer(W, H, config=config or RenderConfig(step_size=0.01, max_steps=10_000,
                                                           early_ray_termination=False),
                       light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((8, 8, 8), 0.5, np.float32)))
    r.set_camera(camera)
    r.set_transfer_functions(ColorTransferFunction.single_color(COLOR), OpacityTransferFunction.linear(A, A))
    return r


def expected(camera, ref=0.01):
    t0, t1, tp = geometry(camera)
    L = np.nan_to_num(np.clip(np.minimum(t1, tp) - t0, 0, None))
    a_v = 1 - np.exp(-np.float64(np.float32(A)) * L / ref)
    rgb = np.asarray(COLOR) * a_v[..., None] + (1 - a_v[..., None]) * PLANE_COLOR
    surface = np.isfinite(tp)
    rgb = np.where(surface[..., None], rgb, np.asarray(COLOR) * a_v[..., None])
    alpha = np.where(surface, 1.0, a_v)
    return tp, np.concatenate([rgb, alpha[..., None]], axis=-1), a_v


@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("step", [0.02, 0.01, 0.0037])
@pytest.mark.parametrize("name", sorted(CAMERAS))
def test_an_opaque_plane_inside_a_homogeneous_box(name, step, order):
    camera = CAMERAS[name]
    cfg = RenderConfig(step_size=step, max_steps=10_000, early_ray_termination=False, order=order)
    r = box(camera, cfg)
    tp, want, a_v = expected(camera)
    surface = np.isfinite(tp)
    # The plane cuts some rays short and misses others: both kinds are here.
    assert 0 < surface.mean() < 1 and a_v[surface].max() > 0.2
    got = r.render(dtype=np.float32, premultiplied=True, depth=tp,
                   color=np.broadcast_to(PLANE_COLOR, (H, W, 3)))
    assert np.abs(got - want).max() < HALF_LEVEL
    # Depth alone: the volume in front of the scene, for the caller to composite.
    alone = r.render(dtype=np.float32, premultiplied=True, depth=tp)
    assert np.abs(alone[..., 3] - a_v).max() < HALF_LEVEL
    # The next frame has no scene again.
    whole = r.render(dtype=np.float32, premultiplied=True)
    assert np.abs(whole[..., 3] - alone[..., 3]).max() > 0.1


@pytest.mark.parametrize("name", sorted(CAMERAS))
def test_the_float64_integrator_stops_at_the_scene_too(name):
    camera = CAMERAS[name]
    r = box(camera)
    tp, want, _ = expected(camera)
    got = r.render_float64(premultiplied=True, depth=tp, color=np.broadcast_to(PLANE_COLOR, (H, W, 3)))
    assert np.abs(got - want).max() < 1e-6


def test_rows_follow_origin_and_bricks_and_accumulation_agree():
    camera = CAMERAS["perspective"]
    tp, _, _ = expected(camera)
    color = np.broadcast_to(PLANE_COLOR, (H, W, 3))
    r = box(camera)
    lower = r.render(dtype=np.float32, depth=tp, color=color)
    upper = r.render(dtype=np.float32, depth=tp[::-1], color=color[::-1], origin="upper")
    np.testing.assert_array_equal(upper, lower[::-1])
    bricked = VolumeRenderer(W, H, config=r.get_config(), light=Light.ambient_only(1.0), brick_shape=(4, 4, 4))
    bricked.load_volume(r.volume)
    bricked.set_camera(camera)
    bricked.set_transfer_functions(ColorTransferFunction.single_color(COLOR), OpacityTransferFunction.linear(A, A))
    assert np.abs(bricked.render(dtype=np.float32, depth=tp, color=color) - lower).max() < HALF_LEVEL
    # A mean of unbiased frames: opaque exactly where the scene is, and
    # there, within its noise, the single frame's colour.
    mean = r.render(dtype=np.float32, premultiplied=True, depth=tp, color=color, accumulate=8)
    surface = np.isfinite(tp)
    assert np.all(mean[..., 3][surface] == 1) and mean[..., 3][~surface].max() < 0.9
    single = r.render(dtype=np.float32, premultiplied=True, depth=tp, color=color)
    assert np.abs(mean - single)[surface].mean() < 0.02


@pytest.mark.parametrize(("kw", "exc", "message"), [
    ({"depth": np.zeros((H, W + 1))}, ValueError, r"depth must have shape \(height, width\) = \(40, 48\)"),
    ({"depth": np.full((H, W), -1.0)}, ValueError, r"depth must hold distances >= 0"),
    ({"depth": np.full((H, W), np.nan)}, ValueError, r"depth must hold distances >= 0"),
    ({"depth": np.zeros((H, W), bool)}, TypeError, r"depth must be an array of distances"),
    ({"color": np.zeros((H, W, 3))}, ValueError, r"color needs depth"),
    ({"depth": np.zeros((H, W)), "color": np.full((H, W, 3), 2.0)}, ValueError, r"color must hold values in \[0, 1\]"),
    ({"depth": np.zeros((H, W)), "color": np.zeros((H, W, 4))}, ValueError, r"color must have shape"),
])
def test_bad_scenes_are_refused_and_change_nothing(kw, exc, message):
    r = box(CAMERAS["perspective"])
    before = r.render(dtype=np.float32)
    with pytest.raises(exc, match=message):
        r.render(**kw)
    np.testing.assert_array_equal(r.render(dtype=np.float32), before)


@pytest.mark.parametrize("name", sorted(CAMERAS))
@pytest.mark.parametrize("convention", ["window", "ndc"])
def test_depth_buffers_convert_to_distances_along_the_rays(name, convention):
    # A rasteriser's depth of the plane, made from pyvr's own view and
    # projection matrices (stored transposed, as pyvr's are), back to the
    # distances the closed form gives.
    camera = CAMERAS[name]
    near, far = camera.near_plane, camera.far_plane
    tp, _, _ = expected(camera)
    view = camera.get_view_matrix().astype(np.float64).T
    proj = camera.get_projection_matrix(W / H).astype(np.float64)
    o, d, _, _ = box_rays(camera, W, H)
    points = o + d * np.where(np.isfinite(tp), tp, 1e9)[..., None]
    eye = np.einsum("ij,hwj->hwi", view, np.concatenate([points, np.ones((H, W, 1))], axis=-1))
    clip = np.einsum("ij,hwj->hwi", proj, eye)
    ndc = np.clip(clip[..., 2] / clip[..., 3], -1.0, 1.0)
    buffer = (ndc + 1) / 2 if convention == "window" else ndc
    got = scene_depth.from_depth_buffer(buffer.astype(np.float32), camera, near, far, convention=convention)
    hit = np.isfinite(tp) & (tp < far * 0.9)
    assert hit.mean() > 0.05
    # float32 window depth resolves distances near 2.5 to about 1e-5.
    np.testing.assert_allclose(got[hit], tp[hit], rtol=1e-4)
    assert np.all(np.isinf(got[~np.isfinite(tp)]))
