"""Gradient-shaded frames store the values with their gradients
(src/gradients.rs) at their first frame: the same images as gradients
taken on the fly, one fetch a lit sample instead of seven."""

import numpy as np
import pytest

from scenes import blob, frame, make_renderer
from pyvr import RenderConfig
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import OpacityTransferFunction
from pyvr.volume import Volume


def both(volume, **options):
    """Frames with the gradient texels and with gradients on the fly (the
    packing skipped), and the first renderer's stored format."""
    out = []
    for pack in (True, False):
        r = make_renderer(volume, **options)
        r._gradients_tried = not pack
        out.append(frame(r))
        if pack:
            storage = r.counters()["volume_storage"]
    return out[0], out[1], storage


def noise(shape, seed=0):
    return np.random.default_rng(seed).random(shape, dtype=np.float32)


SCENES = {
    # structure up to the faces: the border texels decide the outer half voxel
    "noise": lambda: Volume(noise((21, 17, 26))),
    # stretched voxels in a non-cubic box
    "anisotropic": lambda: Volume(blob((40, 24, 12), width=0.5), None, np.array([-1.2, -0.5, -0.3], np.float32),
                                  np.array([1.2, 0.5, 0.3], np.float32)),
    # values near float32's range: the differences must neither overflow nor lose the direction
    "huge_values": lambda: Volume(noise((16, 16, 16), 1) * np.float32(3e38)),
    # a box 6e37 across with faint differences: per world unit they would be
    # float32 subnormals, which devices that flush them read as 0
    "huge_box": lambda: Volume(noise((16, 16, 16), 2) * np.float32(1e-6), None, np.full(3, -3e37, np.float32),
                               np.full(3, 3e37, np.float32)),
}


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("model", ["emission_absorption", "emission", "isosurface"])
def test_gradient_texels_give_the_same_image(name, model):
    vol = SCENES[name]()
    cfg = RenderConfig.balanced().replace(model=model, iso_value=0.5)
    value_range = {"huge_values": (0.0, 3e38), "huge_box": (0.0, 1e-6)}.get(name)
    packed, on_the_fly, storage = both(vol, config=cfg, value_range=value_range,
                                       otf=OpacityTransferFunction.linear(0.0, 0.6))
    assert storage == "rgba32float (value, gradient)"
    assert on_the_fly.max() > 0.2
    # Only float32 rounding differs: measured at most 0.003 level.
    assert np.abs(packed - on_the_fly).max() * 255 < 0.02


def test_gradient_texels_keep_empty_space_skipping_and_passes():
    # A sparse scene with leaps over the bordered grid, marched in passes.
    d = blob((48, 48, 48), width=0.3)
    cfg = RenderConfig(step_size=0.002, max_steps=3000, early_ray_termination=False)
    packed, on_the_fly, storage = both(Volume(d), config=cfg, camera=Camera.isometric_view(distance=2.5),
                                       otf=OpacityTransferFunction.one_step(0.5, 0.0, 0.8))
    assert "gradient" in storage
    assert np.abs(packed - on_the_fly).max() * 255 < 0.02


@pytest.mark.parametrize("case", ["ambient", "normals", "float16", "nan", "mip", "uint8"])
def test_gradient_texels_only_where_gradient_shading_reads_them(case):
    d = blob((20, 20, 20), width=0.5)
    options = {}
    vol = Volume(d)
    if case == "ambient":
        options["light"] = Light.ambient_only(1.0)
    elif case == "normals":
        vol = Volume(d, np.stack(np.gradient(d), axis=-1).astype(np.float32))
    elif case == "float16":
        options["precision"] = "float16"
    elif case == "nan":
        d = d.copy()
        d[3, 4, 5] = np.nan
        vol = Volume(d)
    elif case == "mip":
        options["config"] = RenderConfig.balanced().replace(model="mip")
    elif case == "uint8":
        vol = Volume((d * 255).astype(np.uint8))
    r = make_renderer(vol, **options)
    if case == "uint8":
        # The shader's own fetches of the codes (where the native march
        # renders, it stores them with gradients: test_native_march.py).
        r.native_march = False
    before = r.counters()["volume_storage"]
    frame(r)
    assert r.counters()["volume_storage"] == before
    assert "gradient" not in before


def test_a_new_volume_is_packed_again():
    r = make_renderer(Volume(blob((16, 16, 16), width=0.5)))
    frame(r)
    assert "gradient" in r.counters()["volume_storage"]
    r.load_volume(Volume(blob((24, 16, 16), width=0.4)))
    assert "gradient" not in r.counters()["volume_storage"]
    frame(r)
    assert "gradient" in r.counters()["volume_storage"]
