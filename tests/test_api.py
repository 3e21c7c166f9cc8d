"""pyvr 0.4.1's public API: names, defaults, presets, messages, repr, copies."""

import copy
import pickle

import numpy as np
import pytest

import pyvr
from pyvr.camera import Camera, CameraController, CameraError, CameraPath, get_camera_pos, validate_camera_angles
from pyvr.camera.control import _camera_to_quaternion, _map_to_sphere, _quaternion_to_camera_angles
from pyvr.config import RenderConfig, RenderConfigError
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import (BaseTransferFunction, ColorTransferFunction, InvalidControlPointError,
                                    OpacityTransferFunction)
from pyvr.transferfunctions.base import validate_control_points_format
from pyvr.volume import Volume


# -- RenderConfig ---------------------------------------------------------------
PRESETS = {
    "preview": (0.05, 50, True, 0.80, 34),
    "fast": (0.02, 100, True, 0.90, 86),
    "balanced": (0.01, 500, True, 0.95, 173),
    "high_quality": (0.005, 1000, True, 0.98, 346),
    "ultra_quality": (0.001, 2000, False, 1.0, 1732),
}


@pytest.mark.parametrize("name", PRESETS)
def test_presets(name):
    c = getattr(RenderConfig, name)()
    step, steps, early, thr, samples = PRESETS[name]
    assert (c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold) == (step, steps, early, thr)
    assert c.reference_step_size == 0.01
    assert c.estimate_samples_per_ray() == samples
    assert c.estimate_render_time_relative() == pytest.approx(samples / 173)


def test_config_defaults_repr_eq():
    c = RenderConfig()
    assert c == RenderConfig.balanced()
    assert repr(RenderConfig.fast()) == (
        "RenderConfig(step_size=0.02, max_steps=100, early_termination=True, ~86 samples/ray)")
    assert RenderConfig(0.02, 100) != RenderConfig.balanced()
    assert RenderConfig.custom(0.03, 40).reference_step_size == 0.01
    assert c.opacity_correction == "exponential"
    assert pyvr.RenderConfig is RenderConfig
    assert issubclass(RenderConfigError, Exception)


@pytest.mark.parametrize("kwargs,msg", [
    (dict(step_size=0), "step_size must be positive"),
    (dict(step_size=-1.0), "step_size must be positive"),
    (dict(max_steps=0), "max_steps must be at least 1"),
    (dict(opacity_threshold=1.5), "opacity_threshold must be between 0.0 and 1.0"),
    (dict(reference_step_size=0.0), "reference_step_size"),
    (dict(step_size=float("nan")), "finite"),
    (dict(opacity_correction="linear"), "opacity_correction"),
])
def test_config_validation(kwargs, msg):
    with pytest.raises(ValueError, match=msg):
        RenderConfig(**kwargs)


def test_config_warnings_and_copies():
    with pytest.warns(UserWarning, match="step_size 2.0 is very large"):
        RenderConfig(step_size=2.0)
    with pytest.warns(UserWarning, match="max_steps 20000 is very large"):
        RenderConfig(max_steps=20000)
    c = RenderConfig.balanced()
    d = c.with_step_size(0.008)
    assert d.step_size == 0.008 and c.step_size == 0.01
    assert c.with_max_steps(200).max_steps == 200 and c.max_steps == 500
    with pytest.raises(ValueError, match="max_steps must be at least 1"):
        c.with_max_steps(0)
    e = c.copy()
    e.step_size = 0.5
    assert c.step_size == 0.01
    assert copy.deepcopy(c) == c and pickle.loads(pickle.dumps(c)) == c
    # numpy scalars are numbers (pyvr rejected np.float32)
    assert RenderConfig(step_size=np.float32(0.02), max_steps=np.int64(40)).max_steps == 40


def test_config_subclass_presets():
    class Mine(RenderConfig):
        pass

    assert type(Mine.fast()) is Mine
    assert type(Mine.fast().copy()) is RenderConfig


# -- transfer functions ---------------------------------------------------------------
def test_opacity_tf_luts():
    otf = OpacityTransferFunction.linear(0.0, 1.0)
    lut = otf.to_lut(5)
    assert lut.dtype == np.float32 and lut.shape == (5,)
    np.testing.assert_allclose(lut, [0, 0.25, 0.5, 0.75, 1.0])
    assert otf.to_lut().shape == (256,)
    assert otf(3).shape == (3,)
    step = OpacityTransferFunction.one_step(0.5, 0.1, 0.9)
    assert step.control_points[2] == (0.5 + 1e-12, 0.9)
    np.testing.assert_allclose(step.apply_to_array(np.array([0.2, 0.8])), [0.1, 0.9])
    with pytest.raises(ValueError):
        OpacityTransferFunction.one_step(1.0)
    p = OpacityTransferFunction.peaks([0.3, 0.7], opacity=0.5, eps=0.1)
    expect = [(0.0, 0.0), (0.2, 0.0), (0.3, 0.5), (0.4, 0.0), (0.6, 0.0), (0.7, 0.5), (0.8, 0.0), (1.0, 0.0)]
    assert np.allclose(np.array(p.control_points), np.array(expect), atol=1e-15)
    z = OpacityTransferFunction.peaks([0.0], opacity=0.7)
    assert z.to_lut(11)[0] == pytest.approx(0.7)  # repeated scalar 0: the later point wins
    with pytest.raises(ValueError, match="At least one peak"):
        OpacityTransferFunction.peaks([])
    with pytest.raises(ValueError, match="Peak position 1.5 must be between 0 and 1"):
        OpacityTransferFunction.peaks([1.5])
    assert repr(OpacityTransferFunction()) == (
        "OpacityTransferFunction(control_points=[(0.0, 0.0), (1.0, 1.0)], lut_size=256)")


def test_color_tf():
    ctf = ColorTransferFunction.two_color_ramp((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), lut_size=3)
    lut = ctf.to_lut()
    assert lut.shape == (3, 3) and lut.dtype == np.float32
    np.testing.assert_allclose(lut[1], [0.5, 0, 0.5])
    assert ctf.get_color_at(0.25) == pytest.approx((0.75, 0.0, 0.25))
    assert ctf.apply_to_array(np.zeros((2, 3))).shape == (2, 3, 3)
    assert repr(ctf) == "ColorTransferFunction(2 control points, lut_size=3)"
    assert ColorTransferFunction.grayscale().to_lut(2).tolist() == [[0, 0, 0], [1, 1, 1]]
    color = [0.1, 0.2, 0.3]
    assert ColorTransferFunction.single_color(color).control_points[0][1] is color


def test_from_colormap_with_and_without_matplotlib(monkeypatch):
    with_mpl = ColorTransferFunction.from_colormap("viridis")
    assert len(with_mpl.control_points) == 256
    import builtins

    real_import = builtins.__import__

    def no_mpl(name, *a, **k):
        if name == "matplotlib" or name.startswith("matplotlib."):
            raise ImportError("no matplotlib")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_mpl)
    for name in ["viridis", "plasma", "inferno", "magma", "cividis", "gray"]:
        tf = ColorTransferFunction.from_colormap(name)
        assert len(tf.control_points) == 256
    without = ColorTransferFunction.from_colormap("viridis")
    # 8-bit tables: within half a level of matplotlib's floats.
    assert np.abs(without.to_lut() - with_mpl.to_lut()).max() <= 0.5 / 255 + 1e-6
    with pytest.raises(ValueError, match="Unknown colormap name 'nope'"):
        ColorTransferFunction.from_colormap("nope")
    monkeypatch.setattr(builtins, "__import__", real_import)
    with pytest.raises(ValueError, match="Unknown colormap name 'nope'"):
        ColorTransferFunction.from_colormap("nope")
    ranged = ColorTransferFunction.from_colormap("gray", value_range=(0.2, 0.4), lut_size=3)
    assert [p[0] for p in ranged.control_points] == pytest.approx([0.2, 0.3, 0.4])
    with pytest.raises(ValueError):
        ColorTransferFunction.from_colormap("gray", value_range=(0.0, 2.0))


@pytest.mark.parametrize("points,exc,msg", [
    ([], InvalidControlPointError, "Control points cannot be empty"),
    ([(0.0, 0.5, 1.0)], InvalidControlPointError, "must be a \\(scalar, value\\) tuple"),
    ([("a", 0.5)], InvalidControlPointError, "scalar must be numeric"),
    ([(0.0, "x")], InvalidControlPointError, "value must be numeric"),
    ([(0.0, 1.5)], InvalidControlPointError, "opacity 1.5 outside valid range"),
    ([(1.5, 0.5)], ValueError, "Control point scalar 1.5 outside valid range \\[0.0, 1.0\\]"),
])
def test_opacity_validation(points, exc, msg):
    with pytest.raises(exc, match=msg):
        OpacityTransferFunction(points)


def test_color_validation_and_base():
    with pytest.raises(InvalidControlPointError, match="RGB component 1 value 2.0"):
        ColorTransferFunction([(0.0, (0.0, 2.0, 0.0))])
    with pytest.raises(InvalidControlPointError, match="3-element sequence"):
        ColorTransferFunction([(0.0, (0.0, 1.0))])
    # pyvr's classes stay, and `except ValueError` catches them too.
    assert issubclass(InvalidControlPointError, ValueError)
    with pytest.raises(TypeError):
        BaseTransferFunction()
    with pytest.raises(InvalidControlPointError, match="component 2 must be numeric"):
        validate_control_points_format([(0.0, (0.0, 0.0, "z"))], 3)

    class Stairs(BaseTransferFunction):
        def _get_default_control_points(self):
            return [(0.0, 0.0), (1.0, 1.0)]

        def _validate_control_points(self):
            validate_control_points_format(self.control_points, 1)

        def to_lut(self, size=None):
            n = size or self.lut_size
            return (np.floor(np.linspace(0, 1, n) * 4) / 4).astype(np.float32)

    assert Stairs(lut_size=5)().tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]


# -- camera ---------------------------------------------------------------------
def test_camera_positions_and_matrices():
    p, up = Camera.front_view().get_camera_vectors()
    np.testing.assert_allclose(p, [3, 0, 0], atol=1e-6)
    np.testing.assert_allclose(up, [0, 0, 1], atol=1e-6)
    p, _ = Camera.side_view().get_camera_vectors()
    np.testing.assert_allclose(p, [0, 3, 0], atol=1e-6)
    p, up = Camera.top_view().get_camera_vectors()
    np.testing.assert_allclose(p, [0, 0, 3], atol=1e-6)
    np.testing.assert_allclose(up, [-1, 0, 0], atol=1e-6)
    p, _ = Camera.isometric_view().get_camera_vectors()
    np.testing.assert_allclose(p, [1.8371, 1.8371, 1.5], atol=1e-4)
    np.testing.assert_allclose(Camera.front_view().get_view_matrix(),
                               [[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -3, 1]], atol=1e-6)
    proj = Camera().get_projection_matrix(2.0)
    f = 1 / np.tan(np.pi / 8)
    assert proj[0, 0] == pytest.approx(f / 2) and proj[3, 2] == -1
    p, up = Camera(roll=np.pi / 2).get_camera_vectors()
    np.testing.assert_allclose(up, [0, 1, 0], atol=1e-6)
    assert get_camera_pos(np.zeros(3, np.float32), 0.0, 0.0, 0.0, 2.0)[0] == pytest.approx([0, 0, 2])


@pytest.mark.parametrize("kwargs,msg", [
    (dict(target=[0, 0, 0]), "target must be a 3D numpy array"),
    (dict(azimuth="x"), "azimuth must be numeric"),
    (dict(distance=0), "distance must be positive"),
    (dict(init_pos=np.zeros(3)), "init_pos must not be at the same location as target"),
    (dict(init_up=np.zeros(3)), "init_up must not be the zero vector"),
    (dict(fov=np.pi), "fov must be between 0 and π radians"),
    (dict(near_plane=0), "near_plane must be positive"),
    (dict(far_plane=0.05), "far_plane must be greater than near_plane"),
])
def test_camera_validation(kwargs, msg):
    with pytest.raises(ValueError, match=msg):
        Camera(**kwargs)


def test_camera_misc(tmp_path, capsys):
    cam = Camera.isometric_view(distance=4.0)
    assert repr(cam) == ("Camera(target=[0. 0. 0.], azimuth=0.785 rad (45.0°), elevation=0.524 rad (30.0°), "
                         "roll=0.000 rad (0.0°), distance=4.00)")
    c2 = cam.copy()
    c2.target[0] = 5
    assert cam.target[0] == 0
    cam.save_to_file(tmp_path / "c.json")
    assert Camera.load_from_file(tmp_path / "c.json").to_dict() == cam.to_dict()
    with pytest.warns(UserWarning, match="unusually large"):
        Camera(azimuth=20.0)
    with pytest.raises(CameraError, match="azimuth must be finite"):
        validate_camera_angles(float("inf"), 0, 0)
    assert Camera(azimuth=np.float32(0.5)).azimuth == np.float32(0.5)


def test_controller_and_path():
    ctl = CameraController(Camera.front_view())
    ctl.trackball(50, 0, 512, 512)
    assert ctl.params.azimuth == pytest.approx(-0.098, abs=1e-3)
    ctl = CameraController(Camera.front_view())
    ctl.trackball(0, -50, 512, 512)
    assert ctl.params.elevation == pytest.approx(0.098, abs=1e-3)
    ctl.orbit(0.0, 10.0)
    assert ctl.params.elevation == pytest.approx(np.pi / 2)
    ctl.zoom(1e9)
    assert ctl.params.distance == 1000.0
    with pytest.raises(ValueError, match="Zoom factor must be positive"):
        ctl.zoom(0)
    with pytest.raises(ValueError, match="Viewport dimensions must be positive, got width=0, height=5"):
        ctl.trackball(1, 1, 0, 5)
    with pytest.raises(ValueError, match="Unknown preset: bad"):
        ctl.reset_to_preset("bad")
    ctl.reset_to_preset("side", distance=2.0)
    assert ctl.params.azimuth == pytest.approx(np.pi / 2) and ctl.params.distance == 2.0
    path = CameraPath([Camera.front_view(), Camera(azimuth=3 * np.pi / 2)])
    mid = path.interpolate(0.5)
    # Angles are interpolated as given (pyvr wrapped them and took the short way, -pi/4).
    assert mid.azimuth == pytest.approx(3 * np.pi / 4)
    assert len(path.generate_frames(5)) == 5
    with pytest.raises(ValueError, match="At least 2 keyframes"):
        CameraPath([Camera()])
    with pytest.raises(ValueError, match="t must be between 0.0 and 1.0"):
        path.interpolate(1.5)
    v = _map_to_sphere(0.3, 0.4)
    assert np.linalg.norm(v) == pytest.approx(1.0)
    cam = Camera.isometric_view()
    rot = _camera_to_quaternion(cam)
    az, el, roll = _quaternion_to_camera_angles(rot, cam.target, cam.distance, cam.init_pos, cam.init_up)
    assert (az, el, roll) == pytest.approx((np.pi / 4, np.pi / 6, 0.0), abs=1e-5)


# -- light and volume ---------------------------------------------------------------
def test_light():
    l = Light.default()
    assert repr(l) == "Light(position=[1. 1. 1.], target=[0. 0. 0.], ambient=0.20, diffuse=0.80)"
    d = Light.directional([1, 0, 0], distance=5)
    np.testing.assert_allclose(d.position, [-5, 0, 0])
    np.testing.assert_allclose(d.get_direction(), [1, 0, 0])
    assert Light.ambient_only().get_direction().tolist() == [0, 0, -1]
    assert Light.point_light([5, 5, 5]).kind == "point" and l.kind == "directional"
    assert Light.point_light([5, 5, 5]).copy().kind == "point"
    with pytest.raises(ValueError, match="ambient_intensity must be between 0.0 and 1.0"):
        Light(ambient_intensity=2.0)
    with pytest.raises(ValueError, match="Light is not linked to camera"):
        l.update_from_camera(Camera())
    lk = Light.camera_linked()
    assert lk.is_linked and lk.get_offsets() == {"azimuth": 0.0, "elevation": 0.0, "distance": 0.0}
    lk.update_from_camera(Camera.front_view())
    np.testing.assert_allclose(lk.position, [3, 0, 0], atol=1e-6)


def test_volume():
    d = np.zeros((4, 5, 6), np.float32)
    v = Volume(d, name="v")
    assert repr(v) == ("Volume('v', shape=(4, 5, 6), bounds=[[-0.5 -0.5 -0.5], [0.5 0.5 0.5]], no normals)")
    np.testing.assert_allclose(v.voxel_spacing, [0.25, 0.2, 1 / 6])
    with pytest.raises(ValueError, match="Volume data must be 3D, got shape \\(2, 2\\)"):
        Volume(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="Normal volume must have shape"):
        Volume(d, normals=np.zeros((4, 5, 6)))
    with pytest.raises(ValueError, match="max_bounds must be greater than min_bounds"):
        Volume(d, max_bounds=np.array([0.5, -0.5, 0.5], np.float32))
    v.compute_normals()
    assert v.has_normals and v.normals.shape == (4, 5, 6, 3)
    n = Volume(np.arange(8, dtype=np.float64).reshape(2, 2, 2)).normalize()
    assert n.data.dtype == np.float32 and n.data.max() == 1.0


def test_datasets():
    for shape in ["sphere", "torus", "double_sphere", "cube", "helix", "random_blob"]:
        v = create_sample_volume(16, shape)
        assert v.shape == (16, 16, 16) and v.dtype == np.float32
        assert 0 <= v.min() and v.max() <= 1
    with pytest.raises(ValueError, match="Unknown shape: x. Available shapes"):
        create_sample_volume(8, "x")
    ds = create_sample_volume(32, "double_sphere")
    # meshgrid 'xy': the spheres sit apart along numpy axis 1
    assert ds[16, 16 + 5, 16] > ds[16 + 5, 16, 16]
    n = compute_normal_volume(ds)
    assert n.shape == (32, 32, 32, 3)
    assert np.linalg.norm(n[16, 20, 16]) == pytest.approx(1.0, abs=1e-4)


def test_module_layout():
    import pyvr.moderngl_renderer as mr

    assert mr.VolumeRenderer is pyvr.VolumeRenderer is mr.ModernGLVolumeRenderer
    assert pyvr.transferfunctions.__version__ == "0.2.2" and pyvr.camera.__version__ == "0.2.1"
    for name in mr.__all__:
        assert hasattr(mr, name)


def test_large_camera_angles_warn_instead_of_printing(capsys):
    with pytest.warns(UserWarning, match="azimuth = 20.000 rad"):
        Camera(azimuth=20.0)
    assert capsys.readouterr().out == ""


def test_random_blob_leaves_numpys_global_generator_alone():
    np.random.seed(7)
    expected = np.random.random()
    np.random.seed(7)
    a = create_sample_volume(16, "random_blob")
    assert np.random.random() == expected
    assert np.array_equal(a, create_sample_volume(16, "random_blob"))  # still seeded: the same blob every call


def test_no_runtime_dir_message_without_xdg_runtime_dir():
    """Mesa prints "XDG_RUNTIME_DIR is invalid or not set" when a device opens
    without one; pyvr gives its process a private folder first."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "XDG_RUNTIME_DIR"}
    code = "import pyvr; r = pyvr.VolumeRenderer(4, 4); print(r.device != '')"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "True", run.stderr
    assert "XDG_RUNTIME_DIR" not in run.stderr
