"""Bad input is a clear TypeError/ValueError naming the argument (never
OverflowError, PanicException or a silently different picture), and odd but
valid input works: numpy control points, unaligned arrays, memmaps."""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, _core
from pyvr.camera import Camera, CameraError
from pyvr.config import RenderConfigError
from pyvr.lighting import Light, LightError
from pyvr.transferfunctions import (ColorTransferFunction, InvalidControlPointError, OpacityTransferFunction,
                                    TransferFunctionError)
from pyvr.volume import Volume, VolumeError
from scenes import blob, frame, make_renderer


@pytest.fixture(scope="module")
def r():
    r = VolumeRenderer(16, 16)
    r.load_volume(Volume(blob((8, 8, 8), width=0.6)))
    return r


@pytest.mark.parametrize("field", ["step_size", "max_steps", "iso_value", "jitter_seed", "opacity_threshold",
                                   "reference_step_size", "anisotropy", "shadow_step_size"])
def test_bools_are_not_numbers(field):
    with pytest.raises(TypeError, match=f"{field} must be a.*got bool"):
        RenderConfig(**{field: True})
    cfg = RenderConfig()
    with pytest.raises(TypeError, match=field):
        setattr(cfg, field, np.bool_(True))
    with pytest.raises(TypeError, match=field):
        cfg.replace(**{field: False})


@pytest.mark.parametrize("field", ["jitter", "early_ray_termination", "pre_integrated"])
def test_flags_need_bools(field):
    with pytest.raises(TypeError, match=f"{field} must be True or False"):
        RenderConfig(**{field: 1})


@pytest.mark.parametrize("make, exc, message", [
    (lambda: RenderConfig(max_steps=2**63), ValueError, "max_steps must be at most 4294967295"),
    (lambda: RenderConfig(max_steps=2**200), ValueError, "max_steps must be"),
    (lambda: RenderConfig(step_size=10**400), ValueError, "step_size is too large for a float"),
    (lambda: RenderConfig(jitter_seed=-1), ValueError, "jitter_seed must be between 0 and 4294967295"),
    (lambda: RenderConfig(step_size=1j), TypeError, "step_size must be a real number, got complex"),
    (lambda: RenderConfig(step_size="0.1"), TypeError, "step_size must be a real number, got str"),
    (lambda: RenderConfig().with_max_steps(2**64), ValueError, "max_steps must be at most"),
    (lambda: VolumeRenderer(2**32, 4), ValueError, "width must be at most 4294967295"),
    (lambda: VolumeRenderer(True, 4), TypeError, "width must be an integer"),
    (lambda: _core.Renderer(2**40, 4), ValueError, "width must be between 1 and 4294967295"),
    (lambda: _core.Renderer(-1, 4), ValueError, "width must be between 1 and"),
])
def test_out_of_range_numbers_are_value_errors(make, exc, message):
    with pytest.raises(exc, match=message):
        make()


@pytest.mark.parametrize("size, message", [
    ((-1, 3), "size width must be at least 1"),
    ((2**32, 3), "size width must be at most 4294967295"),
    ((3, True), "size height must be an integer"),
])
def test_frame_sizes(r, size, message):
    with pytest.raises((ValueError, TypeError), match=message):
        r.render(size=size)
    with pytest.raises((ValueError, TypeError), match=message):
        r.render_float64(size=size)


def test_transfer_function_sizes(r):
    for bad, exc in ((0, ValueError), (-1, ValueError), (2**62, ValueError), (True, TypeError), (2.5, TypeError)):
        with pytest.raises(exc, match="lut_size"):
            OpacityTransferFunction(lut_size=bad)
        with pytest.raises(exc, match="size"):
            r.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction(), size=bad)
    with pytest.raises(ValueError, match="lut_size must be at most"):
        ColorTransferFunction.from_colormap("viridis", lut_size=10**9)
    limit = _core.device_limits()["max_texture_dimension_2d"]
    with pytest.raises(ValueError, match=f"size must be at most {limit}"):
        r.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction(), size=limit + 1)


def test_custom_tables_must_have_the_right_shape_and_type(r):
    class Short(ColorTransferFunction):
        def to_lut(self, size=None):
            return np.zeros((7, 3))

    class Complex(OpacityTransferFunction):
        def to_lut(self, size=None):
            return np.zeros(size, complex)

    class Flat(ColorTransferFunction):
        def to_lut(self, size=None):
            return np.zeros(size * 3)

    with pytest.raises(ValueError, match=r"Short.to_lut\(256\) must return colours of shape \(256, 3\), got \(7, 3\)"):
        r.set_transfer_functions(Short(), OpacityTransferFunction())
    with pytest.raises(TypeError, match="Complex.to_lut.*must return real opacities"):
        r.set_transfer_functions(ColorTransferFunction(), Complex())
    with pytest.raises(ValueError, match="Flat.to_lut"):
        r.set_transfer_functions(Flat(), OpacityTransferFunction())


@pytest.mark.parametrize("make", [
    lambda: Light.directional([np.nan, 0, 1]),
    lambda: Light.directional([0, 0, 0]),
    lambda: Light.point_light([np.inf, 0, 1]),
    lambda: Light.point_light([0, 0, 1], target=[0, np.nan, 0]),
    lambda: Light(position=np.array([1, 1, 1j])),
])
def test_lights_must_be_finite(make):
    with pytest.raises(ValueError, match="finite|non-zero|real numbers"):
        make()


def test_set_light_checks_a_light_changed_after_creation(r):
    light = Light.default()
    light.position = np.array([np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match="position must be finite"):
        r.set_light(light)


@pytest.mark.parametrize("kwargs, exc, message", [
    (dict(min_bounds=np.array([-1, -1, -1j])), ValueError, "min_bounds must hold real numbers"),
    (dict(max_bounds=np.array([1, 1, np.inf])), ValueError, "max_bounds must be finite"),
    (dict(normals=np.zeros((4, 4, 4, 3), complex)), TypeError, "normals must be a real numeric array"),
])
def test_volumes_must_be_real_and_finite(kwargs, exc, message):
    with pytest.raises(exc, match=message):
        Volume(np.zeros((4, 4, 4), np.float32), **kwargs)


def test_complex_data_is_a_type_error():
    with pytest.raises(TypeError, match="real numeric array, got dtype complex64"):
        Volume(np.zeros((4, 4, 4), np.complex64))


def test_pyvrs_exception_classes_are_value_errors():
    for cls in (InvalidControlPointError, TransferFunctionError, CameraError, LightError, VolumeError,
                RenderConfigError):
        assert issubclass(cls, ValueError), cls
    with pytest.raises(ValueError):
        OpacityTransferFunction([])


def test_numpy_arrays_as_control_points():
    a = OpacityTransferFunction(np.array([[0.0, 0.0], [0.5, 0.2], [1.0, 1.0]]))
    b = OpacityTransferFunction([(0.0, 0.0), (0.5, 0.2), (1.0, 1.0)])
    assert np.array_equal(a.to_lut(64), b.to_lut(64))
    c = ColorTransferFunction(np.array([[0.0, 0, 0, 1], [1.0, 1, 0.5, 0]]))
    d = ColorTransferFunction([(0.0, (0, 0, 1)), (1.0, (1, 0.5, 0))])
    assert np.array_equal(c.to_lut(64), d.to_lut(64))
    e = OpacityTransferFunction([np.array([0.0, 0.0]), np.array([1.0, 0.5])])
    assert e.to_lut(3)[-1] == np.float32(0.5)
    with pytest.raises(InvalidControlPointError, match=r"shape \(N, 2\).*got shape \(2, 3\)"):
        OpacityTransferFunction(np.zeros((2, 3)))


def test_unaligned_arrays_and_memmaps_render_like_plain_arrays(tmp_path):
    data = blob((12, 12, 12), width=0.6)
    buf = np.zeros(data.nbytes + 1, np.uint8)[1:]
    unaligned = buf.view(np.float32).reshape(data.shape)
    unaligned[...] = data
    assert not unaligned.flags.aligned and unaligned.flags.c_contiguous
    mm = np.memmap(tmp_path / "v.dat", dtype=np.float32, mode="w+", shape=data.shape)
    mm[...] = data
    ref = frame(make_renderer(Volume(data)))
    assert np.array_equal(frame(make_renderer(Volume(unaligned))), ref)
    # A memmap is rendered in bricks, whose lit samples take gradients on the
    # fly where a loaded array reads gradient texels: the same rule up to
    # float32 rounding (tests/test_gradient_texels.py).
    assert np.abs(frame(make_renderer(Volume(mm))) - ref).max() * 255 < 0.02
    for a in (unaligned, mm):
        r = make_renderer(Volume(a))
        assert np.abs(r.render_float64(premultiplied=True) - make_renderer(Volume(data)).render_float64(
            premultiplied=True)).max() == 0


def test_camera_at_its_target_is_a_clear_error():
    with pytest.raises(ValueError, match="distance must be positive"):
        Camera.from_spherical(target=np.zeros(3), distance=0.0, azimuth=0.0, elevation=0.0, roll=0.0)
    with pytest.raises(ValueError, match="init_pos must not be at the same location as target"):
        Camera.from_spherical(target=np.zeros(3), distance=1.0, azimuth=0.0, elevation=0.0, roll=0.0,
                              init_pos=np.zeros(3))


def test_absurd_frames_warn_before_they_start(r):
    import warnings

    cfg = RenderConfig(step_size=1e-7, max_steps=2**31 - 1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(ValueError):  # then stops at once: the frame is too big for this device
            r.render(config=cfg, size=(2**32 - 1, 1))
    assert any("may take up to" in str(w.message) and "Ctrl-C" in str(w.message) for w in caught), caught


def test_a_change_that_raises_leaves_the_renderer_as_it_was():
    """A value range whose width overflows (high - low = inf) cannot map
    values onto the transfer functions: load_volume and
    set_transfer_functions refuse it before changing anything."""
    r = make_renderer(Volume(blob((8, 8, 8), width=0.6)))
    before, volume, lut = frame(r), r.get_volume(), r.lut
    wide = (-1e308, 1e308)
    with pytest.raises(ValueError, match=r"value_range \(-1e\+308, 1e\+308\) cannot map uint8 values"):
        r.load_volume(Volume((blob((9, 9, 9), width=0.6) * 255).astype(np.uint8), value_range=wide))
    with pytest.raises(ValueError, match="cannot map float32 values onto the transfer functions"):
        r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0, 1),
                                 value_range=wide)
    assert r.get_volume() is volume and r.value_range == volume.value_range
    np.testing.assert_array_equal(r.lut, lut)
    np.testing.assert_array_equal(frame(r), before)
