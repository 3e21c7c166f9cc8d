"""Exact filtering (RenderConfig.exact_filtering): the shader interpolates the
volume (trilinear) and the transfer function's and pre-integration tables
(linear, bilinear) with f32 weights instead of through the sampler.

Why: GPUs' texture units weigh texels in fixed point with 8 fractional bits.
On an H200 (benches/filtering.py) that rounding left the helix's step
transfer function at 3.7 levels where a 1-level target was asked. Here the
adapter is lavapipe, whose sampler weighs in f32, so both paths must agree
with each other and with the float64 integrator (its own code): a lookup
off by half a texel or a wrong clamp at the table's edge would not.
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, accuracy
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

LEVELS = 255.0


def scene(kind):
    """A steep transfer function over a small volume: the helix's step
    (lit from the data's gradient, seven fetches a sample) or the torus's
    narrow peaks with normals (each texel holds value and normal)."""
    if kind == "helix step":
        r = VolumeRenderer(48, 48, light=Light.default())
        r.load_volume(Volume(create_sample_volume(40, "helix")))
        otf = OpacityTransferFunction.one_step(0.5, 0.0, 0.6)
    else:
        r = VolumeRenderer(48, 48, light=Light.default())
        d = create_sample_volume(40, "torus")
        r.load_volume(Volume(d, compute_normal_volume(d)), precision="float32")
        otf = OpacityTransferFunction.peaks([0.25, 0.5, 0.75], opacity=0.6, eps=0.02)
    r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), otf)
    return r


def levels(a, b):
    return float(np.abs(np.asarray(a, np.float64) - b).max() * LEVELS)


@pytest.mark.texture_units
@pytest.mark.parametrize("kind", ["helix step", "torus peaks with normals"])
@pytest.mark.parametrize("pre", [False, True], ids=["midpoint", "pre-integrated"])
@pytest.mark.shader
def test_exact_filtering_matches_the_f64_integrator_and_the_sampler(kind, pre):
    # Measured against the f64 integrator on lavapipe: 0.003 and 0.03 level
    # midpoint; 0.12 and 0.46 pre-integrated, the same as the sampler's
    # frames (the table's own resolution). Against the sampler's frame:
    # under 0.0005 level (lavapipe weighs in f32).
    r = scene(kind)
    r.native_march = False  # the shader's path: the native march is always exact
    steps = int(np.ceil(accuracy.longest_chord(r) / 0.01)) + 2
    cfg = RenderConfig(step_size=0.01, max_steps=steps, early_ray_termination=False, pre_integrated=pre)
    frames = {}
    for exact in (False, True):
        r.set_config(cfg.replace(exact_filtering=exact))
        frames[exact] = r.render(dtype=np.float32, premultiplied=True)
        assert r.last_frame_stats["engine"] == "gpu"
    ref = r.render_float64(config=cfg, premultiplied=True)
    assert ref[..., 3].max() > 0.3
    assert levels(frames[True], ref) < (0.6 if pre else 0.1)
    if device_limits()["cpu_device"]:
        assert levels(frames[True], frames[False]) < 0.01
    else:  # texture units weigh in 8-bit fixed point: exact is the closer
        assert levels(frames[True], ref) <= levels(frames[False], ref) + 0.01


def test_exact_filtering_is_a_config_field_that_survives_copies():
    import pickle

    cfg = RenderConfig.balanced().replace(exact_filtering=True)
    assert pickle.loads(pickle.dumps(cfg)).exact_filtering
    assert cfg.copy().exact_filtering
    assert not RenderConfig.balanced().exact_filtering
    with pytest.raises(TypeError, match="exact_filtering"):
        RenderConfig.balanced().replace(exact_filtering="yes please")


def test_config_for_error_filters_exactly_on_gpus_only():
    r = scene("helix step")
    cfg, _ = accuracy.config_for_error(r, 4.0)
    assert cfg.exact_filtering == (not device_limits()["cpu_device"])
