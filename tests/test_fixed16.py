"""Volumes stored as 16-bit fixed point over their own range
(load_volume(..., precision="fixed16"), and what precision="auto" chooses):
integers exactly, floats to a 131068th of their range, with normals in the
value's texel at 16 bits; the frames are checked against the float64
integrator of the exact data."""

import numpy as np
import pytest

from scenes import frame, make_renderer
from pyvr import VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

LEVELS = 255.0
PACKED = "rgba16snorm (16-bit fixed point (value, normal))"
HAS_NORM16 = device_limits()["norm16_textures"]
# Auto stores float data in fixed point only where the adapter is a CPU (its
# caches); test_auto_stores_lit_volumes_in_16_bits_per_component checks
# that a GPU's auto keeps float32.
CPU_AUTO = pytest.mark.skipif(not device_limits()["cpu_device"],
                              reason="auto stores float data in fixed point only on a CPU adapter")


@pytest.fixture
def small_cache(monkeypatch):
    """A CPU cache smaller than these test volumes' float32 texels, so that
    precision='auto' treats them as it treats large volumes."""
    monkeypatch.setattr("pyvr._storage.cpu_cache_bytes", lambda: 2**16)


def renderer(vol, precision="auto", light=None, otf=None, value_range=None, config=None, size=(48, 40)):
    return make_renderer(vol, size=size, precision=precision, light=light or Light.default(), otf=otf,
                         value_range=value_range, config=config, camera=Camera.isometric_view(distance=2.6),
                         ctf=ColorTransferFunction.from_colormap("plasma"))


def oracle_error(r):
    """Max difference, in levels, between the frame and the float64
    integrator's image of the exact data."""
    return float(np.abs(frame(r) - r.render_float64(premultiplied=True)).max() * LEVELS)


def lit_volume(n=40, dtype=np.float32, scale=1.0, offset=0.0):
    d = create_sample_volume(n, "double_sphere")
    nrm = compute_normal_volume(d)
    if dtype == np.float32:
        return Volume((d * scale + offset).astype(np.float32), nrm)
    # uint16 up to 65534: 65535 steps would not code exactly.
    top = min(np.iinfo(dtype).max, 65534)
    return Volume(np.round(d / d.max() * top).astype(dtype), nrm)


def test_auto_stores_lit_volumes_in_16_bits_per_component(monkeypatch):
    if not HAS_NORM16:
        # Without 16-bit normalized textures auto keeps float32, and asking is a clear error.
        assert renderer(lit_volume()).precision == "float32"
        with pytest.raises(ValueError, match="16-bit normalized"):
            renderer(lit_volume(), precision="fixed16")
        return
    for vol in (lit_volume(dtype=np.uint8), lit_volume(dtype=np.uint16)):
        r = renderer(vol)
        assert r.precision == "fixed16"
        c = r.counters()
        assert (c["volume_storage"], c["volume_bytes"]) == (PACKED, 8 * vol.data.size)
    # Float data: fixed point where its float32 texels outgrow a CPU's cache.
    cpu = device_limits()["cpu_device"]
    assert renderer(lit_volume()).precision == "float32"
    monkeypatch.setattr("pyvr._storage.cpu_cache_bytes", lambda: 2**16)
    assert renderer(lit_volume()).precision == ("fixed16" if cpu else "float32")
    # A reported cache counts for at most TRUSTED_CPU_CACHE (a VM reports
    # its host's, shared with other guests).
    monkeypatch.setattr("pyvr._storage.cpu_cache_bytes", lambda: 480 * 2**20)
    assert renderer(lit_volume()).precision == "float32"
    monkeypatch.setattr("pyvr._storage.TRUSTED_CPU_CACHE", 2**16)
    assert renderer(lit_volume()).precision == ("fixed16" if cpu else "float32")
    # Without normals auto keeps the values as they are.
    assert renderer(Volume(create_sample_volume(16))).precision == "float32"


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
@pytest.mark.parametrize("dtype", [np.float32, np.uint8, np.uint16])
def test_fixed16_frames_match_the_float64_integrator(dtype):
    # Floats move by at most 1.5e-5 of their range (measured: 0.01 level);
    # integers are exact, and their normals at 16 bits light as the exact
    # ones (measured: 0.001 level, against 0.10 with the 8-bit normals
    # integers get at float32).
    vol = lit_volume(dtype=dtype)
    r = renderer(vol, "fixed16")
    assert frame(r)[..., 3].max() > 0.5
    err = oracle_error(r)
    assert err < (0.05 if dtype == np.float32 else 0.01), err
    if dtype == np.uint8:
        assert oracle_error(renderer(vol, "float32")) > 0.05  # what the 16-bit normals buy


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
def test_the_codes_read_back_as_the_data_far_from_zero():
    # Values in [1000, 1001]: a code map off by half a code (or an offset
    # composed in the wrong order) would move every value by 8e-6 or more
    # of the transfer functions' range; this frame would show it as levels.
    vol = lit_volume(offset=1000.0)
    r = renderer(vol, "fixed16", value_range=(1000.0, 1001.0),
                 otf=OpacityTransferFunction([(0.0, 0.0), (0.4, 0.0), (0.6, 0.5), (1.0, 0.2)]))
    assert frame(r)[..., 3].max() > 0.3
    assert oracle_error(r) < 0.05


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
@pytest.mark.parametrize("model", ["mip", "average", "isosurface"])
def test_value_only_fixed16_for_other_models(model):
    from pyvr import RenderConfig

    vol = Volume(create_sample_volume(40, "double_sphere"))
    cfg = RenderConfig.balanced().replace(model=model)
    r = renderer(vol, "fixed16", config=cfg, light=Light.ambient_only(1.0))
    assert r.counters()["volume_storage"] == "r16snorm (16-bit fixed point)"
    exact = renderer(vol, "float32", config=cfg, light=Light.ambient_only(1.0))
    a, b = frame(r), frame(exact)
    assert b.max() > 0.05
    assert np.abs(a - b).max() * LEVELS < 0.1


@CPU_AUTO
@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
def test_auto_follows_the_value_range(small_cache):
    # Data over [0, 1000] seen through a window one unit wide: 16 bits over
    # the data would move values by 0.008 of the window, so auto keeps
    # float32; a window over the whole range takes fixed16; back again.
    vol = lit_volume(scale=1000.0)
    r = renderer(vol, value_range=(0.0, 1.0))
    assert r.precision == "float32"
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.4),
                             value_range=(0.0, 1000.0))
    assert r.precision == "fixed16" and r.counters()["volume_storage"] == PACKED
    assert oracle_error(r) < 0.05
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.4),
                             value_range=(0.0, 1.0))
    assert r.precision == "float32"
    assert oracle_error(r) < 0.05


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
@pytest.mark.parametrize("bad", [np.nan, np.inf, "mask", "u16 full range"])
def test_data_16_bits_cannot_code(bad, small_cache):
    vol = lit_volume(16)
    if bad == "mask":
        vol = Volume(np.ma.masked_greater(vol.data, 0.5), vol.normals)
    elif bad == "u16 full range":
        d = np.zeros((16, 16, 16), np.uint16)
        d[0, 0, 0], d[1, 0, 0] = 0, 65535
        vol = Volume(d, vol.normals)
    else:
        vol.data[3, 4, 5] = bad
    copy = np.array(vol.data, copy=True)
    assert renderer(vol).precision == "float32"
    with pytest.raises(ValueError, match="fixed16"):
        VolumeRenderer(8, 8).load_volume(vol, precision="fixed16")
    assert np.array_equal(np.asarray(vol.data), copy, equal_nan=copy.dtype.kind == "f")


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
def test_constant_volume_and_bricks():
    flat = Volume(np.full((12, 12, 12), 0.3, np.float32), compute_normal_volume(create_sample_volume(12)))
    a, b = renderer(flat, "fixed16"), renderer(flat, "float32")
    assert np.abs(frame(a) - frame(b)).max() * LEVELS < 0.01 and frame(b)[..., 3].max() > 0.2
    vol = lit_volume(24)
    r = VolumeRenderer(16, 16, brick_shape=(12, 12, 12))
    with pytest.raises(ValueError, match="one texture"):
        r.load_volume(vol, precision="fixed16")
    r.load_volume(vol)
    assert r.bricks is not None and r.precision == "float32"


def test_cpu_cache_size_is_read_or_assumed():
    from pyvr.renderer import DEFAULT_CPU_CACHE, cpu_cache_bytes

    size = cpu_cache_bytes()
    assert 2**16 <= size <= 2**32 and (size == DEFAULT_CPU_CACHE or size % 1024 == 0)


@CPU_AUTO
@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
def test_auto_keeps_fixed16_with_a_warning_where_float32_would_not_fit(small_cache):
    # 40^3 lit voxels: 512 KB at 8 bytes fits this budget in one texture,
    # 1 MB at 16 would not.
    vol = lit_volume(scale=1000.0)
    vol.value_range = (0.0, 1000.0)
    r = VolumeRenderer(16, 16, memory_budget=700_000)
    r.load_volume(vol)
    assert r.precision == "fixed16" and r.bricks is None
    with pytest.warns(UserWarning, match="stays in fixed point"):
        r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"),
                                 OpacityTransferFunction.linear(0.0, 0.4), value_range=(0.0, 1.0))
    assert r.precision == "fixed16"


@pytest.mark.skipif(not HAS_NORM16, reason="covered by test_auto_stores_lit_volumes_in_16_bits_per_component")
def test_fixed16_skipping_matches_unskipped():
    # The occupancy grid is built from the values the device reads: values
    # within half a code of the data's least (0 here) read as 0, so more
    # cells are empty than at float32, and skipping them changes nothing.
    d = create_sample_volume(64, "double_sphere")
    vol = Volume(d, compute_normal_volume(d))
    otf = OpacityTransferFunction.linear(0.0, 0.4)
    frames = {}
    for precision in ("float32", "fixed16"):
        for skip in (False, True):
            r = renderer(vol, precision, otf=otf)
            r.empty_space_skipping = skip
            frames[precision, skip] = (frame(r), r.last_frame_stats["samples"], r.empty_fraction())
    plain, skipped = frames["fixed16", False], frames["fixed16", True]
    assert np.abs(plain[0] - skipped[0]).max() * LEVELS < 0.01 and plain[0][..., 3].max() > 0.5
    assert skipped[1] < 0.9 * plain[1]
    assert skipped[2] > frames["float32", True][2]
    assert np.abs(skipped[0] - frames["float32", True][0]).max() * LEVELS < 0.05
