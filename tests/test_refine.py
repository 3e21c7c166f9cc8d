"""Refined pre-integrated segments (RenderConfig.refine).

Rule (compositing.wgsl `needs_refining`, the f64 integrator's
`reaches_unseen_opacity`): trilinear values change along a ray by at most
l per unit length (the voxels' largest neighbour differences per axis times
the voxels crossed), so a full segment from vf to vb stays within
(vf + vb -/+ l h) / 2; where the table's opacity changes by more than 1/64
over that range the segment is taken as `refine` midpoint samples instead
of its (front, back) ramp. Checked against the f64 integrator (same rule,
its own code), against a converged image, and for what it costs.

Scene: a thin helix under a step transfer function (opacity 0 below 0.5,
0.6 above), where a ramp between two samples below the threshold misses
the tube a grazing ray crosses between them.
"""

import warnings

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, accuracy
from pyvr.camera import Camera
from pyvr.datasets import create_sample_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.renderer import device_limits
from pyvr.volume import Volume

LEVELS = 255.0
NATIVE = pytest.mark.skipif(not device_limits()["native_march"],
                            reason="the native march runs only where the adapter is a CPU with AVX2, FMA and F16C")


def helix_scene(lit=False):
    r = VolumeRenderer(48, 48, light=Light.default() if lit else Light.ambient_only(1.0))
    r.load_volume(Volume(create_sample_volume(40, "helix")))
    r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                             OpacityTransferFunction.one_step(0.5, 0.0, 0.6))
    return r


def config(r, h, refine, order="front_to_back"):
    steps = int(np.ceil(accuracy.longest_chord(r) / h)) + 2
    return RenderConfig(step_size=h, max_steps=steps, early_ray_termination=False, pre_integrated=True,
                        refine=refine, order=order)


def gpu(r, cfg):
    # The shader's frame: refined ones are only the shader's, and some
    # tests compare them bit for bit with unrefined ones.
    r.native_march = False
    r.set_config(cfg)
    return r.render(dtype=np.float32, premultiplied=True), r.last_frame_stats["samples"]


def levels(a, b):
    return float(np.abs(np.asarray(a, np.float64) - b).max() * LEVELS)


@pytest.mark.parametrize("lit", [False, True])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("h", [0.02, 0.01])
def test_refined_frames_match_the_f64_integrator(lit, order, h):
    # Measured: 0.01-0.03 level (the two decide each segment's refinement
    # in f32 and f64; a segment decided differently would cost levels).
    r = helix_scene(lit)
    cfg = config(r, h, 8, order)
    img, _ = gpu(r, cfg)
    ref = r.render_float64(config=cfg, premultiplied=True)
    assert levels(img, ref) < 0.25


@pytest.mark.parametrize("lut_size", [1024, 4096])
@pytest.mark.parametrize("native", [pytest.param(False, marks=pytest.mark.shader), pytest.param(True, marks=NATIVE)])
def test_refined_frames_of_a_long_transfer_function_match_the_f64_integrator(lut_size, native):
    # Longer than the table's 512 entries, the running opacity sums the rule
    # reads, and the transfer function shorter segments read, are wrapped
    # into rows of the table's width (3 rows at 1024 entries, 9 at 4096).
    # The step at 0.5 falls where the first row ends at 1024 entries.
    r = helix_scene()
    ctf, otf = ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.one_step(0.5, 0.0, 0.6)
    ctf.lut_size = otf.lut_size = lut_size
    r.set_transfer_functions(ctf, otf)
    cfg = config(r, 0.01, 8)
    r.native_march = native
    r.set_config(cfg)
    img = r.render(dtype=np.float32, premultiplied=True)
    assert r.last_frame_stats["engine"] == ("native" if native else "gpu")
    ref = r.render_float64(config=cfg, premultiplied=True)
    assert ref[..., 3].max() > 0.5
    assert levels(img, ref) < 0.25


def test_refinement_finds_what_the_ramp_misses_for_few_samples_more():
    # Measured at step 0.01: 11.8 levels unrefined, 3.2 refined, for 5% more
    # samples (only segments near the threshold are refined).
    r = helix_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        converged, info = accuracy.converged_image(r, max_halvings=5)
    assert info["estimated_max_error"] < 0.1
    plain, n_plain = gpu(r, config(r, 0.01, 0))
    refined, n_refined = gpu(r, config(r, 0.01, 8))
    e_plain, e_refined = levels(plain, converged), levels(refined, converged)
    assert e_plain > 8.0, e_plain
    assert e_refined < 0.4 * e_plain and e_refined < 5.0, (e_plain, e_refined)
    assert n_refined < 1.2 * n_plain, (n_plain, n_refined)


def test_a_transfer_function_without_opacity_changes_refines_nothing():
    r = helix_scene()
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.3, 0.3))
    plain, n_plain = gpu(r, config(r, 0.01, 0))
    refined, n_refined = gpu(r, config(r, 0.01, 16))
    assert n_refined == n_plain
    assert levels(plain, refined) == 0.0


def test_refine_is_ignored_without_pre_integration():
    r = helix_scene()
    base = config(r, 0.02, 0).replace(pre_integrated=False)
    a, _ = gpu(r, base)
    b, _ = gpu(r, base.replace(refine=8))
    assert levels(a, b) == 0.0


@pytest.mark.parametrize("bad", [1, -2, 17, 100])
def test_refine_out_of_range_is_a_value_error(bad):
    with pytest.raises(ValueError, match="refine must be 0 .off. or 2..=16"):
        RenderConfig(pre_integrated=True, refine=bad)


def test_refine_must_be_an_integer():
    with pytest.raises(TypeError, match="refine"):
        RenderConfig(pre_integrated=True, refine=2.5)


def test_refine_round_trips_through_replace_and_pickle():
    import pickle

    cfg = RenderConfig(pre_integrated=True, refine=4)
    assert cfg.refine == 4 and cfg.replace(step_size=0.02).refine == 4
    assert pickle.loads(pickle.dumps(cfg)) == cfg
    assert cfg != cfg.replace(refine=0)


def test_bricked_refined_frames_equal_one_texture():
    # Each brick measures its own slopes (ghost voxels included), which
    # bound its values as the volume's do; measured 0.001 level apart.
    frames = []
    for kw in ({}, {"brick_shape": (16, 16, 16)}):
        r = VolumeRenderer(48, 48, light=Light.ambient_only(1.0), **kw)
        r.load_volume(Volume(create_sample_volume(40, "helix")))
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                 OpacityTransferFunction.one_step(0.5, 0.0, 0.6))
        frames.append(gpu(r, config(r, 0.01, 8))[0])
    assert r.bricks["count"] == 27
    assert levels(frames[0], frames[1]) < 0.05
