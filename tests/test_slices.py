"""Slices: render_slice (multi-planar reformatting) and slice planes shown
in the 3-D view. Trilinear interpolation reproduces a linear field exactly
away from the box's outer half-voxel, so a slice of one has a closed form;
an opaque slice inside a homogeneous box has the depth-in closed form
(tests/test_depth_in.py) with the slice's own colour."""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_closed_form import COLOR, H, W, rays

N = 16
GRAD = np.array([0.3, -0.2, 0.5])


def linear_volume():
    """data = GRAD . x at each voxel's centre, x in the box [-1, 1]^3."""
    c = (np.arange(N) + 0.5) / N * 2 - 1
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    return Volume((GRAD[0] * x + GRAD[1] * y + GRAD[2] * z).astype(np.float64).astype(np.float32),
                  min_bounds=np.full(3, -1, np.float32), max_bounds=np.full(3, 1, np.float32))


def renderer(volume):
    r = VolumeRenderer(W, H, config=RenderConfig.balanced(), light=Light.ambient_only(1.0))
    r.load_volume(volume)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("gray"), OpacityTransferFunction.linear(0.2, 0.9),
                             value_range=(-1.0, 1.0))
    return r


def test_a_slice_of_a_linear_field_is_the_field():
    r = renderer(linear_volume())
    point, normal = np.array([0.1, -0.05, 0.2]), np.array([0.3, 0.9, -0.2])
    values = r.render_slice((point, normal), height=1.2, values=True)
    n = normal / np.linalg.norm(normal)
    up = np.array([0.0, 0.0, 1.0]) - n[2] * n
    up /= np.linalg.norm(up)
    right = np.cross(up, n)
    x = (2 * (np.arange(W) + 0.5) / W - 1) * 0.6 * W / H
    y = (2 * (np.arange(H) + 0.5) / H - 1) * 0.6
    pts = point + x[None, :, None] * right + y[:, None, None] * up
    assert np.all(np.abs(pts) < 1 - 1 / N)  # inside the voxels' centres: exact interpolation
    np.testing.assert_allclose(values, pts @ GRAD, atol=1e-6)  # float32 voxels
    # The image through the transfer functions: grey at the value's place in
    # [-1, 1], opacity on the ramp 0.2 -> 0.9, straight colour.
    img = r.render_slice((point, normal), height=1.2, dtype=np.float32)
    s = (values + 1) / 2
    np.testing.assert_allclose(img[..., 0], s, atol=1 / 255)
    np.testing.assert_allclose(img[..., 3], 0.2 + 0.7 * s, atol=1 / 255)
    # origin="upper" flips rows.
    np.testing.assert_array_equal(r.render_slice((point, normal), height=1.2, values=True, origin="upper"),
                                  values[::-1])


def test_the_slice_is_seen_from_the_normals_side_with_its_up():
    r = renderer(linear_volume())
    # Normal +x, up +z: right is +y (y's gradient -0.2: values fall left to right).
    v = r.render_slice(((0, 0, 0), (1, 0, 0)), height=1.0, values=True)
    assert np.all(np.diff(v, axis=1) < 0) and np.all(np.diff(v, axis=0) > 0)  # rows up +z (gradient 0.5)
    turned = r.render_slice(((0, 0, 0), (1, 0, 0)), height=1.0, values=True, up=(0, 1, 0))
    assert np.all(np.diff(turned, axis=0) < 0)  # up +y now


def test_outside_the_box_is_transparent():
    r = renderer(linear_volume())
    v = r.render_slice(((0, 0, 0), (0, 0, 1)), height=6.0, values=True)
    img = r.render_slice(((0, 0, 0), (0, 0, 1)), height=6.0)
    outside = np.isnan(v)
    assert 0.1 < outside.mean() < 0.95
    assert np.all(img[outside] == 0) and np.all(img[~outside][..., 3] > 0)


def test_slice_planes_in_the_view_are_opaque_and_depth_correct():
    # A homogeneous box with an opaque slice x = 0.1 across it: the volume in
    # front of the slice over the slice's own colour (the transfer function's
    # at the box's value), the rest of the box as it was.
    camera = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, roll=0.0,
                                   distance=2.5)
    a = 0.01
    r = VolumeRenderer(W, H, config=RenderConfig(step_size=0.01, max_steps=10_000, early_ray_termination=False),
                       light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((8, 8, 8), 0.5, np.float32)))
    r.set_camera(camera)
    r.set_transfer_functions(ColorTransferFunction.single_color(COLOR), OpacityTransferFunction.linear(a, a))
    img = r.render(dtype=np.float32, premultiplied=True, slices=[((0.1, 0, 0), (1, 0, 0))])
    o, d, t0, t1 = rays(camera, np.full(3, -0.5), np.full(3, 0.5), W, H)
    tp = (0.1 - o[0]) / d[..., 0]
    hit = o + d * tp[..., None]
    on = (tp > 0) & np.all(np.abs(hit) <= 0.5, axis=-1)
    L = np.nan_to_num(np.clip(np.where(on, tp, t1) - t0, 0, None))
    a_v = 1 - np.exp(-np.float64(np.float32(a)) * L / 0.01)
    want_rgb = np.asarray(COLOR) * a_v[..., None] + np.where(on[..., None], (1 - a_v[..., None]) * np.asarray(COLOR), 0)
    assert 0.1 < on.mean() < 0.9
    assert np.abs(img[..., :3] - want_rgb).max() < 0.5 / 255
    assert np.abs(img[..., 3] - np.where(on, 1.0, a_v)).max() < 0.5 / 255
    # With a scene given too, the nearer surface shows: a wall just in front
    # of the camera hides the slice.
    near = r.render(dtype=np.float32, premultiplied=True, slices=[((0.1, 0, 0), (1, 0, 0))],
                    depth=np.full((H, W), 0.5), color=np.zeros((H, W, 3)))
    assert np.all(near[..., 3] == 1) and near[..., :3].max() == 0


@pytest.mark.parametrize(("kw", "exc", "message"), [
    ({"plane": [((0, 0, 0), (1, 0, 0))] * 2}, ValueError, "plane must be one"),
    ({"plane": ((0, 0, 0), (0, 0, 0))}, ValueError, "normal must not be zero"),
    ({"plane": ((0, 0, 0), (1, 0, 0)), "height": -1.0}, ValueError, "height must be a finite number > 0"),
    ({"plane": ((0, 0, 0), (1, 0, 0)), "up": (2, 0, 0)}, ValueError, "parallel to the plane's normal"),
])
def test_bad_slices_are_refused(kw, exc, message):
    r = renderer(linear_volume())
    with pytest.raises(exc, match=message):
        r.render_slice(**kw)
