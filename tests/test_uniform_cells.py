"""Uniform runs: where every sample in a cube of occupancy cells takes one
colour and opacity (a constant region, or values where the transfer function
is flat), unlit Beer-Lambert frames composite a ray's run through the cube as
one segment k steps long. In exact arithmetic that is the sum of its k
midpoint segments, so images equal the frames marched one segment at a time
(empty_space_skipping off) to f32 rounding, while the samples fall;
pre-integrated frames too."""

import numpy as np
import pytest

from scenes import frame, make_renderer
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

# In [0, 1] units: 0.02 of a level, and 1e-5 of emission sums (unbounded:
# a run adds one term where the march adds k). Measured up to 0.002 levels,
# 0.023 on emission sums up to 20; a run's opacity or colour off by one
# segment's share is a level or more.
TOL = 0.02 / 255


def close(a, b):
    return bool(np.all(np.abs(a - b) <= TOL + 1e-5 * np.abs(a)))
AMBIENT = Light.ambient_only(1.0)


def labels():
    """A label map (uint8) in which every label, background included, shows:
    no cell is empty, so only uniform runs can save samples."""
    lab = np.zeros((96, 80, 88), np.uint8)
    lab[16:60, 10:70, 20:80] = 80
    lab[40:88, 24:60, 8:48] = 160
    lab[60:80, 50:76, 40:84] = 255
    ctf = ColorTransferFunction([(0.0, (0.2, 0.3, 0.9)), (0.33, (0.9, 0.2, 0.1)), (0.66, (0.1, 0.8, 0.2)),
                                 (1.0, (1.0, 1.0, 0.6))])
    otf = OpacityTransferFunction([(0.0, 0.02), (0.33, 0.3), (0.66, 0.08), (1.0, 0.6)])
    return Volume(lab, None, np.array([-1.0, -0.8, -0.9], np.float32), np.array([1.0, 0.8, 0.9], np.float32)), ctf, otf


def plateau():
    """A smooth field in [0.2, 1] under a transfer function flat above 0.45:
    a cell is uniform where all its values lie on the flat part."""
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, 72)] * 3, indexing="ij")
    data = (0.6 + 0.4 * np.sin(3 * x) * np.sin(2 * y) * np.cos(2.5 * z)).astype(np.float32)
    ctf = ColorTransferFunction([(0.0, (0.0, 0.0, 1.0)), (0.45, (1.0, 0.5, 0.0)), (1.0, (1.0, 0.5, 0.0))])
    otf = OpacityTransferFunction([(0.0, 0.0), (0.2, 0.0), (0.45, 0.2), (1.0, 0.2)])
    return Volume(data), ctf, otf


SCENES = {"labels": labels, "plateau": plateau}


def pair(make, light=AMBIENT, **cfg):
    """Frames and samples marched one segment at a time, then with leaps."""
    vol, ctf, otf = make()
    config = RenderConfig(step_size=0.01, max_steps=2000, **cfg)
    out = []
    for skip in (False, True):
        r = make_renderer(vol, size=(64, 56), config=config, light=light, ctf=ctf, otf=otf, skip=skip,
                          camera=Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.6, elevation=0.35,
                                                       roll=0.0, distance=3.0))
        out.append((frame(r), r.last_frame_stats["samples"], r))
    return out


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("model", ["emission_absorption", "absorption", "emission", "single_scattering"])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_uniform_runs_keep_the_image(name, model, order):
    (plain, n_plain, _), (leapt, n_leapt, r) = pair(SCENES[name], model=model, order=order,
                                                    early_ray_termination=False)
    assert r.uniform_fraction() > 0.25
    assert plain.max() > 0.2
    err = np.abs(plain - leapt).max()
    print(f"{name} {model} {order}: uniform {r.uniform_fraction():.2f}, samples {n_plain} -> {n_leapt}, "
          f"max diff {err * 255:.4f} levels of {plain.max():.3g}")
    assert close(plain, leapt)
    # Runs through cubes of uniform cells, at least a few cells long, are
    # one sample each.
    assert n_leapt < 0.7 * n_plain


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("threshold", [0.0, 0.5, 0.95])
def test_a_run_stops_where_early_termination_would(name, threshold):
    # Opacity 8x the scene's: most rays stop inside a run, at the segment
    # where marching one at a time would.
    (plain, _, _), (leapt, _, _) = pair(lambda: boosted(SCENES[name]), early_ray_termination=True,
                                        opacity_threshold=threshold)
    assert close(plain, leapt)


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_pre_integrated_frames_take_runs_too(name, order):
    # Cells are judged over the values of every segment centred in them, so
    # a run's segments read the table's entry of one value at both ends.
    (plain, n_plain, _), (leapt, n_leapt, r) = pair(SCENES[name], pre_integrated=True, order=order)
    assert r.uniform_fraction() > 0.25
    assert close(plain, leapt)
    assert n_leapt < 0.7 * n_plain, (n_plain, n_leapt)


def boosted(make):
    vol, ctf, otf = make()
    return vol, ctf, OpacityTransferFunction([(x, min(8 * a, 1.0)) for x, a in otf.control_points])


def test_jittered_frames_take_runs_too():
    (plain, n_plain, _), (leapt, n_leapt, _) = pair(labels, jitter=True, jitter_seed=7)
    assert close(plain, leapt)
    assert n_leapt < 0.7 * n_plain


def test_lit_frames_and_nan_volumes_march_every_segment():
    # Lit: the light follows each sample's gradient (noise of a few ulps in
    # a constant region would be a full normal), so no run is composited.
    (plain, n_plain, _), (leapt, n_leapt, r) = pair(labels, light=Light.default())
    assert r.uniform_fraction() > 0.25 and n_leapt == n_plain
    assert close(plain, leapt)
    # A NaN voxel: ranges ignore NaN, so no cell counts as uniform.
    def with_nan():
        vol, ctf, otf = plateau()
        data = vol.data.copy()
        data[40, 30, 20] = np.nan
        return Volume(data), ctf, otf
    (plain, _, _), (leapt, _, r) = pair(with_nan)
    assert r.uniform_fraction() == 0.0
    assert close(plain, leapt)


@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_bricks_take_runs_within_their_own_segments(order):
    # Each brick's cells come from its own voxels (ghosts included), and a
    # run ends where the brick's window of segments does.
    vol, ctf, otf = labels()
    cfg = RenderConfig(step_size=0.01, max_steps=2000, order=order)
    out = []
    for skip, bricks in ((False, None), (True, (40, 36, 30))):
        r = VolumeRenderer(64, 56, config=cfg, light=AMBIENT, brick_shape=bricks)
        r.empty_space_skipping = skip
        r.load_volume(vol)
        r.set_camera(Camera.from_spherical(np.zeros(3), 0.6, 0.35, 0.0, 3.0))
        r.set_transfer_functions(ctf, otf)
        out.append((frame(r), r.last_frame_stats["samples"], r))
    (plain, n_plain, _), (leapt, n_leapt, r) = out
    assert r.bricks["count"] == 3 * 3 * 3
    assert close(plain, leapt)
    assert n_leapt < 0.8 * n_plain, (n_plain, n_leapt)


def test_the_switch_turns_runs_off_alone():
    # The label map has no empty cell: without runs every segment is marched.
    (plain, n_plain, r), _ = pair(labels)
    r.empty_space_skipping = True
    r.uniform_runs = False
    assert close(plain, frame(r)) and r.last_frame_stats["samples"] == n_plain
    r.uniform_runs = True
    assert r.uniform_runs and r.last_frame_stats["samples"] == n_plain
    frame(r)
    assert r.last_frame_stats["samples"] < 0.7 * n_plain
