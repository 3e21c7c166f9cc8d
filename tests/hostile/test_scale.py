"""Scale: the engine normalises world coordinates to the volume's box in
float64 before anything reaches float32, so scaling a whole scene (box,
camera distance, step sizes, light positions) by 1e-30 .. 1e30 gives the
same image, and far lights and cameras keep their directions."""

import warnings

import numpy as np
import pytest

from pyvr import RenderConfig
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.volume import Volume
from scenes import blob, frame, make_renderer

SCALES = [1e-30, 1e-19, 1e-6, 1e6, 1e19, 1e30]


def scene(s, light_kind="directional"):
    data = blob((24, 20, 16), width=0.6)
    vol = Volume(data, min_bounds=np.array([-1.0, -0.8, -0.6]) * s, max_bounds=np.array([1.0, 0.8, 0.6]) * s)
    if light_kind == "point":
        light = Light.point_light(np.array([2.0, 1.5, 1.0]) * s)
    else:
        light = Light.directional([1, -1, 0.5])
    cam = Camera.from_spherical(target=np.zeros(3), distance=3.0 * s, azimuth=0.5, elevation=0.3, roll=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "step_size is very large" at s > 1
        cfg = RenderConfig(step_size=0.02 * s, max_steps=400, reference_step_size=0.01 * s)
        r = make_renderer(vol, config=cfg, light=light, camera=cam)
        return frame(r), r


@pytest.mark.parametrize("s", SCALES)
@pytest.mark.parametrize("light_kind", ["directional", "point"])
def test_scaling_the_scene_keeps_the_image(s, light_kind):
    ref, _ = scene(1.0, light_kind)
    img, _ = scene(s, light_kind)
    assert ref[..., 3].max() > 0.3  # something is drawn
    # Positions reach f32 as the same fractions of the box: rounding only.
    assert np.abs(img - ref).max() < 1.5 / 255


@pytest.mark.parametrize("s", [1e-30, 1e30])
def test_scaled_isosurface_depth_is_in_world_units(s):
    cfg = lambda k: RenderConfig(step_size=0.02 * k, max_steps=400, reference_step_size=0.01 * k).replace(
        model="isosurface", iso_value=0.5)
    data = blob((24, 24, 24), width=0.6)
    depths = []
    warnings.simplefilter("ignore")
    for k in (1.0, s):
        vol = Volume(data, min_bounds=np.full(3, -k), max_bounds=np.full(3, k))
        r = make_renderer(vol, config=cfg(k), camera=Camera.front_view(distance=3.0 * k))
        frame(r)
        depths.append(r.depth() / k)
    hit = np.isfinite(depths[0])
    assert hit.mean() > 0.05 and np.array_equal(hit, np.isfinite(depths[1]))
    assert np.abs(depths[0][hit] - depths[1][hit]).max() < 1e-5


def test_a_point_light_far_away_lights_like_a_directional_one():
    # 3e19 from a unit box: its squared distance overflows float32.
    data = blob((24, 24, 24), width=0.6)
    far = frame(make_renderer(Volume(data), light=Light.point_light([3e19, -3e19, 1.5e19])))
    directional = frame(make_renderer(Volume(data), light=Light.directional([-2, 2, -1])))
    assert np.abs(far - directional).max() < 1.5 / 255


def test_a_tiny_reference_step_saturates_opacity_as_in_f64():
    data = blob((16, 16, 16), width=0.6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = make_renderer(Volume(data), config=RenderConfig(reference_step_size=1e-300))
        gpu = frame(r)
        ref = r.render_float64(premultiplied=True)
    assert np.abs(gpu - ref).max() < 2.5 / 255
    assert gpu[..., 3].max() > 0.99  # every sample with any opacity is opaque


def test_camera_far_away_keeps_its_elevation():
    for d in (1e-30, 1.0, 1e30):
        c = Camera.from_spherical(target=np.zeros(3), distance=d, azimuth=0.3, elevation=0.4, roll=0.0)
        p, up = c.get_camera_vectors()
        assert np.allclose(p / d, [0.87992318, 0.27219214, 0.38941834], atol=1e-7)
        assert np.allclose(up, [-0.37202555, -0.11508099, 0.92106099], atol=1e-7)
