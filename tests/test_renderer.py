"""VolumeRenderer behaviour: output layout, orientation, dtypes, warnings,
uploads, and clear errors for bad input."""

import warnings

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, _core
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_closed_form import chords

W, H = 40, 32


def make(vol, config=None, light=None, camera=None, w=W, h=H, otf=None):
    r = VolumeRenderer(w, h, config=config, light=light or Light.ambient_only(1.0))
    r.load_volume(vol)
    r.set_camera(camera or Camera.front_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.grayscale(), otf or OpacityTransferFunction.linear(0.0, 0.5))
    return r


def test_output_layout_and_pil():
    r = make(Volume(create_sample_volume(16, "sphere")))
    img = r.render()
    assert img.shape == (H, W, 4) and img.dtype == np.uint8 and img.flags.c_contiguous
    up = r.render(origin="upper")
    assert np.array_equal(up, img[::-1])
    pil = r.render_to_pil()
    assert pil.size == (W, H) and pil.mode == "RGBA"
    assert np.array_equal(np.asarray(pil), img[::-1])
    f = r.render(dtype=np.float32, premultiplied=True)
    assert f.dtype == np.float32 and np.isfinite(f).all()
    assert np.all(f[..., :3] <= f[..., 3:4] + 1e-6), "premultiplied colour never exceeds alpha"
    with pytest.raises(ValueError, match="origin"):
        r.render(origin="left")
    with pytest.raises(ValueError, match="dtype"):
        r.render(dtype=np.int16)


def test_world_axes_and_non_cubic_orientation():
    # numpy axis 1 is world y (screen right in the front view), axis 2 is
    # world z (screen up; row 0 is the bottom).
    d = np.zeros((6, 10, 14), np.float32)
    d[:, 5:, :] = 1.0
    img = make(Volume(d)).render()
    assert img[:, W // 2:, 3].mean() > 50 * max(img[:, : W // 2 - 2, 3].mean(), 0.1)
    d = np.zeros((6, 10, 14), np.float32)
    d[:, :, 7:] = 1.0
    img = make(Volume(d)).render()
    assert img[H // 2:, :, 3].mean() > 50 * max(img[: H // 2 - 2, :, 3].mean(), 0.1)


def test_early_termination_and_threshold_are_honoured():
    vol = Volume(np.full((8, 8, 8), 1.0, np.float32))
    on = make(vol, RenderConfig(early_ray_termination=True, opacity_threshold=0.6),
              otf=OpacityTransferFunction.linear(0.3, 0.3))
    off = make(vol, RenderConfig(early_ray_termination=False), otf=OpacityTransferFunction.linear(0.3, 0.3))
    a_on = on.render(dtype=np.float32)[H // 2, W // 2, 3]
    a_off = off.render(dtype=np.float32)[H // 2, W // 2, 3]
    # One step at ref: a = 1 - e^-0.3 = 0.259; it takes 4 steps to pass 0.6.
    assert a_on == pytest.approx(1 - np.exp(-0.3 * 4), abs=2e-3)
    assert a_off == pytest.approx(1 - np.exp(-0.3 * 100), abs=1e-3)


def test_max_steps_warning_names_what_would_cross_once():
    vol = Volume(np.full((8, 8, 8), 0.5, np.float32), None, np.full(3, -1, np.float32), np.ones(3, np.float32))
    cfg = RenderConfig.preview()
    r = make(vol, cfg, camera=Camera.isometric_view(distance=3.0), otf=OpacityTransferFunction.linear(0.0, 0.001))
    with pytest.warns(UserWarning, match=r"max_steps=50 cannot cross the volume") as rec:
        r.render()
    msg = str(rec[0].message)
    needed = int(msg.split("max_steps=")[2].split()[0])
    L = chords(Camera.isometric_view(distance=3.0), np.full(3, -1.0), np.ones(3), W, H)
    assert abs(needed - int(np.ceil(L.max() / 0.05))) <= 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r.render()  # once per config and volume box
    r.set_config(cfg.with_max_steps(needed))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r.render()


def test_camera_only_rerender_uploads_no_volume():
    d = create_sample_volume(32, "double_sphere")
    r = make(Volume(d, compute_normal_volume(d)), light=Light.default())
    r.render()
    before = r.counters()
    r.set_camera(Camera.isometric_view())
    r.set_light(Light.directional([0, 1, 0]))
    r.set_config(RenderConfig.fast())
    r.render()
    after = r.counters()
    assert after["volume_uploads"] == before["volume_uploads"] == 1
    assert after["lut_uploads"] == before["lut_uploads"]
    assert r.last_frame_stats["uploaded_bytes"] < 512
    # Value and normal in one Rgba32Float texel, or R32Float + Rgba8Snorm
    # (precision "auto" keeps float32 while the texels fit a CPU's cache).
    texel = 16 if device_limits()["float32_filterable"] else 4 + 4
    assert after["volume_bytes"] == 32**3 * texel


def test_dtypes_layouts_and_inputs_untouched():
    base = create_sample_volume(12, "sphere")
    ref = make(Volume(base)).render()
    u8 = np.round(base * 255).astype(np.uint8)
    u8_copy = u8.copy()
    img8 = make(Volume(u8)).render()
    assert np.abs(img8.astype(int) - ref).max() <= 2
    assert np.array_equal(u8, u8_copy)
    assert make(Volume(u8)).counters()["volume_bytes"] == 12**3
    u16 = np.round(base * 65535).astype(np.uint16)
    assert np.abs(make(Volume(u16)).render().astype(int) - ref).max() <= 1
    f64 = base.astype(np.float64)
    assert np.array_equal(make(Volume(f64)).render(), ref)
    fortran = np.asfortranarray(base)
    assert np.array_equal(make(Volume(fortran)).render(), ref)
    big = np.zeros((24, 12, 12), np.float32)
    big[::2] = base
    strided = big[::2]
    assert not strided.flags.c_contiguous
    assert np.array_equal(make(Volume(strided)).render(), ref)
    mask = base > 0.3
    img_b = make(Volume(mask)).render()
    assert img_b[..., 3].max() > 100
    i16 = (base * 1000).astype(np.int16)
    assert make(Volume(i16)).render()[..., 3].max() > 0  # converted as raw values, clamped by the TF


def test_nan_and_inf_voxels():
    d = create_sample_volume(12, "sphere")
    d[3:6] = np.nan
    d[0, 0, 0] = np.inf
    d[1, 1, 1] = -np.inf
    before = d.copy()
    img = make(Volume(d)).render(dtype=np.float32, premultiplied=True)
    assert np.isfinite(img).all() and img.min() >= 0 and img.max() <= 1
    assert np.array_equal(np.isnan(d), np.isnan(before))
    all_nan = make(Volume(np.full((4, 4, 4), np.nan, np.float32))).render()
    assert not all_nan.any()


def test_gradient_shading_without_normals_varies():
    d = create_sample_volume(32, "sphere")
    r = make(Volume(d), light=Light.directional([-1, 0, 0], ambient=0.1, diffuse=0.9),
             camera=Camera.side_view(), otf=OpacityTransferFunction.linear(0, 1))
    r.set_transfer_functions(ColorTransferFunction.single_color((1.0, 1.0, 1.0)), OpacityTransferFunction.linear(0, 1))
    img = r.render()
    row = img[H // 2, :, 0].astype(int)
    lit = row[img[H // 2, :, 3] > 20]
    # Straight colour is the light intensity: ambient 0.1 on the far side,
    # up to 1.0 facing the light (screen left is world +x in the side view).
    assert lit.max() - lit.min() > 100, "diffuse shading from gradients, not constant"
    assert row[: W // 2].max() > row[W // 2:].max()


@pytest.mark.parametrize("call,exc,msg", [
    (lambda: VolumeRenderer(0, 10), ValueError, "width must be at least 1"),
    (lambda: VolumeRenderer(10.5, 10), TypeError, "width must be an integer"),
    (lambda: VolumeRenderer(config="fast"), TypeError, "Expected RenderConfig instance"),
    (lambda: VolumeRenderer(light=1), TypeError, "Expected Light instance"),
    (lambda: VolumeRenderer(200_000, 200_000), ValueError, "limit"),
])
def test_constructor_errors(call, exc, msg):
    with pytest.raises(exc, match=msg):
        call()


def test_method_errors():
    r = VolumeRenderer(8, 8)
    with pytest.raises(RuntimeError, match="no volume loaded"):
        r.render()
    with pytest.raises(TypeError, match="Expected Volume instance.*from pyvr.volume import Volume"):
        r.load_volume(np.zeros((2, 2, 2)))
    with pytest.raises(TypeError, match="Expected Camera instance"):
        r.set_camera("front")
    with pytest.raises(TypeError, match="Expected Light instance"):
        r.set_light(None)
    with pytest.raises(TypeError, match="Expected RenderConfig instance"):
        r.set_config({"step_size": 0.1})
    with pytest.raises(TypeError, match="real numeric"):
        r.load_volume(Volume(np.zeros((2, 2, 2), np.complex64)))
    bad = RenderConfig()
    bad.reference_step_size = -1.0
    with pytest.raises(ValueError, match="reference_step_size"):
        r.set_config(bad)

    class Wild(OpacityTransferFunction):
        def to_lut(self, size=None):
            return np.full(size or self.lut_size, 2.0, np.float32)

    with pytest.raises(ValueError, match=r"in \[0, 1\]"):
        r.set_transfer_functions(ColorTransferFunction(), Wild())
    assert r.get_camera() is None and r.get_volume() is None


def test_getters_return_stored_objects():
    cfg, light = RenderConfig.fast(), Light.default()
    r = VolumeRenderer(8, 8, config=cfg, light=light)
    vol = Volume(np.zeros((2, 2, 2), np.float32))
    cam = Camera.front_view()
    r.load_volume(vol)
    r.set_camera(cam)
    assert r.get_config() is cfg and r.get_light() is light and r.get_volume() is vol and r.get_camera() is cam


def test_core_rejects_bad_arguments_with_python_errors():
    """The extension checks its own inputs: no panic reaches Python."""
    with pytest.raises(ValueError, match="width must be between 1 and"):
        _core.Renderer(0, 4)
    r = _core.Renderer(4, 4)
    with pytest.raises(TypeError, match="float32, uint8 or uint16"):
        r.set_volume(np.zeros((2, 2, 2), np.float64), None, (0, 0, 0), (1, 1, 1))
    with pytest.raises(TypeError):
        r.set_volume(np.zeros((2, 2), np.float32), None, (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="C-contiguous"):
        r.set_volume(np.zeros((4, 4, 4), np.float32)[::2], None, (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="max_bounds must be greater"):
        r.set_volume(np.zeros((2, 2, 2), np.float32), None, (0, 0, 0), (1, 0, 1))
    with pytest.raises(ValueError, match="Normal volume must have shape"):
        r.set_volume(np.zeros((2, 2, 2), np.float32), np.zeros((2, 2, 3, 3), np.float32), (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match=r"shape \(M, 4\)"):
        r.set_lut(np.zeros((5, 3), np.float32))
    with pytest.raises(ValueError, match="finite"):
        r.set_lut(np.full((2, 4), np.nan, np.float32))
    cam = ((3, 0, 0), (0, 0, 0), (0, 0, 1), 0.8)
    light = ((1, 1, 1), (0, 0, 0), 0.2, 0.8, "directional")
    args = (cam, light, RenderConfig())
    with pytest.raises(ValueError, match="no volume loaded"):
        r.render(*args)
    r.set_volume(np.zeros((2, 2, 2), np.float32), None, (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="no transfer function"):
        r.render(*args)
    r.set_lut(np.zeros((2, 4), np.float32))
    with pytest.raises(ValueError, match="light kind"):
        r.render(cam, light[:4] + ("spot",), args[2])
    with pytest.raises(ValueError, match="fov"):
        r.render(cam[:3] + (3.5,), light, args[2])
    with pytest.raises(ValueError, match="camera position must differ"):
        r.render(((0, 0, 0),) + cam[1:], light, args[2])
    with pytest.raises(ValueError, match="finite"):
        r.render(((np.nan, 0, 0),) + cam[1:], light, args[2])
    with pytest.raises(TypeError, match="tuple of length 4"):
        r.render((1, 2), light, args[2])
    img, stats = r.render(*args)
    assert img.shape == (4, 4, 4) and stats["truncated_needed"] == 0
    straight = (False, True, None, False)
    with pytest.raises(ValueError, match=r"shape \(H, W, 4\)"):
        _core.convert(np.zeros((2, 2, 3), np.float32), straight)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.convert(np.zeros((4, 4, 4), np.float32)[:, ::2], straight)
    with pytest.raises(ValueError, match="length 4"):
        _core.convert(np.zeros((4, 4, 4), np.float32), (False, True))
    assert _core.colormap_table("nope") is None


def test_straight_float_frames_are_numpys_rule_bit_for_bit():
    """render(dtype=float32) un-premultiplies in Rust, on every core (a
    2048x2048 frame took 118-167 ms in numpy on the 2-core VM): the same
    bits as numpy's clip(where(a > 0, c / a, c), 0, 1), around zero and one,
    for NaN, infinities and negative zeros."""
    from pyvr._frames import _straight

    rng = np.random.default_rng(5)
    img = rng.uniform(-0.2, 1.3, (300, 301, 4)).astype(np.float32)
    special = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 1.0, 1e-45, -1e-45], np.float32)
    img.reshape(-1)[::7] = np.resize(special, img.size)[: img.size][::7]
    want = _straight(img)
    before = img.copy()
    got = _core.convert(img, (False, True, None, False))
    assert np.array_equal(img.view(np.uint32), before.view(np.uint32)), "the input is left as it is"
    assert np.array_equal(got[..., 3].view(np.uint32), img[..., 3].view(np.uint32)), "alpha is left as it is"
    assert np.array_equal(got[..., :3].view(np.uint32), want.view(np.uint32))
    assert np.isnan(want).any() and (img[..., 3] <= 0).any() and (want == 1.0).any() and (want == 0.0).any()


def test_frames_are_made_in_the_returned_format_as_numpys_rules_give_it():
    """render() writes each pixel in the asked dtype, colour, background and
    row order as the frame is marched (native march) or copied out (GPU):
    the same bits as numpy's rules applied to the premultiplied float frame,
    for every combination; with a box covering part of the view (missed
    pixels stay zero or take the background) and with a transfer function
    that shows nothing (the frame is never marched)."""
    from pyvr._frames import _straight
    from scenes import blob, make_renderer

    # An emission-heavy ramp makes colour above alpha, and alpha above 0.
    otf = OpacityTransferFunction([(0.0, 0.0), (0.3, 0.0), (1.0, 0.9)])
    r = make_renderer(Volume(blob((20, 18, 16), width=0.6)), size=(37, 29), otf=otf,
                      camera=Camera.isometric_view(distance=6.0))
    bg = (0.25, 1.0, 0.1)

    def numpys(base, dt, premultiplied, background, origin):
        img = base.copy()
        if background is not None:
            img[..., :3] += (1.0 - img[..., 3:4]) * np.asarray(background, np.float32)
            img[..., 3] = 1.0
        if dt == np.uint8:
            a = img[..., 3:4]
            with np.errstate(divide="ignore"):
                scale = np.where(a > 0, np.float32(1) / a, np.float32(1)) if not premultiplied else np.float32(1)
            c = np.concatenate([img[..., :3] * scale, a], axis=-1)
            img = np.clip(np.floor(c * np.float32(255) + np.float32(0.5)), 0, 255).astype(np.uint8)
        elif not premultiplied:
            img = np.concatenate([_straight(img), img[..., 3:4]], axis=-1)
        return img[::-1] if origin == "upper" else img

    # Two frames accumulated are made in float64 sums and converted after.
    for tf_shows, n in ((True, 1), (True, 2), (False, 1)):
        if not tf_shows:
            r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                     OpacityTransferFunction([(0.0, 0.0), (1.0, 0.0)]))
        base = r.render(dtype=np.float32, premultiplied=True, accumulate=n)
        assert (base[..., 3].max() > 0.5 and (base[..., 3] == 0).mean() > 0.2) == tf_shows
        for dt in (np.uint8, np.float32):
            for premultiplied in (False, True):
                for background in (None, bg):
                    for origin in ("lower", "upper"):
                        got = r.render(dtype=dt, premultiplied=premultiplied, background=background, origin=origin,
                                       accumulate=n)
                        want = numpys(base, dt, premultiplied, background, origin)
                        assert got.dtype == dt and got.flags.c_contiguous and got.shape == (29, 37, 4)
                        if dt == np.float32:
                            got, want = got.view(np.uint32), want.view(np.uint32)
                        where = (dt.__name__, premultiplied, background, origin, tf_shows, n)
                        assert np.array_equal(got, want), where


def test_big_endian_data_renders_as_its_values():
    """uint16 and float32 arrays in big-endian byte order (FITS, NRRD, raw
    files from other machines) render exactly as the native arrays do."""
    from scenes import blob, frame, make_renderer
    from pyvr.volume import Volume

    unit = blob((12, 10, 8), scale=3.0)
    for native in ((unit * 65535).astype(np.uint16), unit):
        swapped = native.astype(native.dtype.newbyteorder(">"))
        assert swapped.dtype.byteorder == ">" and np.array_equal(swapped, native)
        a = frame(make_renderer(Volume(native), size=(24, 20)))
        b = frame(make_renderer(Volume(swapped), size=(24, 20)))
        assert a[..., 3].max() > 0.05
        assert np.array_equal(a, b)


def test_threads_sharing_one_renderer_take_turns():
    """Two threads rendering on one renderer: every call succeeds (the
    engine is entered one thread at a time) and gives the same image."""
    import threading

    from scenes import blob, frame, make_renderer
    from pyvr.volume import Volume

    r = make_renderer(Volume(blob((16, 16, 16), scale=3.0)), size=(64, 48))
    expected = frame(r)
    results, errors = [], []

    def work():
        try:
            for _ in range(4):
                results.append(frame(r))
        except Exception as e:  # collected: the assertion below reports it
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert errors == [] and len(results) == 8
    assert all(np.array_equal(img, expected) for img in results)
