"""Float volumes stored as float16 (load_volume(..., precision="float16")):
the device reads exactly the float16-rounded values, in 2 bytes per voxel or
8 with normals in the same texel; bad requests are clear errors."""

import numpy as np
import pytest

from scenes import make_renderer
from pyvr import VolumeRenderer
from pyvr.renderer import device_limits
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

LEVEL = 1 / 255


def renderer(vol, precision="float32", light=None, otf=None, skip=True, size=(48, 40)):
    return make_renderer(vol, size=size, precision=precision, light=light, otf=otf, skip=skip,
                         camera=Camera.isometric_view(distance=2.6), ctf=ColorTransferFunction.from_colormap("plasma"))


def image(r):
    return r.render(dtype=np.float32, premultiplied=True)


def lit_scene(n=48):
    d = create_sample_volume(n, "double_sphere")
    return d, compute_normal_volume(d)


SEPARATE = ("r32float + rgba8snorm normals", 8)
PACKED = ("rgba32float (value, normal)", 16)


def test_storage_and_bytes_per_voxel():
    d, nrm = lit_scene(16)
    holed = d.copy()
    holed[0, 0, 0] = np.nan
    # Value and normal share a float32 texel where the device filters them.
    packed = PACKED if device_limits()["float32_filterable"] else SEPARATE
    cases = [
        (Volume(d), "float32", "r32float", 4),
        (Volume(d, nrm), "float32", *packed),
        # NaN is interpolated in the shader, which reads values alone.
        (Volume(holed, nrm), "float32", *SEPARATE),
        (Volume(d), "float16", "r16float", 2),
        (Volume(d, nrm), "float16", "rgba16float (value, normal)", 8),
        # Integer data is stored exactly whatever the precision.
        (Volume(np.round(d * 255).astype(np.uint8)), "float16", "r8unorm", 1),
    ]
    for vol, precision, storage, bpv in cases:
        c = renderer(vol, precision).counters()
        assert (c["volume_storage"], c["volume_bytes"]) == (storage, bpv * d.size), (precision, storage)


def test_packed_normals_light_as_separate_ones():
    # The same lit scene with value and normal in one float32 texel, and
    # (a NaN in a corner, where the table is transparent anyway, forces it)
    # with the normals in a texture of their own, to 1/127 per component.
    if not device_limits()["float32_filterable"]:
        pytest.skip("this device stores float32 normals apart only")
    d, nrm = lit_scene()
    holed = d.copy()
    holed[0, 0, 0] = np.nan
    light = Light.default()
    a, b = renderer(Volume(d, nrm), "float32", light), renderer(Volume(holed, nrm), "float32", light)
    assert (a.counters()["volume_storage"], b.counters()["volume_storage"]) == (PACKED[0], SEPARATE[0])
    ia, ib = image(a), image(b)
    assert ia[..., 3].max() > 0.5
    # The normals' rounding (1/127) moves the diffuse term by under 0.4%.
    assert np.abs(ia - ib).max() * 255 < 1.0


@pytest.mark.parametrize("lit", [False, True])
def test_float16_reads_exactly_the_rounded_values(lit):
    # The float16 frame equals a float32 frame of the rounded data: the only
    # other difference is the normals' precision (float16 vs 1/127), measured
    # at 0.08 level at most here.
    d, nrm = lit_scene()
    d[5:9, 20:30, 20:30] = np.nan
    rounded = d.astype(np.float16).astype(np.float32)
    light = Light.default() if lit else Light.ambient_only(1.0)
    half = image(renderer(Volume(d, nrm if lit else None), "float16", light))
    ref = image(renderer(Volume(rounded, nrm if lit else None), "float32", light))
    assert half[..., 3].max() > 0.5
    tol = 0.25 if lit else 0.02
    assert np.abs(half - ref).max() < tol * LEVEL
    # And the rounding itself is small against the exact data (measured: at
    # most 0.08 level; longer, denser rays reach 2, see README).
    exact = image(renderer(Volume(d, nrm if lit else None), "float32", light))
    err = np.abs(half - exact) / LEVEL
    assert err.max() < 0.5 and err.mean() < 0.01, (err.max(), err.mean())


def test_float16_skipping_matches_unskipped():
    # The occupancy grid is built from the rounded values the device reads.
    d = create_sample_volume(64, "helix")
    d = d.astype(np.float32)
    otf = OpacityTransferFunction.one_step(0.5, 0.0, 0.6)
    plain = renderer(Volume(d, compute_normal_volume(d)), "float16", otf=otf, skip=False)
    skip = renderer(Volume(d, compute_normal_volume(d)), "float16", otf=otf, skip=True)
    a, b = image(plain), image(skip)
    assert skip.empty_fraction() > 0.5
    assert skip.last_frame_stats["samples"] < 0.8 * plain.last_frame_stats["samples"]
    assert np.abs(a - b).max() < LEVEL and a[..., 3].max() > 0.3


def test_camera_only_rerender_uploads_nothing_with_float16():
    d, nrm = lit_scene(24)
    r = renderer(Volume(d, nrm), "float16")
    r.render()
    r.set_camera(Camera.front_view(distance=3.0))
    r.render()
    assert r.counters()["volume_uploads"] == 1 and r.last_frame_stats["uploaded_bytes"] < 512


@pytest.mark.parametrize("value", [1e5, -7e4, np.inf])
def test_float16_refuses_values_it_cannot_hold(value):
    d, _ = lit_scene(8)
    d[1, 2, 3] = value
    copy = d.copy()
    r = VolumeRenderer(8, 8)
    with pytest.raises(ValueError, match="65504"):
        r.load_volume(Volume(d), precision="float16")
    assert np.array_equal(d, copy)
    r.load_volume(Volume(d), precision="float32")  # exact storage takes it


@pytest.mark.parametrize("bad", ["float64", "fixed8", "", 16])
def test_unknown_precision_is_a_value_error(bad):
    with pytest.raises(ValueError, match="float32"):
        VolumeRenderer(8, 8).load_volume(Volume(create_sample_volume(8)), precision=bad)
