"""Bricked and out-of-core volumes render the single-texture image.

Bricks are forced small on small volumes so that every ray crosses many brick
faces; the tolerance is 0.05 of an 8-bit level (float output): the only
difference allowed is f32 rounding of texture coordinates, which measured
below 0.001 levels. A brick seam, a segment marched twice or skipped, or a
state lost between bricks costs whole levels.
"""

import numpy as np
import pytest

import pyvr
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

LEVEL = 1 / 255
TOL = 0.05 * LEVEL
BOX = (np.array([-1, -0.8, -0.7], np.float32), np.array([1, 0.8, 0.7], np.float32))


def scene_data():
    d = pyvr.datasets.create_sample_volume(40, "double_sphere").astype(np.float32)
    return np.ascontiguousarray(d[:, :33, :29])


def renderer(native=False, **kw):
    r = VolumeRenderer(64, 56, config=RenderConfig.balanced(), **kw)
    # Both frames of a comparison run on one engine: the single-texture
    # frame a bricked one must equal to 0.05 level in straight colour, which
    # f32 rounding changes by more where alpha is ~1e-10 (the native march's
    # agreement with the shader is tests/test_native_march.py's).
    r.native_march = native
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.5))
    r.set_camera(Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0))
    return r


def config(**kw):
    c = RenderConfig.balanced()
    for k, v in kw.items():
        setattr(c, k, v)
    return c


CONFIGS = {
    "emission_absorption": {},
    "back_to_front": {"order": "back_to_front"},
    "jitter_early_stop": {"jitter": True, "opacity_threshold": 0.7},
    "pre_integrated": {"pre_integrated": True},
    # Each segment's Poisson points are seeded by the segment, whichever brick marches it.
    "unbiased": {"unbiased": True, "opacity_threshold": 0.7},
    "unbiased_back_to_front": {"unbiased": True, "order": "back_to_front"},
    "power_correction": {"opacity_correction": "power"},
    "absorption": {"model": "absorption"},
    "emission": {"model": "emission"},
    "mip": {"model": "mip"},
    "minip": {"model": "minip"},
    "average": {"model": "average"},
    "isosurface": {"model": "isosurface", "iso_value": 0.5},
    "isosurface_jitter": {"model": "isosurface", "iso_value": 0.3, "jitter": True},
    "refined": {"pre_integrated": True, "refine": 8},
    "truncated": {"max_steps": 40, "early_ray_termination": False},
    "mip_truncated": {"model": "mip", "max_steps": 40},
}
# Where the only adapter is a CPU the native march renders bricked frames
# too: both renderers of a comparison run on one engine.
def engine_of(native):
    """The engine a renderer with ``native_march`` = ``native`` renders on:
    the native march where it may and runs, or where no adapter opened."""
    limits = device_limits()
    return "native" if (native and limits["native_march"]) or not limits["gpu_adapter"] else "gpu"


CASES = [pytest.param(engine, name, marks=[pytest.mark.shader] if engine == "shader" else [])
         for engine in ("shader", "native") for name in sorted(CONFIGS)]


def loaded_pair(native):
    vol = Volume(data=scene_data(), min_bounds=BOX[0], max_bounds=BOX[1])
    whole, bricked = renderer(native), renderer(native, brick_shape=(9, 11, 7))
    whole.load_volume(vol)
    bricked.load_volume(vol)
    return whole, bricked


@pytest.fixture(scope="module")
def pair():
    return loaded_pair(False)


@pytest.fixture(scope="module")
def native_pair():
    return loaded_pair(True)


def test_small_bricks_are_really_used(pair):
    info = pair[1].bricks
    assert info["count"] == 5 * 3 * 5 and info["brick_shape"] == (9, 11, 7) and info["resident"]
    assert pair[0].bricks is None


@pytest.mark.parametrize("engine,name", CASES)
def test_bricked_frame_equals_single_texture(request, engine, name):
    # Each ray's state (colour, optical depth or a projection's value, the
    # isosurface's bracket; whether it stopped) passes from brick to brick:
    # a segment marched twice or skipped, or a ray marched on after it
    # stopped, costs whole levels.
    whole, bricked = request.getfixturevalue("native_pair" if engine == "native" else "pair")
    runs = engine_of(engine == "native")
    cfg = config(**CONFIGS[name])
    # Refined frames pick the segments they refine from each brick's own
    # slopes, which moves pixels of alpha ~1e-3 by 0.02 level: their
    # straight colour would magnify it.
    premultiplied = name == "refined"
    outside = Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0)
    inside = Camera(target=np.array([-1.0, 0.2, 0.1]), azimuth=0.0, elevation=0.0, roll=0.0, distance=0.9)
    for cam in (outside, inside):
        whole.set_camera(cam)
        bricked.set_camera(cam)
        a = whole.render(dtype=np.float32, premultiplied=premultiplied, config=cfg)
        want = whole.last_frame_stats
        b = bricked.render(dtype=np.float32, premultiplied=premultiplied, config=cfg)
        got = bricked.last_frame_stats
        assert got["engine"] == runs
        if cam is outside:
            assert a.max() > 0.05, "the scene must show something"
        assert np.abs(a - b).max() < TOL, f"{name}: max difference {np.abs(a - b).max() / LEVEL:.4f} levels"
        # A ray cut short by max_steps is reported by the brick holding its last segment.
        assert got["truncated_needed"] == want["truncated_needed"]
        assert (got["truncated_needed"] > 40) == name.endswith("truncated")
        if name.startswith("isosurface"):
            da, db = whole.depth(), bricked.depth()
            hit = np.isfinite(da)
            assert (hit.sum() > 100 or cam is inside) and np.array_equal(hit, np.isfinite(db))
            assert np.abs(da[hit] - db[hit]).max(initial=0.0) < 1e-4


@pytest.mark.parametrize("engine", [pytest.param("shader", marks=pytest.mark.shader), "native"])
def test_bricked_unbiased_frames_with_cell_rates_have_the_same_mean(request, engine):
    # At a step of 0.05 the table's largest extinction tops a point a step,
    # so each segment takes its cell's rate: a brick's cells are its own,
    # the points differ from the single texture's, and only the means agree.
    whole, bricked = request.getfixturevalue("native_pair" if engine == "native" else "pair")
    runs = engine_of(engine == "native")
    cam = Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0)
    stacks = []
    for r in (whole, bricked):
        r.set_camera(cam)
        stacks.append(np.stack([r.render(dtype=np.float32, premultiplied=True,
                                         config=config(unbiased=True, step_size=0.05, jitter_seed=k))
                                for k in range(64)]).astype(np.float64))
        assert r.last_frame_stats["engine"] == runs
    a, b = stacks
    se = np.sqrt((a.var(axis=0, ddof=1) + b.var(axis=0, ddof=1)) / len(a))
    live = se > 1e-6
    z = (a.mean(axis=0) - b.mean(axis=0))[live] / np.hypot(se[live], 0.25 * LEVEL)
    assert live.sum() > 2000 and np.sqrt(np.mean(z**2)) < 1.3, (live.sum(), np.sqrt(np.mean(z**2)))
    per_frame = (a - b).reshape(len(a), -1).mean(axis=1)
    assert abs(per_frame.mean()) < 4 * per_frame.std(ddof=1) / np.sqrt(len(a)) + 0.05 * LEVEL


def test_a_longer_step_recuts_the_bricks_with_wider_ghosts(pair):
    whole, bricked = pair
    ghost = bricked.bricks["ghost"]
    cfg = config(step_size=0.2)
    a = whole.render(dtype=np.float32, config=cfg)
    b = bricked.render(dtype=np.float32, config=cfg)
    assert bricked.bricks["ghost"] > ghost
    assert np.abs(a - b).max() < TOL


def test_crop_box_applies_to_bricks(pair):
    whole, bricked = pair
    for r in pair:
        r.set_crop_box((-0.5, -0.8, -0.2), (0.6, 0.3, 0.7))
    try:
        a, b = whole.render(dtype=np.float32), bricked.render(dtype=np.float32)
        assert np.abs(a - b).max() < TOL
    finally:
        for r in pair:
            r.set_crop_box()


def test_single_scattering_is_refused_with_bricks(pair):
    with pytest.raises(ValueError, match="single_scattering"):
        pair[1].render(config=config(model="single_scattering"))


def test_bad_brick_options_are_errors():
    with pytest.raises(ValueError, match="brick_shape"):
        VolumeRenderer(8, 8, brick_shape=(4, 0, 4))
    with pytest.raises(ValueError, match="memory_budget"):
        VolumeRenderer(8, 8, memory_budget=0)


# Rendered in each test (not once per module): a module's fixture is set up
# before conftest's per-test switch to exact filtering on GPUs, so its frame
# would be the texture units' (0.18 off the exact one on an H200).
@pytest.fixture
def reference():
    data = scene_data()
    r = renderer()
    r.load_volume(Volume(data=data, min_bounds=BOX[0], max_bounds=BOX[1]))
    return data, r.render(dtype=np.float32)


def test_memmap_streams_bricks_when_over_budget(reference, tmp_path):
    data, want = reference
    path = tmp_path / "v.raw"
    data.tofile(path)
    mm = np.memmap(path, dtype=np.float32, mode="r", shape=data.shape)
    r = renderer(brick_shape=(16, 16, 16), memory_budget=64 * 1024)
    r.load_volume(Volume(data=mm, min_bounds=BOX[0], max_bounds=BOX[1]))
    assert r.bricks["resident"] is False and r.bricks["device_bytes"] > 64 * 1024
    got = r.render(dtype=np.float32)
    assert np.abs(got - want).max() < TOL
    # Nothing stays on the device between frames.
    assert r.counters()["volume_bytes"] == 0


def test_zarr_array_renders_like_numpy(reference, tmp_path):
    zarr = pytest.importorskip("zarr")
    data, want = reference
    z = zarr.open_array(str(tmp_path / "v.zarr"), mode="w", shape=data.shape, chunks=(16, 16, 16), dtype="f4")
    z[:] = data
    r = renderer()
    r.load_volume(Volume(data=z, min_bounds=BOX[0], max_bounds=BOX[1]))
    assert r.bricks is not None
    assert np.abs(r.render(dtype=np.float32) - want).max() < TOL


def test_dask_and_xarray_arrays_render_like_numpy(reference):
    da = pytest.importorskip("dask.array")
    xr = pytest.importorskip("xarray")
    data, want = reference
    lazy = da.from_array(data, chunks=(20, 17, 15))
    r = renderer()
    r.load_volume(Volume(data=lazy, min_bounds=BOX[0], max_bounds=BOX[1]))
    assert np.abs(r.render(dtype=np.float32) - want).max() < TOL
    # Coordinates at cell centres give the box.
    coords = {d: lo + (np.arange(n) + 0.5) * (hi - lo) / n
              for d, n, lo, hi in zip("xyz", data.shape, BOX[0].astype(float), BOX[1].astype(float))}
    arr = xr.DataArray(lazy, dims=("x", "y", "z"), coords=coords, name="density")
    r2 = renderer()
    r2.load_volume(arr)
    np.testing.assert_allclose(r2.volume.min_bounds, BOX[0], atol=1e-6)
    np.testing.assert_allclose(r2.volume.max_bounds, BOX[1], atol=1e-6)
    assert np.abs(r2.render(dtype=np.float32) - want).max() < TOL


@pytest.mark.parametrize("native", [False, True])
@pytest.mark.parametrize("kind", ["normals", "float16", "float16_normals", "uint8", "uint16_value_range"])
def test_stored_formats_and_normals_brick_like_one_texture(kind, native, tmp_path):
    data = scene_data()
    kw = {}
    precision = "float32"
    if kind in ("normals", "float16_normals"):
        kw["normals"] = pyvr.datasets.compute_normal_volume(data)
    if kind.startswith("float16"):
        precision = "float16"
    if kind == "uint8":
        data = (np.clip(data, 0, 1) * 255).astype(np.uint8)
    if kind == "uint16_value_range":
        data = (np.clip(data, 0, 1) * 4000).astype(np.uint16)
        kw["value_range"] = (0.0, 4000.0)
    vol = Volume(data=data, min_bounds=BOX[0], max_bounds=BOX[1], **kw)
    images = []
    for r in (renderer(native), renderer(native, brick_shape=(12, 10, 9))):
        r.load_volume(vol, precision=precision)
        images.append(r.render(dtype=np.float32, premultiplied=True))
        assert r.last_frame_stats["engine"] == engine_of(native)
    assert images[0][..., 3].max() > 0.2
    assert np.abs(images[0] - images[1]).max() < TOL
    if "normals" in kind:
        # Normals held in memmaps are read brick by brick too.
        path = tmp_path / "n.raw"
        kw["normals"].astype(np.float32).tofile(path)
        mm = np.memmap(path, dtype=np.float32, mode="r", shape=kw["normals"].shape)
        r = renderer(native, brick_shape=(12, 10, 9))
        r.load_volume(Volume(data=data, normals=mm, min_bounds=BOX[0], max_bounds=BOX[1]), precision=precision)
        assert np.abs(r.render(dtype=np.float32, premultiplied=True) - images[0]).max() < TOL


def test_bricks_out_of_view_or_crop_are_never_read():
    data = scene_data()
    vol = Volume(data=data, min_bounds=BOX[0], max_bounds=BOX[1])
    near = Camera(target=np.array([0.3, 0.2, 0.1]), azimuth=0.3, elevation=0.2, roll=0.0, distance=1.5, fov=0.15)
    whole, bricked = renderer(), renderer(brick_shape=(9, 11, 7))
    for r in (whole, bricked):
        r.load_volume(vol)
        r.set_camera(near)
    a, b = whole.render(dtype=np.float32), bricked.render(dtype=np.float32)
    assert a[..., 3].max() > 0.05 and np.abs(a - b).max() < TOL
    read = bricked.counters()["volume_uploads"]
    assert 0 < read < bricked.bricks["count"] // 2, f"{read} of {bricked.bricks['count']} bricks read"
    # A crop box leaves the bricks outside it unread as well.
    cropped = renderer(brick_shape=(9, 11, 7))
    cropped.load_volume(vol)
    cropped.set_crop_box((-1, -0.8, -0.7), (0, 0, 0))
    whole.set_camera(Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0))
    whole.set_crop_box((-1, -0.8, -0.7), (0, 0, 0))
    assert np.abs(cropped.render(dtype=np.float32) - whole.render(dtype=np.float32)).max() < TOL
    assert cropped.counters()["volume_uploads"] <= 3 * 2 * 3


def test_a_copy_on_write_memmap_renders_its_changes(reference, tmp_path):
    data, want = reference
    path = tmp_path / "zeros.raw"
    np.zeros(data.shape, np.float32).tofile(path)
    mm = np.memmap(path, dtype=np.float32, mode="c", shape=data.shape)
    mm[:] = data  # private changes: the file still holds zeros
    r = renderer(brick_shape=(16, 16, 16), memory_budget=64 * 1024)
    r.load_volume(Volume(data=mm, min_bounds=BOX[0], max_bounds=BOX[1]))
    assert np.abs(r.render(dtype=np.float32) - want).max() < TOL
    assert np.array_equal(mm, data)  # and they are still there


def test_bricks_skipped_under_one_table_come_back_under_the_next():
    # Which bricks can show is kept per table and value map: a change must
    # bring the skipped ones back.
    data = scene_data()
    vol = Volume(data=data, min_bounds=BOX[0], max_bounds=BOX[1])
    whole, bricked = renderer(), renderer(brick_shape=(9, 11, 7))
    for r in (whole, bricked):
        r.load_volume(vol)
    narrow = OpacityTransferFunction([(0.0, 0.0), (0.9, 0.0), (0.95, 0.8), (1.0, 0.8)])
    wide = OpacityTransferFunction.linear(0.0, 0.5)
    cmap = ColorTransferFunction.from_colormap("viridis")
    # The first frame reads every brick; the next ones decide from the kept ranges.
    for otf, value_range in ((wide, None), (narrow, None), (wide, None), (wide, (0.0, 4.0)), (wide, None)):
        for r in (whole, bricked):
            r.set_transfer_functions(cmap, otf, value_range=value_range)
        a, b = whole.render(dtype=np.float32, premultiplied=True), bricked.render(dtype=np.float32, premultiplied=True)
        assert np.abs(a - b).max() < TOL, (otf is narrow, value_range, np.abs(a - b).max() / LEVEL)
    assert a[..., 3].max() > 0.2


@pytest.mark.parametrize("native", [False, True])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("pre", [False, True])
def test_sparse_bricks_pass_every_ray_on(order, pre, native):
    # Bricks of 24^3 hold 3-4 occupancy cells a side; two small blobs, one
    # in each of two bricks a ray crosses in turn, leave most of each brick
    # empty, so rays leap inside bricks and leave them past their last
    # visible cell. Each must still reach the other blob: a brick is done
    # with a ray, not the frame.
    d = np.zeros((64, 64, 64), np.float32)
    d[4:12, 4:12, 4:12] = 0.8
    d[50:58, 50:58, 50:58] = 0.6
    box = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
    whole, bricked = renderer(native), renderer(native, brick_shape=(24, 24, 24))
    cfg = RenderConfig(step_size=0.01, max_steps=400, early_ray_termination=False, order=order, pre_integrated=pre)
    for r in (whole, bricked):
        r.load_volume(Volume(data=d, min_bounds=box[0], max_bounds=box[1]))
        r.set_camera(Camera.from_spherical(np.zeros(3), np.pi / 4, np.arcsin(1 / np.sqrt(3)), 0.0, 3.0))
        r.set_config(cfg)
    a, b = whole.render(dtype=np.float32, premultiplied=True), bricked.render(dtype=np.float32, premultiplied=True)
    assert bricked.bricks["count"] == 27
    # Both blobs on the diagonal: some rays cross both.
    assert a[..., 3].max() > 0.5
    assert np.abs(a - b).max() < TOL, np.abs(a - b).max() / LEVEL


@pytest.mark.parametrize("native", [False, True])
def test_rays_stopped_in_one_brick_stay_stopped(native):
    # Rays stop early in the nearer blob with most of their light left
    # (threshold 0.2): marched on in the farther blob's brick, even for one
    # segment, they would take up its colour.
    d = np.zeros((64, 64, 64), np.float32)
    d[4:20, 4:20, 4:20] = 0.8
    d[44:60, 44:60, 44:60] = 0.6
    box = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
    whole, bricked = renderer(native), renderer(native, brick_shape=(24, 24, 24))
    cfg = RenderConfig(step_size=0.01, opacity_threshold=0.2)
    for r in (whole, bricked):
        r.load_volume(Volume(data=d, min_bounds=box[0], max_bounds=box[1]))
        r.set_camera(Camera.from_spherical(np.zeros(3), np.pi / 4, np.arcsin(1 / np.sqrt(3)), 0.0, 3.0))
        r.set_config(cfg)
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 1.0))
    a, b = whole.render(dtype=np.float32, premultiplied=True), bricked.render(dtype=np.float32, premultiplied=True)
    assert bricked.last_frame_stats["engine"] == engine_of(native)
    stopped = (a[..., 3] >= 0.2) & (a[..., 3] < 0.5)
    assert stopped.sum() > 100, stopped.sum()
    assert np.abs(a - b).max() < TOL, np.abs(a - b).max() / LEVEL


@pytest.mark.parametrize("native", [False, True])
@pytest.mark.parametrize("where", ["entry", "exit"])
def test_isosurface_at_the_box_faces_in_bricks(where, native):
    # Looking down the x axis (numpy axis 0) from x = 3. "entry": the near
    # half is inside the surface, so every ray hits at its entry (distance
    # 2 on the axis), tested by the brick holding it. "exit": a one-voxel
    # layer on the far face, thinner than a step, is met by the exit's test
    # (distance 4), made by the brick holding a ray's last segment.
    d = np.zeros((64, 64, 64), np.float32)
    if where == "entry":
        d[32:] = 0.8
    else:
        d[0] = 0.9
    box = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
    whole, bricked = renderer(native), renderer(native, brick_shape=(24, 24, 24))
    cfg = RenderConfig(step_size=0.1, model="isosurface", iso_value=0.5)
    for r in (whole, bricked):
        r.load_volume(Volume(data=d, min_bounds=box[0], max_bounds=box[1]))
        r.set_camera(Camera.from_spherical(np.zeros(3), 0.0, 0.0, 0.0, 3.0))
        r.set_config(cfg)
    a, b = whole.render(dtype=np.float32, premultiplied=True), bricked.render(dtype=np.float32, premultiplied=True)
    da, db = whole.depth(), bricked.depth()
    assert bricked.last_frame_stats["engine"] == engine_of(native)
    hit = np.isfinite(da)
    assert hit.mean() > 0.25 and np.array_equal(hit, np.isfinite(db)) and np.abs(da[hit] - db[hit]).max() < 1e-4
    assert np.abs(a - b).max() < TOL, np.abs(a - b).max() / LEVEL
    assert abs(da[28, 32] - (2.0 if where == "entry" else 4.0)) < 0.05, da[28, 32]


@pytest.mark.shader
def test_bricks_loaded_with_the_native_march_off_stay_on_the_shader():
    # Resident bricks loaded while the native march was off keep no texels
    # for it (the shader's textures alone): turning it on later renders
    # them on the shader, the same image, and a volume loaded anew is native.
    vol = Volume(data=scene_data(), min_bounds=BOX[0], max_bounds=BOX[1])
    r = renderer(False, brick_shape=(9, 11, 7))
    r.load_volume(vol)
    a = r.render(dtype=np.float32, premultiplied=True)
    assert r.last_frame_stats["engine"] == "gpu" and a[..., 3].max() > 0.2
    r.native_march = True
    b = r.render(dtype=np.float32, premultiplied=True)
    assert r.last_frame_stats["engine"] == "gpu" and np.abs(a - b).max() < TOL
    r.load_volume(vol)
    c = r.render(dtype=np.float32, premultiplied=True)
    assert r.last_frame_stats["engine"] == ("native" if device_limits()["native_march"] else "gpu")
    assert np.abs(a - c).max() < TOL
