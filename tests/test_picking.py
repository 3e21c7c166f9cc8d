"""renderer.pick: the point of the volume a pixel shows, by its model.

A homogeneous box has a closed form: along a ray entering at t0 the
opacity 1 - exp(-a (t - t0) / ref) reaches a threshold q at
t0 + ref ln(1 / (1 - q)) / a, exactly (a segment's extinction is uniform,
so the crossing inside it is exact too). Projections and isosurfaces are
held to their geometry and to the engines' own depth images."""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_closed_form import rays
from test_orthographic import box_rays

W, H = 40, 32
A = 0.004


def box_renderer(camera, config=None, data=None, opacity=A):
    r = VolumeRenderer(W, H, config=config or RenderConfig.balanced(), light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((8, 8, 8), 0.5, np.float32) if data is None else data))
    r.set_camera(camera)
    r.set_transfer_functions(ColorTransferFunction.single_color((1, 1, 1)),
                             OpacityTransferFunction.linear(opacity, opacity))
    return r


def every_pixel():
    return np.meshgrid(np.arange(W), np.arange(H))


PERSPECTIVE = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.2, elevation=0.15, roll=0.0,
                                    distance=2.5)
ORTHOGRAPHIC = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.2, elevation=0.15, roll=0.0,
                                     distance=2.5, projection="orthographic", view_height=1.6)


@pytest.mark.parametrize("camera", [PERSPECTIVE, ORTHOGRAPHIC], ids=["perspective", "orthographic"])
@pytest.mark.parametrize("threshold", [0.1, 0.5, 0.9])
def test_a_homogeneous_box_is_picked_where_its_opacity_reaches_the_threshold(camera, threshold):
    # An opacity that reaches the threshold 0.7 into the box.
    opacity = float(np.float32(0.01 * np.log(1 / (1 - threshold)) / 0.7))
    r = box_renderer(camera, opacity=opacity)
    x, y = every_pixel()
    picks = r.pick(x, y, threshold=threshold)
    o, d, t0, t1 = box_rays(camera, W, H)
    reach = 0.01 * np.log(1 / (1 - threshold)) / np.float64(np.float32(opacity))  # reference step 0.01
    t = t0 + reach
    expect_hit = np.nan_to_num(t1 - t0) >= reach
    assert 0 < expect_hit.sum() < W * H, "some rays reach the threshold, some do not"
    assert np.array_equal(picks.hit, expect_hit)
    assert np.abs(picks.depth[expect_hit] - t[expect_hit]).max() < 1e-9
    np.testing.assert_allclose(picks.position[expect_hit], (o + d * t[..., None])[expect_hit], atol=1e-9)
    assert np.all(np.isnan(picks.position[~expect_hit])) and np.all(picks.index[~expect_hit] == -1)
    assert np.all(picks.value[expect_hit] == pytest.approx(0.5))


def blob(n=48, centre=(0.1, -0.05, 0.08)):
    axes = [(np.arange(n) + 0.5) / n - 0.5 - c for c in centre]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    return (np.exp(-(x * x + y * y + z * z) / 0.08)).astype(np.float32), np.array(centre)


def test_a_maximum_projection_is_picked_at_its_brightest_sample():
    data, centre = blob()
    config = RenderConfig(step_size=0.005, model="mip")
    r = box_renderer(PERSPECTIVE, config, data, opacity=1.0)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("gray"), OpacityTransferFunction.linear(1.0, 1.0))
    img = r.render(dtype=np.float32)
    x, y = every_pixel()
    picks = r.pick(x, y)
    o, d, t0, t1 = rays(PERSPECTIVE, np.full(3, -0.5), np.full(3, 0.5), W, H)
    assert picks.hit.sum() == np.isfinite(t0).sum() > 100
    # The engine's pixel is grey at the ray's largest sample: the value at
    # the picked point (interpolated apart from both) gives that grey.
    assert np.abs(img[..., 0][picks.hit] - picks.value[picks.hit]).max() < 2 / 255
    # And nothing on the ray is brighter, up to the samples' spacing: not
    # the point nearest the field's centre, where the Gaussian peaks.
    nearest = o + d * np.clip(d @ (centre - o), t0, t1)[..., None]
    peak = np.exp(-np.sum((nearest - centre) ** 2, axis=-1) / 0.08)
    assert np.all(picks.value[picks.hit] > peak[picks.hit] - 0.01)


def test_isosurface_picks_agree_with_the_engines_depth():
    data, centre = blob()
    config = RenderConfig(step_size=0.01, model="isosurface", iso_value=0.5)
    r = box_renderer(PERSPECTIVE, config, data, opacity=0.5)
    r.render()
    depth = r.depth()
    x, y = every_pixel()
    picks = r.pick(x, y)
    seen = np.isfinite(depth)
    assert seen.sum() > 30 and np.array_equal(picks.hit, seen)
    # The engine brackets its crossing by bisection to 1/256 of a step.
    assert np.abs(picks.depth[seen] - depth[seen]).max() < 0.5 * 0.01
    # On the surface: the interpolated field there is the iso value.
    assert np.abs(picks.value[seen] - 0.5).max() < 1e-3
    # ... which, for this Gaussian, is a sphere about the centre.
    radius = np.linalg.norm(picks.position[seen] - centre, axis=-1)
    assert radius.std() < 0.01


def test_clip_planes_move_what_is_picked():
    r = box_renderer(PERSPECTIVE, opacity=0.01)
    before = r.pick(20, 16)
    r.set_clip_planes([((0.2, 0.0, 0.0), (-1.0, 0.0, 0.0))])  # keeps x <= 0.2: the near part is cut
    after = r.pick(20, 16)
    assert before.hit and after.hit
    assert after.position[0] == pytest.approx(before.position[0] - 0.3, abs=1e-6)


def test_indices_values_shapes_and_origin():
    data = np.broadcast_to(np.arange(8, dtype=np.float32)[:, None, None], (8, 8, 8)).copy()  # value = i
    r = box_renderer(PERSPECTIVE, data=data, opacity=0.01)
    picks = r.pick(np.arange(W), 16)
    assert picks.hit.shape == (W,) and picks.position.shape == (W, 3) and picks.index.shape == (W, 3)
    shown = picks.hit
    # Cell-centred: voxel i covers x in [-0.5 + i/8, -0.5 + (i+1)/8].
    u = (picks.position[shown, 0] + 0.5) * 8 - 0.5
    np.testing.assert_allclose(picks.value[shown], np.clip(u, 0, 7), atol=1e-9)
    assert np.array_equal(picks.index[shown, 0], np.clip(np.rint(u), 0, 7).astype(int))
    # Row 16 from the bottom is row H - 1 - 16 from the top.
    flipped = r.pick(np.arange(W), H - 1 - 16, origin="upper")
    np.testing.assert_array_equal(flipped.depth, picks.depth)
    single = r.pick(20.2, 16)  # numbers round to the nearest pixel
    assert single.hit.shape == () and single.depth == picks.depth[20]


def test_rays_that_show_nothing():
    r = box_renderer(PERSPECTIVE, opacity=0.0)
    picks = r.pick([0, 20], [0, 16])
    assert not picks.hit.any() and np.all(np.isnan(picks.value)) and np.all(picks.index == -1)


@pytest.mark.parametrize(("kw", "exc", "message"), [
    ({"x": W, "y": 0}, ValueError, r"x must be pixel coordinates from 0 to 39"),
    ({"x": 0, "y": -1}, ValueError, r"y must be pixel coordinates from 0 to 31"),
    ({"x": True, "y": 0}, TypeError, r"x must be pixel coordinates"),
    ({"x": 0, "y": 0, "threshold": 0.0}, ValueError, r"threshold must be in \(0, 1\]"),
    ({"x": 0, "y": 0, "threshold": True}, TypeError, r"threshold must be a number"),
    ({"x": 0, "y": 0, "origin": "middle"}, ValueError, r"origin must be 'lower' or 'upper'"),
])
def test_bad_arguments_are_refused(kw, exc, message):
    r = box_renderer(PERSPECTIVE)
    with pytest.raises(exc, match=message):
        r.pick(**kw)


def test_picking_needs_a_volume():
    with pytest.raises(RuntimeError, match="no volume loaded"):
        VolumeRenderer(8, 8).pick(0, 0)


@pytest.mark.parametrize("config", [RenderConfig.balanced(), RenderConfig.balanced().replace(model="mip")],
                         ids=["emission_absorption", "mip"])
def test_a_depth_image_for_any_model_round_trips_a_depth_buffer(config):
    from pyvr import scene_depth

    data, _ = blob()
    r = box_renderer(PERSPECTIVE, config, data, opacity=0.5)
    depth = r.depth_image()
    x, y = every_pixel()
    np.testing.assert_array_equal(depth, np.where(r.pick(x, y).hit, r.pick(x, y).depth, np.inf).astype(np.float32))
    assert np.isfinite(depth).mean() > 0.2
    near, far = PERSPECTIVE.near_plane, PERSPECTIVE.far_plane
    buffer = scene_depth.to_depth_buffer(depth, PERSPECTIVE, near, far)
    assert buffer.dtype == np.float32 and 0 <= buffer.min() and buffer.max() == 1.0
    back = scene_depth.from_depth_buffer(buffer, PERSPECTIVE, near, far)
    seen = np.isfinite(depth)
    np.testing.assert_allclose(back[seen], depth[seen], rtol=1e-4)
    assert np.all(np.isinf(back[~seen]))


def test_picks_follow_the_loaded_volume():
    # Picks keep the volume as the integrator reads it (float64 data is
    # converted once, not per pick) until another volume is loaded.
    r = box_renderer(PERSPECTIVE, data=np.full((8, 8, 8), 0.5), opacity=0.01)
    first = r.pick(20, 16)
    kept = r._reference_voxels[1]
    assert r.pick(20, 16).value == first.value == pytest.approx(0.5) and r._reference_voxels[1] is kept
    r.load_volume(Volume(np.full((8, 8, 8), 0.75)))
    assert r.pick(20, 16).value == pytest.approx(0.75)
