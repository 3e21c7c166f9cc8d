"""Sort-last rendering on a dask.distributed LocalCluster (two worker
processes) from a zarr array on disk equals the single-machine render."""

import os
import signal
import time

import numpy as np
import pytest

import pyvr
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera, CameraPath
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

distributed = pytest.importorskip("distributed")
da = pytest.importorskip("dask.array")
zarr = pytest.importorskip("zarr")

LEVEL = 1 / 255
BOX = (np.array([-1, -0.8, -0.7], np.float32), np.array([1, 0.8, 0.7], np.float32))


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = pyvr.datasets.create_sample_volume(40, "double_sphere").astype(np.float32)[:, :33, :29].copy()
    path = str(tmp_path_factory.mktemp("z") / "v.zarr")
    z = zarr.open_array(path, mode="w", shape=d.shape, chunks=(20, 17, 15), dtype="f4")
    z[:] = d
    lazy = da.from_zarr(path)
    r = VolumeRenderer(48, 40, config=RenderConfig.balanced(), brick_shape=(20, 17, 15))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.5))
    r.set_camera(Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0))
    r.load_volume(Volume(data=d, min_bounds=BOX[0], max_bounds=BOX[1]))
    return r, Volume(data=lazy, min_bounds=BOX[0], max_bounds=BOX[1])


def config(**kw):
    c = RenderConfig.balanced()
    for k, v in kw.items():
        setattr(c, k, v)
    return c


@pytest.mark.parametrize("kw, tol", [
    # Partial images composite exactly: float rounding only.
    ({"early_ray_termination": False}, 0.05 * LEVEL),
    ({"early_ray_termination": False, "pre_integrated": True}, 0.05 * LEVEL),
    # The host's table interpolation against the texture unit's.
    ({"model": "mip"}, 1 * LEVEL),
    ({"model": "average"}, 1 * LEVEL),
    ({"model": "isosurface", "iso_value": 0.5}, 0.05 * LEVEL),
])
def test_cluster_render_equals_single_machine(client, scene, kw, tol):
    r, lazy = scene
    r.set_config(config(**kw))
    # Premultiplied: the straight colour of an almost transparent pixel is
    # ill-conditioned (alpha 1e-11 from the host's table against 0).
    want = r.render(dtype=np.float32, premultiplied=True)
    got = pyvr.distributed.render(r, lazy, client, dtype=np.float32, premultiplied=True)
    assert want[..., 3].max() > 0.1
    assert np.abs(got - want).max() < tol, np.abs(got - want).max() / LEVEL


def test_clip_planes_reach_the_workers(client, scene):
    r, lazy = scene
    r.set_config(config(early_ray_termination=False))
    whole = r.render(dtype=np.float32, premultiplied=True)
    path = CameraPath([Camera.from_spherical(np.zeros(3), a, 0.3, 0.0, 3.0) for a in (0.0, 1.0)])
    unclipped = list(r.render_path(path, 2))
    r.set_clip_planes([((0.1, 0.0, 0.0), (1.0, 0.4, -0.2))])
    try:
        want = r.render(dtype=np.float32, premultiplied=True)
        got = pyvr.distributed.render(r, lazy, client, dtype=np.float32, premultiplied=True)
        local = list(r.render_path(path, 2))
        farmed = pyvr.distributed.render_path(r, path, 2, client)
    finally:
        r.set_clip_planes(None)
    assert np.abs(whole - want).max() > 0.1, "the plane cuts what the frame shows"
    assert np.abs(got - want).max() < 0.05 * LEVEL
    for a, b, c in zip(local, farmed, unclipped):
        a, b, c = a.astype(int), b.astype(int), c.astype(int)
        assert np.abs(a[..., 3] - b[..., 3]).max() <= 1
        assert np.abs(a[..., 3] - c[..., 3]).max() > 20


def test_early_termination_per_brick_stays_within_its_bound(client, scene):
    r, lazy = scene
    r.set_config(config(opacity_threshold=0.9))
    want = r.render(dtype=np.float32, premultiplied=True)
    got = pyvr.distributed.render(r, lazy, client, dtype=np.float32, premultiplied=True)
    # What a stopped ray leaves out is at most 1 - threshold of the colour.
    assert np.abs(got - want).max() <= 0.1 + LEVEL


def test_a_killed_worker_is_retried_and_the_image_is_the_same(client, scene):
    r, lazy = scene
    r.set_config(config(early_ray_termination=False, step_size=0.002, max_steps=5000))
    want = pyvr.distributed.render(r, lazy, client, dtype=np.float32)
    future = client.compute(pyvr.distributed._graph(r, lazy))
    pids = client.run(os.getpid)
    deadline = time.time() + 60
    while time.time() < deadline and not any(client.processing().values()):
        time.sleep(0.01)
    busy = next(w for w, tasks in client.processing().items() if tasks)
    os.kill(pids[busy], signal.SIGKILL)
    got = pyvr.distributed._output(future.result(), np.float32, False)
    assert np.abs(got - want).max() < 0.05 * LEVEL
    # The worker really died mid-task: its process is gone.
    with pytest.raises(ProcessLookupError):
        os.kill(pids[busy], 0)


def test_path_frames_farmed_out_equal_local_frames(client, scene):
    r, _ = scene
    r.set_config(config())
    path = CameraPath([Camera.from_spherical(np.zeros(3), a, 0.3, 0.0, 3.0) for a in (0.0, 1.0)])
    local = r.render_path(path, 3)
    farmed = pyvr.distributed.render_path(r, path, 3, client)
    assert len(farmed) == 3
    for a, b in zip(local, farmed):
        a, b = a.astype(int), b.astype(int)
        assert np.abs(a[..., 3] - b[..., 3]).max() <= 1
        # Straight colour is ill-conditioned where a pixel is all but transparent.
        seen = np.minimum(a[..., 3], b[..., 3]) >= 2
        assert seen.sum() > 100 and np.abs(a - b)[seen].max() <= 1


@pytest.mark.parametrize("where", ["volume", "transfer functions"])
def test_value_ranges_reach_the_workers(client, where):
    """Data in its own units (HU) with the value range on the Volume or on
    the transfer functions, and a renderer with no volume loaded (the
    README's pattern): the cluster's image is the renderer's."""
    d = pyvr.datasets.create_sample_volume(32, "double_sphere")
    hu = (d * 2000 - 1000).astype(np.int16)
    hu_range = (-1000.0, 1000.0)
    on_volume = hu_range if where == "volume" else None
    lazy = Volume(data=da.from_array(hu, chunks=(16, 16, 16)), value_range=on_volume)

    def renderer():
        r = VolumeRenderer(40, 32, config=config(early_ray_termination=False), brick_shape=(16, 16, 16))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                 OpacityTransferFunction.linear(0.0, 0.5),
                                 value_range=None if on_volume else hu_range)
        r.set_camera(Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0))
        return r

    local = renderer()
    local.load_volume(Volume(data=hu, value_range=on_volume))
    want = local.render(dtype=np.float32, premultiplied=True)
    got = pyvr.distributed.render(renderer(), lazy, client, dtype=np.float32, premultiplied=True)
    assert want[..., 3].max() > 0.1
    assert np.abs(got - want).max() < 0.05 * LEVEL, np.abs(got - want).max() / LEVEL


def test_no_client_is_a_clear_error():
    # In a fresh interpreter: this module's cluster is the default client here.
    import subprocess
    import sys

    code = ("import pyvr.distributed as d\n"
            "try:\n    d._client(None)\nexcept ValueError as e:\n    print('RAISED', e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120).stdout
    assert out.startswith("RAISED no dask.distributed client"), out
