"""RenderConfig(unbiased=True): Poisson points composited with opacity
sigma / rate (ratio tracking), so each frame's expectation is the exact
integral and render(accumulate=n) converges to it, where jittered midpoint
frames converge to the mean over grid offsets.

Unbiasedness is tested as a statistic that bias makes grow with n: each
pixel's mean over n frames against the converged image, in units of its
standard error (its spread over the frames / sqrt(n)). Unbiased means leave
z of order 1; a bias b makes z grow as b sqrt(n) / spread. The standard
error is floored at a quarter of an 8-bit level, the f32 arithmetic and
filtered fetches GPU frames differ from the float64 integrator by: alpha
near 1 has almost no spread, and 0.1-level offsets there would dominate.
Measured on the test's scene: unbiased z 1.06 / 0.90 / 0.86 at n = 64 /
256 / 1024; the jittered midpoint frames' 3.8 / 7.1 at n = 64 / 256.
A bias of one sign shows in the mean over all pixels: -2.6 levels for the
jittered frames, 0.02 (standard error 0.03) for unbiased ones. What these
tests catch, tried on the shader: opacity 1 - exp(-sigma / rate) for
sigma / rate gives z 4.1-4.6 and a mean error of -0.8 to -1.8 levels in
every order and model it applies to; opacity 3% too high (mean error 0.1-
0.15 levels here) is within the tests' noise."""

import pickle

import numpy as np
import pytest

from pyvr import RenderConfig
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import OpacityTransferFunction
from pyvr.volume import Volume
from scenes import blob, frame, make_renderer

# A narrow TF peak at a coarse step: where midpoint frames band and their
# jittered mean keeps a bias.
CFG = RenderConfig(step_size=0.05, max_steps=400, early_ray_termination=False)
CONVERGED = RenderConfig(step_size=2e-4, max_steps=100_000, early_ray_termination=False)


@pytest.fixture(scope="module")
def r():
    return make_renderer(Volume(blob((48, 48, 48), width=0.7)), size=(48, 40), config=CFG,
                         camera=Camera.isometric_view(distance=1.5),
                         otf=OpacityTransferFunction.peaks([0.5], opacity=0.6, eps=0.03))


def exact(r, **changes):
    return r.render_float64(premultiplied=True, progress=False, config=CONVERGED.replace(**changes))


def frames(r, cfg, n):
    return np.stack([frame(r, config=cfg.replace(jitter_seed=k)) for k in range(n)]).astype(np.float64)


def global_bias(stack, reference):
    """The mean signed error over all values of the n-frame mean, and its
    standard error from the frames' spread: a bias of one sign (too much
    or too little opacity everywhere) shows here long before it does per
    pixel."""
    per_frame = (stack - reference).reshape(len(stack), -1).mean(axis=1)
    return float(per_frame.mean()), float(per_frame.std(ddof=1) / np.sqrt(len(stack)))


def assert_unbiased(stack, reference, min_live):
    z, live = z_rms(stack, reference)
    b, se = global_bias(stack, reference)
    assert live > min_live and z < 1.35, (z, live)
    # 4 standard errors, plus 0.05 level for f32 arithmetic.
    assert abs(b) < 4 * se + 0.05 / 255, (b * 255, se * 255)


def z_rms(stack, reference):
    """RMS over the values that vary of (mean - reference) / standard error."""
    spread = stack.std(axis=0, ddof=1)
    live = spread > 1e-5
    se = np.hypot(spread / np.sqrt(len(stack)), 0.25 / 255)
    z = (stack.mean(axis=0) - reference)[live] / se[live]
    return float(np.sqrt(np.mean(z**2))), int(live.sum())


def test_the_mean_of_unbiased_frames_has_no_bias(r):
    ref = exact(r)
    assert_unbiased(frames(r, CFG.replace(unbiased=True), 256), ref, 1000)
    # The jittered midpoint frames' mean, the same test: its bias shows.
    zj, _ = z_rms(frames(r, CFG.replace(jitter=True), 256), ref)
    assert zj > 4.0, zj


def test_the_error_falls_as_one_over_sqrt_n(r):
    ref = exact(r)
    u = CFG.replace(unbiased=True)
    rms = {n: np.sqrt(np.mean((frame(r, config=u, accumulate=n) - ref) ** 2)) * 255 for n in (4, 64)}
    jittered = np.sqrt(np.mean((frames(r, CFG.replace(jitter=True), 64).mean(axis=0) - ref) ** 2)) * 255
    # sqrt(64 / 4) = 4 with no floor; the jittered mean stalls at its bias.
    assert 3.2 < rms[4] / rms[64] < 5.0, rms
    assert rms[64] < 0.5 * jittered, (rms, jittered)


@pytest.mark.parametrize("changes", [
    {"order": "back_to_front"},
    {"early_ray_termination": True, "opacity_threshold": 0.6},
    {"opacity_correction": "power"},
    {"model": "absorption"},
    {"model": "emission"},
], ids=lambda c: "-".join(f"{v}" for v in c.values()))
def test_every_order_model_and_roulette_is_unbiased(r, changes):
    # Early termination becomes Russian roulette: still unbiased.
    ref_changes = {k: v for k, v in changes.items() if k not in ("early_ray_termination", "opacity_threshold")}
    assert_unbiased(frames(r, CFG.replace(unbiased=True, **changes), 128), exact(r, **ref_changes), 250)


def test_a_homogeneous_cube_has_the_closed_form_opacity():
    # A constant medium: alpha = 1 - exp(-sigma chord), which the float64
    # integrator gives exactly at any step.
    data = np.full((16, 16, 16), 0.5, np.float32)
    r = make_renderer(Volume(data), size=(32, 32), config=CFG, light=Light.ambient_only(1.0),
                      camera=Camera.isometric_view(distance=1.5), otf=OpacityTransferFunction.linear(0.2, 0.2))
    ref = r.render_float64(premultiplied=True, progress=False, config=CFG)
    assert_unbiased(frames(r, CFG.replace(unbiased=True), 128), ref, 250)


@pytest.mark.parametrize("form", ["exponential", "power"])
def test_cost_follows_the_extinction_where_rays_are(form):
    # Faint tissue around an opaque core (opacity 1: unbounded extinction in
    # the power form). One rate for the whole frame would draw 5 (exponential)
    # or 16 (power, the cap) points a step everywhere; each segment takes its
    # cell's majorant instead, and the frames stay unbiased.
    otf = OpacityTransferFunction([(0.0, 0.0), (0.3, 0.01), (0.85, 0.01), (0.9, 1.0), (1.0, 1.0)])
    r = make_renderer(Volume(blob((48, 48, 48), width=0.7)), size=(48, 40), config=CFG,
                      camera=Camera.isometric_view(distance=1.5), otf=otf)
    cfg = CFG.replace(opacity_correction=form)
    frame(r, config=cfg)
    midpoint = r.last_frame_stats["samples"]
    frame(r, config=cfg.replace(unbiased=True))
    # Measured 1.04 and 1.30 times the midpoint frame's samples.
    assert r.last_frame_stats["samples"] < 1.5 * midpoint, (r.last_frame_stats["samples"], midpoint)
    assert_unbiased(frames(r, cfg.replace(unbiased=True), 128), exact(r, opacity_correction=form), 1000)


@pytest.mark.shader
def test_leaps_and_passes_see_the_same_points():
    # A sparse scene: skipping leaps over most cells, and a small step splits
    # rays into passes; neither may change which points a frame composites.
    r = make_renderer(Volume(blob((40, 40, 40), centre=(0.3, -0.2, 0.1), width=0.35)), size=(16, 14),
                      config=CFG, camera=Camera.isometric_view(distance=1.2),
                      otf=OpacityTransferFunction.peaks([0.3], opacity=0.6, eps=0.05))
    assert r.empty_fraction() > 0.5
    for cfg in (CFG.replace(unbiased=True), CFG.replace(unbiased=True, order="back_to_front"),
                RenderConfig(step_size=1e-4, max_steps=40_000, early_ray_termination=False, unbiased=True)):
        r.empty_space_skipping = True
        skipped = frame(r, config=cfg)
        n_skipped = r.last_frame_stats["samples"]
        r.empty_space_skipping = False
        plain = frame(r, config=cfg)
        assert np.abs(skipped - plain).max() < 1e-5, np.abs(skipped - plain).max()
        assert n_skipped < 0.5 * r.last_frame_stats["samples"]
        assert plain[..., 3].max() > 0.2
    # The shader's passes (the native march takes one): leaps see the same points there too.
    r.native_march = False
    passes = [frame(r, config=cfg)]
    r.empty_space_skipping = True
    passes.append(frame(r, config=cfg))
    assert r.last_frame_stats["passes"] >= 2
    assert np.abs(passes[0] - passes[1]).max() < 1e-5
    # Rays that cross passes keep their state and their segments' points:
    # the mean of such frames has no bias either.
    ref = r.render_float64(premultiplied=True, progress=False, config=CONVERGED)
    r.empty_space_skipping = True
    assert_unbiased(frames(r, cfg, 32), ref, 80)


@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_leaps_land_before_a_hard_face(order):
    # A semi-transparent cube with hard faces near the empty cells around
    # it, met from both sides: leaps must land before its first points
    # (resuming 3 steps past the cells' far sides fails by 0.59 on 152 values;
    # the cells' aprons make resuming less than a voxel late harmless).
    data = np.zeros((48, 48, 48), np.float32)
    data[17:31, 17:31, 17:31] = 1.0
    r = make_renderer(Volume(data), size=(40, 36), config=CFG, camera=Camera.isometric_view(distance=1.5),
                      otf=OpacityTransferFunction.one_step(0.5, 0.0, 0.02))
    assert r.empty_fraction() > 0.3
    cfg = CFG.replace(unbiased=True, order=order, step_size=0.1)
    skipped = frame(r, config=cfg)
    r.empty_space_skipping = False
    plain = frame(r, config=cfg)
    # Semi-transparent (optical depth about 1 at most), so every point counts.
    assert 0.3 < plain[..., 3].max() < 0.95
    assert np.abs(skipped - plain).max() < 1e-5, np.abs(skipped - plain).max()


def test_unbiased_is_a_field_with_clear_limits():
    c = RenderConfig(unbiased=True)
    assert c.unbiased and not RenderConfig().unbiased
    assert pickle.loads(pickle.dumps(c)).unbiased
    assert c.replace(step_size=0.02).unbiased
    with pytest.raises(ValueError, match="unbiased applies to"):
        RenderConfig(unbiased=True, model="mip")
    with pytest.raises(ValueError, match="exclude each other"):
        RenderConfig(unbiased=True, pre_integrated=True)
    r = make_renderer(Volume(blob((8, 8, 8), width=0.6)), size=(8, 8))
    with pytest.raises(ValueError, match="no float64 counterpart"):
        r.render_float64(config=c)
