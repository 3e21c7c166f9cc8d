"""Values in the data's own units, framing and compositing for real data:
value ranges mapped on the GPU (against the same scene in [0, 1] and the
f64 integrator), window/level, histograms, crop boxes (closed form and
oracle), backgrounds, Camera.fit and a first picture of a file in
physical units without hand-tuning."""

import os
import warnings

import numpy as np
import pytest

import pyvr
import scenes
from scenes import make_renderer
from conftest import SHARED_DATA, levels
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction, window_level
from pyvr.volume import Volume
from test_closed_form import chords

W, H = 48, 40


def blob(shape=(20, 16, 12)):
    return scenes.blob(shape, scale=3.0)


def renderer(vol, otf=None, value_range=None, light=None):
    return make_renderer(vol, size=(W, H), otf=otf, value_range=value_range, light=light)


def test_value_range_maps_data_units_on_the_gpu():
    """A CT-like volume in Hounsfield units with value_range (-1000, 3000)
    renders as the same field scaled to [0, 1] does: within 1 level (the
    map is an f32 multiply-add per sample), lit by gradients."""
    unit = blob()
    hu = unit * 4000.0 - 1000.0
    expected = renderer(Volume(unit)).render(dtype=np.float32)
    r = renderer(Volume(hu), value_range=(-1000, 3000))
    got = r.render(dtype=np.float32)
    assert np.abs(levels(got) - levels(expected)).max() <= 1
    assert expected[..., 3].max() > 0.3
    # The f64 integrator applies the same map.
    ref = r.render_float64()
    assert np.abs(levels(ref) - levels(got)).max() <= 1.5
    # The volume was not rescaled: the renderer holds the caller's array.
    assert r.volume.data is not None and r.volume.data.min() == hu.min()


def test_value_range_precedence_and_agreement():
    hu = blob() * 4000.0 - 1000.0
    vol = Volume(hu, value_range=(-1000, 3000))
    r = renderer(vol)
    assert r.value_range == (-1000.0, 3000.0)
    on_volume = r.render()
    ctf = ColorTransferFunction.from_colormap("viridis")
    otf = OpacityTransferFunction.linear(0.0, 0.4)
    ctf.value_range = otf.value_range = (-1000, 3000)
    r2 = renderer(Volume(hu), otf=otf)
    r2.set_transfer_functions(ctf, otf)
    assert r2.value_range == (-1000.0, 3000.0)
    assert np.abs(r2.render().astype(int) - on_volume.astype(int)).max() <= 1
    # Explicit argument wins; different ranges on the two functions are refused.
    r2.set_transfer_functions(ctf, otf, value_range=(-1000, 1000))
    assert r2.value_range == (-1000.0, 1000.0)
    assert not np.array_equal(r2.render(), on_volume)
    otf.value_range = (0, 1)
    with pytest.raises(ValueError, match="different value ranges"):
        r2.set_transfer_functions(ctf, otf)
    for bad in [(1, 1), (2, 1), (0, np.inf), "wide", (1, 2, 3)]:
        with pytest.raises(ValueError, match="value_range"):
            r2.set_transfer_functions(ctf, OpacityTransferFunction(), value_range=bad)


def test_twelve_bit_ct_in_uint16_uses_the_whole_tf():
    """uint16 data is stored exactly (2 bytes per voxel); its data range
    spans the TF, so 12-bit data looks as its float version over [0, 1]."""
    unit = blob()
    u16 = np.round(unit / unit.max() * 4095).astype(np.uint16)
    expected = renderer(Volume(u16.astype(np.float32) / 4095)).render()
    vol = Volume(u16, value_range=(0, 4095))
    r = renderer(vol)
    assert r.counters()["volume_storage"].lower().startswith("r16")
    got = r.render()
    assert np.abs(got.astype(int) - expected.astype(int)).max() <= 1
    # Without the range, pyvr's rule reads it as a fraction of 65535: faint.
    faint = renderer(Volume(u16)).render()
    assert faint[..., 3].astype(int).sum() < 0.5 * got[..., 3].astype(int).sum()


def test_value_range_drives_empty_space_skipping():
    """Cells the mapped TF leaves empty are skipped; images are unchanged."""
    hu = blob((32, 32, 32)) * 4000.0 - 1000.0
    otf = OpacityTransferFunction([(0.0, 0.0), (0.6, 0.0), (0.7, 0.5), (1.0, 0.5)])
    r = renderer(Volume(hu), otf=otf, value_range=(-1000, 3000))
    assert 0.2 < r.empty_fraction() < 1.0
    with_skip = r.render()
    r.empty_space_skipping = False
    assert np.array_equal(r.render(), with_skip)
    r.set_transfer_functions(ColorTransferFunction(), otf, value_range=(-1000, 30000))
    assert r.empty_fraction() == 1.0  # nothing reaches 0.6 of that range


def test_isosurface_value_is_in_the_tf_domain():
    hu = blob() * 4000.0 - 1000.0
    r = renderer(Volume(hu), value_range=(-1000, 3000))
    r.set_config(RenderConfig(model="isosurface", iso_value=0.15))
    r.render()
    depth = r.depth()
    r0 = renderer(Volume(blob()))
    r0.set_config(RenderConfig(model="isosurface", iso_value=0.15))
    r0.render()
    hit = np.isfinite(depth)
    assert hit.mean() > 0.05 and np.array_equal(hit, np.isfinite(r0.depth()))
    np.testing.assert_allclose(depth[hit], r0.depth()[hit], atol=1e-3)


def test_window_level():
    assert window_level(400, 40) == (-160.0, 240.0)
    assert window_level(*pyvr.transferfunctions.CT_WINDOWS["bone"]) == (-500.0, 1500.0)
    with pytest.raises(ValueError, match="window"):
        window_level(0, 40)


def test_histogram_ignores_nan_and_matches_numpy():
    data = blob()
    data[0, 0, :3] = [np.nan, np.inf, -np.inf]
    vol = Volume(data)
    counts, edges = vol.histogram(bins=32)
    finite = data[np.isfinite(data)]
    np.testing.assert_array_equal(counts, np.histogram(finite, bins=32, range=(finite.min(), finite.max()))[0])
    assert counts.sum() == data.size - 3
    vol.value_range = (0.0, 0.5)
    counts, edges = vol.histogram(bins=10)
    assert edges[0] == 0.0 and edges[-1] == 0.5
    logc, _ = vol.histogram(bins=10, log=True)
    np.testing.assert_allclose(logc, np.log10(1 + counts))
    with pytest.raises(ValueError, match="bins"):
        vol.histogram(bins=0)


def test_crop_box_closed_form_and_oracle():
    """A homogeneous box cropped to a sub-box: alpha = 1 - exp(-a L / ref)
    over the chord through the crop only (Beer–Lambert), and the GPU frame
    equals the f64 integrator's with the same crop."""
    a_tf = 0.004
    vol = Volume(np.full((8, 8, 8), 0.5, np.float32))
    r = VolumeRenderer(W, H, config=RenderConfig(step_size=0.01, max_steps=10000, early_ray_termination=False),
                       light=Light.ambient_only(1.0))
    r.load_volume(vol)
    cam = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, roll=0.0, distance=2.5)
    r.set_camera(cam)
    r.set_transfer_functions(ColorTransferFunction.single_color((0.9, 0.5, 0.2)),
                             OpacityTransferFunction.linear(a_tf, a_tf))
    lo, hi = np.array([-0.5, -0.2, -0.3]), np.array([0.1, 0.5, 0.25])
    r.set_crop_box(lo, hi)
    assert r.crop_box == (tuple(lo), tuple(hi))
    img = r.render(dtype=np.float32)
    L = chords(cam, lo, hi, W, H)
    expected = 1 - np.exp(-a_tf * L / r.config.reference_step_size)
    assert np.abs(img[..., 3] - expected).max() * 255 < 1
    assert expected.max() > 0.2 and (L == 0).mean() > 0.2
    ref = r.render_float64()
    assert np.abs(levels(ref) - levels(img)).max() <= 1
    r.set_crop_box()
    whole = r.render(dtype=np.float32)[..., 3]
    assert np.abs(whole - (1 - np.exp(-a_tf * chords(cam, vol.min_bounds, vol.max_bounds, W, H) / 0.01))).max() * 255 < 1
    with pytest.raises(ValueError, match="greater than min_corner"):
        r.set_crop_box(hi, lo)
    with pytest.raises(ValueError, match="both corners"):
        r.set_crop_box(lo)


def test_background_composites_over_a_colour():
    r = renderer(Volume(blob()))
    pre = r.render(dtype=np.float32, premultiplied=True)
    bg = (0.1, 0.2, 0.3)
    out = r.render(dtype=np.float32, background=bg)
    np.testing.assert_allclose(out[..., 3], 1.0)
    np.testing.assert_allclose(out[..., :3], pre[..., :3] + (1 - pre[..., 3:4]) * np.array(bg), atol=1e-6)
    u8 = r.render(background="white")
    assert (u8[..., 3] == 255).all() and (u8[0, 0, :3] == 255).all()
    with pytest.raises(ValueError, match="background"):
        r.render(background=(2, 0, 0))
    # matplotlib's "none" is no background: the transparent frame, not black.
    for none in ("none", "transparent", "None"):
        np.testing.assert_array_equal(r.render(background=none), r.render())


def test_camera_fit_frames_the_box_at_any_scale():
    """The fitted camera sees the whole box: every corner projects inside
    the image, and a box scaled by 1000 gets the same picture (with the
    step scaled alike)."""
    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([64.0, 32.0, 16.0])
    cam = Camera.fit((lo, hi), azimuth=0.5, elevation=0.3, aspect=1.5)
    p, up = cam.get_camera_vectors()
    f = (cam.target - p) / np.linalg.norm(cam.target - p)
    right = np.cross(f, up) / np.linalg.norm(np.cross(f, up))
    u = np.cross(right, f)
    t = np.tan(cam.fov / 2)
    for corner in np.array(np.meshgrid(*zip(lo, hi))).T.reshape(-1, 3):
        v = corner - p
        x, y = (v @ right) / (v @ f) / (t * 1.5), (v @ u) / (v @ f) / t
        assert abs(x) < 1 and abs(y) < 1
    imgs = []
    for s in (1.0, 1000.0):
        vol = Volume(blob(), min_bounds=np.full(3, -s, np.float32), max_bounds=np.full(3, s, np.float32))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pyvr's "step_size is very large" note, meant for [-1, 1] boxes
            cfg = RenderConfig(step_size=0.01 * s, max_steps=1000, reference_step_size=0.01 * s)
            r = VolumeRenderer(W, H, config=cfg)
        r.load_volume(vol)
        r.set_camera(Camera.fit(vol, azimuth=0.4, elevation=0.2))
        r.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction.linear(0, 0.4))
        imgs.append(r.render().astype(int))
    assert np.abs(imgs[0] - imgs[1]).max() <= 1 and imgs[0][..., 3].max() > 50


def fuel_path():
    path = os.path.join(SHARED_DATA, "fuel.vti")
    return path if os.path.exists(path) else None


def test_a_good_first_picture_of_a_file():
    """pyvr.load + the defaults (no camera, the default TFs, balanced):
    a picture, not a blank image or a max_steps warning."""
    path = fuel_path()
    if path is None:
        return  # the data set lives beside the project, not in it
    vol = pyvr.load(path)
    r = VolumeRenderer(64, 64)
    r.load_volume(vol)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = r.render()
    # fuel.vti is 98% zeros: its plume fills the middle of the framed box.
    assert (img[..., 3] > 0).mean() > 0.03 and img[..., 3].max() > 200
    # The same file in physical units (0..64) is framed by default, and the
    # warning says what to change.
    phys = pyvr.load(path, box="physical")
    r = VolumeRenderer(64, 64)
    r.load_volume(phys)
    with pytest.warns(UserWarning, match=r"pyvr\.load\(path\)"):
        img = r.render()
    assert (img[..., 3] > 0).mean() > 0.03
