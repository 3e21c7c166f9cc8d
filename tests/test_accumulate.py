"""render(accumulate=n): the mean of n frames with consecutive seeds,
unbiased ones where the model has them (tests/test_unbiased.py checks that
they have no bias) and jittered ones elsewhere. The noise falls as
1/sqrt(n), and the mean lands far closer to the converged integral than the
unjittered frame at the same step."""

import numpy as np
import pytest

from pyvr import RenderConfig
from pyvr.transferfunctions import OpacityTransferFunction
from pyvr.volume import Volume
from scenes import blob, frame, make_renderer

# A narrow TF peak at a coarse step: the banding jitter exists for.
CFG = RenderConfig(step_size=0.05, max_steps=400)


@pytest.fixture(scope="module")
def r():
    return make_renderer(Volume(blob((48, 48, 48), width=0.7)), size=(48, 40), config=CFG,
                         otf=OpacityTransferFunction.peaks([0.5], opacity=0.6, eps=0.03))


UNBIASED_CFG = CFG.replace(unbiased=True)


def mean_of_seeds(r, first, n, cfg=UNBIASED_CFG):
    total = sum(frame(r, config=cfg.replace(jitter_seed=first + k)).astype(np.float64) for k in range(n))
    return (total / n).astype(np.float32)


def test_one_frame_is_the_plain_render(r):
    assert np.array_equal(frame(r, accumulate=1), frame(r))


def test_the_mean_of_frames_with_consecutive_seeds(r):
    assert np.array_equal(frame(r, accumulate=8), mean_of_seeds(r, 0, 8))
    cfg = CFG.replace(jitter_seed=77)
    assert np.array_equal(frame(r, config=cfg, accumulate=3), mean_of_seeds(r, 77, 3))
    # Pre-integrated frames and models without unbiased frames are jittered.
    for other in (CFG.replace(pre_integrated=True), CFG.replace(model="mip")):
        assert np.array_equal(frame(r, config=other, accumulate=3), mean_of_seeds(r, 0, 3, other.replace(jitter=True)))


def test_frames_add_to_the_sums_as_they_are_made_at_a_size_and_in_bricks():
    """Each frame adds its pixels to float64 sums as it is marched (or
    copied out of the GPU), at a frame size of its own too; a bricked
    volume's frames are added after they are composited. Both equal
    numpy's mean of the frames."""
    from pyvr import VolumeRenderer
    from pyvr.camera import Camera
    from pyvr.lighting import Light
    from pyvr.transferfunctions import ColorTransferFunction

    vol = Volume(blob((30, 26, 22), width=0.7))
    for options in ({}, {"brick_shape": (9, 11, 7)}):
        r = VolumeRenderer(40, 32, config=CFG, light=Light.default(), **options)
        r.load_volume(vol)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                 OpacityTransferFunction.peaks([0.5], opacity=0.6, eps=0.03))
        assert (r.bricks is not None and r.bricks["count"] > 1) == bool(options)
        for size in (None, (23, 17)):
            got = frame(r, accumulate=5, size=size)
            cfg = CFG.replace(unbiased=True)
            frames = [frame(r, config=cfg.replace(jitter_seed=k), size=size) for k in range(5)]
            want = (sum(f.astype(np.float64) for f in frames) / 5).astype(np.float32)
            assert got.shape == want.shape and np.array_equal(got, want), (options, size)
            assert np.abs(frames[0] - frames[1]).max() > 0.01 and got[..., 3].max() > 0.1


def test_noise_falls_as_one_over_sqrt_n(r):
    # Against an independent 256-frame mean: rms(n) ~ sigma * sqrt(1/n + 1/256).
    # (accumulate=1 is the plain frame, not one of these.)
    far = mean_of_seeds(r, 10_000, 256)
    rms = {n: np.sqrt(np.mean((frame(r, accumulate=n) - far) ** 2)) for n in (2, 8, 32)}
    expected = np.sqrt((1 / 2 + 1 / 256) / (1 / 32 + 1 / 256))  # 3.77
    assert 0.8 * expected < rms[2] / rms[32] < 1.2 * expected, rms
    assert rms[2] > rms[8] > rms[32]


def test_the_mean_is_closer_to_the_converged_image(r):
    exact = r.render_float64(premultiplied=True, progress=False,
                             config=RenderConfig(step_size=2e-4, max_steps=100_000, early_ray_termination=False))
    rms = lambda img: np.sqrt(np.mean((img - exact) ** 2)) * 255
    plain, mean = rms(frame(r)), rms(frame(r, accumulate=64))
    jittered = rms(mean_of_seeds(r, 0, 64, CFG.replace(jitter=True)))
    # Measured 8.6, 0.97 and 4.1 levels: the mean of jittered frames keeps a
    # bias (compositing is not linear in the grid's offset).
    assert mean < 0.2 * plain and mean < 0.5 * jittered, (plain, mean, jittered)


def test_bad_counts():
    r = make_renderer(Volume(blob((8, 8, 8), width=0.6)), size=(8, 8))
    for bad, exc in ((0, ValueError), (True, TypeError), (2.0, TypeError), (1 << 17, ValueError)):
        with pytest.raises(exc, match="accumulate"):
            r.render(accumulate=bad)
