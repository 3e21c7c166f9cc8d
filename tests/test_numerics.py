"""Numerics at the extremes: step sizes, opacities, thresholds, data values,
shapes and image sizes. Each case compares with a closed form or states the
rule it checks; tolerances are one 8-bit level unless said otherwise."""

import warnings

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, _core
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

LEVEL = 1 / 255


def f32(*v):
    return np.array(v, dtype=np.float32)


def slab_alpha(step, ref, a_tf, max_steps=None, size=3, correction="exponential", early=False, threshold=1.0,
               data=None, bounds=(-0.5, 0.5)):
    """Centre-pixel straight RGBA through a constant unit cube viewed along -x
    (odd image size: the centre ray is exactly axis-parallel, chord 1)."""
    if max_steps is None:
        max_steps = int(np.ceil((bounds[1] - bounds[0]) / step)) + 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "very large" warnings are expected here
        cfg = RenderConfig(step_size=step, max_steps=max_steps, early_ray_termination=early,
                           opacity_threshold=threshold, reference_step_size=ref, opacity_correction=correction)
        vol = Volume(np.full((4, 4, 4), 0.5, np.float32) if data is None else data, None,
                     np.full(3, bounds[0], np.float32), np.full(3, bounds[1], np.float32))
        r = VolumeRenderer(size, size, config=cfg, light=Light.ambient_only(1.0))
        r.load_volume(vol)
        r.set_camera(Camera.front_view(distance=3.0 * (bounds[1] - bounds[0])))
        r.set_transfer_functions(ColorTransferFunction.single_color((0.8, 0.6, 0.4)),
                                 OpacityTransferFunction.linear(a_tf, a_tf))
        img = r.render(dtype=np.float32)
    return img[size // 2, size // 2]


@pytest.mark.parametrize("step", [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1, 0.37, 1.0, 10.0])
def test_slab_opacity_does_not_depend_on_step(step):
    a = np.float64(np.float32(0.005))
    px = slab_alpha(step, 0.01, 0.005)
    assert px[3] == pytest.approx(1 - np.exp(-a / 0.01), abs=LEVEL)
    assert px[0] == pytest.approx(0.8, abs=LEVEL)


@pytest.mark.parametrize("ref", [1e-6, 1e-4, 1e-2, 1.0, 10.0])
@pytest.mark.parametrize("step", [1e-4, 1e-2, 1.0])
def test_reference_step_and_ratio_extremes(ref, step):
    # Step/ref ratios from 1e-5 to 1e6; a_tf chosen so the slab is semi-transparent
    # where possible (a_tf <= 1), opaque otherwise.
    a = min(1.0, 0.7 * ref)
    a32 = np.float64(np.float32(a))
    px = slab_alpha(step, ref, a)
    assert np.isfinite(px).all()
    assert px[3] == pytest.approx(1 - np.exp(-a32 / ref), abs=LEVEL)


def test_a_million_tiny_contributions_are_not_lost():
    # Each step adds optical depth 1e-4 * 1e-6 / 0.01 = 1e-8, below f32's
    # half-ulp of 1: a running product of (1 - alpha) would stay at 1.
    a = np.float64(np.float32(1e-4))
    px = slab_alpha(1e-6, 0.01, 1e-4)
    expect = 1 - np.exp(-a / 0.01)
    assert expect * 255 > 2.5
    assert px[3] == pytest.approx(expect, abs=0.25 * LEVEL)


def test_power_form_extremes():
    assert slab_alpha(0.01, 0.01, 1.0, correction="power")[3] == 1.0
    px = slab_alpha(1e-5, 0.01, 1e-5, correction="power")
    a = np.float64(np.float32(1e-5))
    assert px[3] == pytest.approx(1 - (1 - a) ** 100, abs=0.25 * LEVEL)


def test_opacity_zero_and_one():
    zero = slab_alpha(0.01, 0.01, 0.0)
    assert zero.tolist() == [0.0, 0.0, 0.0, 0.0]
    one = slab_alpha(0.01, 1e-6, 1.0)  # corrected alpha rounds to 1 in f32
    assert one[3] == 1.0 and one[0] == pytest.approx(0.8, abs=1e-6)


def test_threshold_extremes():
    # threshold 0: stop at the first non-empty sample -> one segment's alpha.
    first = slab_alpha(0.1, 0.01, 0.005, early=True, threshold=0.0)
    assert first[3] == pytest.approx(1 - np.exp(-np.float32(0.005) * 0.1 / 0.01), abs=1e-6)
    full = slab_alpha(0.01, 0.01, 0.005, early=True, threshold=1.0)
    assert full[3] == pytest.approx(1 - np.exp(-np.float32(0.005) / 0.01), abs=LEVEL)
    half = slab_alpha(0.001, 0.01, 0.5, early=True, threshold=0.5)
    assert 0.5 <= half[3] < 0.5 + 0.05


def test_max_steps_one_and_truncation():
    px = slab_alpha(0.01, 0.01, 0.5, max_steps=1)
    assert px[3] == pytest.approx(1 - np.exp(-np.float32(0.5) * 0.01 / 0.01), abs=1e-6)
    r = VolumeRenderer(3, 3, config=RenderConfig(max_steps=1, early_ray_termination=False))
    r.load_volume(Volume(np.full((4, 4, 4), 0.5, np.float32)))
    r.set_camera(Camera.front_view())
    with pytest.warns(UserWarning, match="max_steps=1 cannot cross .* max_steps=100 would"):
        r.render()


@pytest.mark.parametrize("value,expect_alpha", [
    (np.nan, 0.0),            # NaN voxels are empty
    (np.inf, 1.0),            # +Inf clamps to the TF's top (opacity 1 here)
    (-np.inf, 0.0),           # -Inf clamps to the bottom (opacity 0)
    (1e30, 1.0),
    (-5.0, 0.0),
    (7.0, 1.0),
    (1e-40, 0.0),             # denormal: ~0
])
def test_data_values(value, expect_alpha):
    data = np.full((3, 3, 3), value, np.float32)
    cfg_alpha = 1 - np.exp(-expect_alpha * 1.0 / 0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        vol = Volume(data)
        r = VolumeRenderer(3, 3, config=RenderConfig(early_ray_termination=False), light=Light.ambient_only(1.0))
        r.load_volume(vol)
        r.set_camera(Camera.front_view())
        r.set_transfer_functions(ColorTransferFunction.grayscale(), OpacityTransferFunction.linear(0.0, 1.0))
        img = r.render(dtype=np.float32, premultiplied=True)
    assert np.isfinite(img).all()
    assert img[1, 1, 3] == pytest.approx(cfg_alpha, abs=LEVEL)


@pytest.mark.parametrize("shape", [(1, 1, 1), (1, 7, 1), (2, 2, 2), (64, 64, 1), (1, 1, 300)])
def test_degenerate_shapes_render_constant_data_exactly(shape):
    px = slab_alpha(0.01, 0.01, 0.005, data=np.full(shape, 0.5, np.float32))
    assert px[3] == pytest.approx(1 - np.exp(-np.float64(np.float32(0.005)) / 0.01), abs=LEVEL)


def test_axis_over_the_3d_texture_limit_renders_in_bricks():
    # A constant field looks the same at any resolution: one voxel more than
    # the device's 3-D texture holds must render the image of the limit.
    limit = _core.device_limits()["max_texture_dimension_3d"]
    images = []
    for n in (limit, limit + 1):
        r = VolumeRenderer(8, 8)
        r.load_volume(Volume(np.full((n, 1, 1), 0.5, np.float32)))
        assert (r.bricks is None) == (n == limit)
        images.append(r.render(dtype=np.float32))
    assert images[0][..., 3].max() > 0.5
    assert np.abs(images[0] - images[1]).max() < 1e-4


@pytest.mark.parametrize("lo,hi", [(-5e-7, 5e-7), (-5e5, 5e5)])
def test_tiny_and_huge_bounds(lo, hi):
    width = hi - lo
    step = width / 200
    ref = width / 100
    px = slab_alpha(step, ref, 0.005, bounds=(lo, hi))
    assert px[3] == pytest.approx(1 - np.exp(-np.float64(np.float32(0.005)) * width / ref), abs=LEVEL)


@pytest.mark.parametrize("w,h", [(1, 1), (1, 4096), (4096, 1)])
def test_extreme_image_shapes(w, h):
    r = VolumeRenderer(w, h, config=RenderConfig(), light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((2, 2, 2), 0.5, np.float32)))
    r.set_camera(Camera(distance=0.6))  # close: the box spans several pixels of the thin side
    img = r.render()
    assert img.shape == (h, w, 4)
    assert img[..., 3].max() > 0


def test_largest_image_and_one_past_it():
    max_px = _core.device_limits()["max_image_pixels"]
    side = int(np.sqrt(max_px))
    with pytest.raises(ValueError, match="limit"):
        VolumeRenderer(side + 1, side + 1)
    r = VolumeRenderer(side, 8, light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((2, 2, 2), 0.5, np.float32)))
    r.set_camera(Camera.front_view())
    assert r.render().shape == (8, side, 4)


@pytest.mark.shader
def test_long_rays_are_marched_in_several_passes():
    # 1e5 steps per ray: more than one dispatch's 16384 steps and more than
    # lavapipe's 65535-iteration loop cap; the passes must join seamlessly.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = RenderConfig(step_size=1e-5, max_steps=200_000, early_ray_termination=False)
    r = VolumeRenderer(5, 5, config=cfg, light=Light.ambient_only(1.0))
    r.native_march = False  # passes are the shader's (the native march needs none)
    r.load_volume(Volume(np.full((4, 4, 4), 0.5, np.float32)))
    r.set_camera(Camera.front_view())
    r.set_transfer_functions(ColorTransferFunction.single_color((0.8, 0.6, 0.4)),
                             OpacityTransferFunction.linear(0.005, 0.005))
    img = r.render(dtype=np.float32)
    assert r.last_frame_stats["passes"] >= 7
    assert img[2, 2, 3] == pytest.approx(1 - np.exp(-np.float64(np.float32(0.005)) / 0.01), abs=1e-4)
    assert img[2, 2, 0] == pytest.approx(0.8, abs=1e-4)
    one = VolumeRenderer(5, 5, config=RenderConfig(), light=Light.ambient_only(1.0))
    one.load_volume(Volume(np.full((4, 4, 4), 0.5, np.float32)))
    one.set_camera(Camera.front_view())
    one.render()
    assert one.last_frame_stats["passes"] == 1


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "int16", "int32", "float16", "float32", "float64", "bool"])
@pytest.mark.parametrize("layout", ["C", "F", "strided"])
def test_every_dtype_and_layout_matches_the_float64_integrator(dtype, layout):
    rng = np.random.default_rng(7)
    base = rng.random((10, 8, 6))
    if dtype == "bool":
        data = base > 0.5
    elif dtype.startswith("uint"):
        data = (base * np.iinfo(dtype).max).astype(dtype)
    elif dtype.startswith("int"):
        data = (base * 3 - 1).round().astype(dtype)  # raw values -1..2: outside [0, 1] clamp
    else:
        data = base.astype(dtype)
    if layout == "F":
        data = np.asfortranarray(data)
    elif layout == "strided":
        big = np.zeros((20,) + data.shape[1:], dtype)
        big[::2] = data
        data = big[::2]
    before = data.copy()
    r = VolumeRenderer(16, 12, config=RenderConfig(step_size=0.02), light=Light.default())
    r.load_volume(Volume(data))
    r.set_camera(Camera.isometric_view(distance=2.5))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0, 0.3))
    gpu = r.render(dtype=np.float32, premultiplied=True)
    ref = r.render_float64(premultiplied=True)
    assert np.array_equal(data, before)
    assert ref[..., 3].max() > 0.2
    assert np.abs(gpu - ref).max() < 1.5 * LEVEL


def test_anisotropic_bounds_1000_to_1():
    # A 1000 x 1 x 1 box seen end-on: the centre ray's chord is 1000 long.
    px = slab_alpha(2.0, 500.0, 0.3, bounds=(-500.0, 500.0), data=np.full((4, 2, 2), 0.5, np.float32))
    assert px[3] == pytest.approx(1 - np.exp(-np.float64(np.float32(0.3)) * 1000 / 500), abs=LEVEL)
    vol = Volume(np.full((4, 4, 4), 0.5, np.float32), None, f32(-500, -0.5, -0.5), f32(500, 0.5, 0.5))
    r = VolumeRenderer(9, 9, config=RenderConfig(step_size=0.5, max_steps=5000, early_ray_termination=False),
                       light=Light.ambient_only(1.0))
    r.load_volume(vol)
    r.set_camera(Camera.side_view(distance=3.0))  # across the thin side: chord 1
    r.set_transfer_functions(ColorTransferFunction.grayscale(), OpacityTransferFunction.linear(0.005, 0.005))
    img = r.render(dtype=np.float32)
    assert img[4, 4, 3] == pytest.approx(1 - np.exp(-np.float64(np.float32(0.005)) / 0.01), abs=LEVEL)


def test_ray_grazing_an_edge():
    # Pixel centres exactly on the box's edge lines: the chord there is zero
    # length or the face itself; results must be finite and match f64.
    vol = Volume(np.full((4, 4, 4), 0.5, np.float32))
    cam = Camera(azimuth=np.pi / 4, distance=3.0, fov=0.5)
    r = VolumeRenderer(33, 33, config=RenderConfig(step_size=0.01), light=Light.ambient_only(1.0))
    r.load_volume(vol)
    r.set_camera(cam)
    r.set_transfer_functions(ColorTransferFunction.grayscale(), OpacityTransferFunction.linear(0.2, 0.2))
    gpu = r.render(dtype=np.float32, premultiplied=True)
    ref = r.render_float64(premultiplied=True)
    assert np.isfinite(gpu).all()
    # A one-pixel band along the silhouette may flip between hit and miss;
    # everywhere else the GPU matches the f64 integrator.
    d = np.abs(gpu - ref)[..., 3]
    assert np.mean(d > LEVEL) < 0.05 and np.median(d) < 1e-4


@pytest.mark.parametrize("cam", [
    Camera(distance=0.5),                              # on the +x face
    Camera(azimuth=np.pi / 4, distance=np.sqrt(0.5)),  # on an edge
    Camera(distance=1e-6),                             # at the target, inside
    Camera(distance=1e-3, azimuth=0.3),                # inside, very close to the target
    Camera(fov=1e-6),
    Camera(fov=np.pi - 1e-6),
], ids=["on_face", "on_edge", "at_target", "near_target", "fov_1e-6", "fov_pi"])
def test_extreme_cameras_match_the_float64_integrator(cam):
    rng = np.random.default_rng(3)
    r = VolumeRenderer(9, 7, config=RenderConfig(step_size=0.01), light=Light.default())
    r.load_volume(Volume(rng.random((6, 6, 6), dtype=np.float32)))
    r.set_camera(cam)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0, 0.2))
    gpu = r.render(dtype=np.float32, premultiplied=True)
    ref = r.render_float64(premultiplied=True)
    assert np.isfinite(gpu).all() and gpu.min() >= 0 and gpu.max() <= 1
    assert ref[..., 3].max() > 0.1
    assert np.abs(gpu - ref).max() < 1.5 * LEVEL


def test_far_camera_is_finite_and_covers_the_right_pixels():
    # At distance 1e6, f32 ray directions (relative error ~6e-8) put rays
    # ~0.06 units off at the box: the rule is finite output and the right
    # silhouette to within that, not 8-bit agreement at the rim.
    cam = Camera(distance=1e6, fov=4e-6)
    r = VolumeRenderer(21, 21, config=RenderConfig(step_size=0.01), light=Light.ambient_only(1.0))
    r.load_volume(Volume(np.full((4, 4, 4), 0.5, np.float32)))
    r.set_camera(cam)
    r.set_transfer_functions(ColorTransferFunction.grayscale(), OpacityTransferFunction.linear(0.2, 0.2))
    gpu = r.render(dtype=np.float32, premultiplied=True)
    ref = r.render_float64(premultiplied=True)
    assert np.isfinite(gpu).all()
    assert abs((gpu[..., 3] > 0.5).sum() - (ref[..., 3] > 0.5).sum()) <= 0.2 * (ref[..., 3] > 0.5).sum()
