"""What uses a renderer needs only pyvr 0.4.1's renderer API, or says
clearly that it needs pyvr's own: the interface runs on a renderer that
has nothing else (a wrapper, a stand-in, pyvr 0.4.1's class), and the
newer consumers reject one with a TypeError naming what they need."""

import matplotlib

matplotlib.use("Agg")

from unittest.mock import MagicMock  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backend_bases import KeyEvent, MouseEvent  # noqa: E402

from pyvr import VolumeRenderer  # noqa: E402
from pyvr.config import RenderConfig  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.interface import cache, matplotlib_interface  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

SIZE = 48


class OldAPIRenderer:
    """A renderer with pyvr 0.4.1's methods and nothing more, as a user's
    wrapper would be; it draws with pyvr's renderer inside and counts the
    calls the interface makes."""

    def __init__(self, width=512, height=512, config=None, light=None):
        self._inner = VolumeRenderer(width, height, config=config, light=light)
        self.width, self.height = width, height
        self.calls = []

    def __getattr__(self, name):
        if name in ("load_volume", "set_camera", "set_light", "get_light", "set_config", "get_config",
                    "set_transfer_functions", "get_volume", "get_camera", "render", "render_to_pil"):
            self.calls.append(name)
            return getattr(self._inner, name)
        raise AttributeError(f"pyvr 0.4.1's renderer has no {name!r}")


@pytest.fixture
def volume():
    d = create_sample_volume(24, "double_sphere")
    return Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]), max_bounds=np.array([1.0, 1, 1]))


@pytest.fixture
def old_ui(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "cache")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(matplotlib_interface, "VolumeRenderer", OldAPIRenderer)
    ui = matplotlib_interface.InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE)
    ui._min_render_interval = 0.0
    ui._build_figure()
    ui.fig.canvas.draw()
    yield ui
    matplotlib.pyplot.close(ui.fig)


def _event(ui, name, ax, fx, fy, button=1, step=0):
    x, y = ax.transAxes.transform((fx, fy))
    c = ui.fig.canvas
    if name == "scroll_event":
        ev = MouseEvent(name, c, x, y, button="up" if step > 0 else "down", step=step)
    else:
        ev = MouseEvent(name, c, x, y, button=button)
    c.callbacks.process(name, ev)


def test_the_window_runs_on_a_renderer_with_only_pyvr_041s_api(old_ui, capsys):
    ui = old_ui
    assert not ui._native and ui.drag_quality is None and ui.refinement is None
    # Frames come from render_to_pil at the renderer's own config: the pixels pyvr's renderer gives.
    shown = np.array(ui.image_display.image.get_array())
    np.testing.assert_array_equal(shown, np.array(ui.renderer._inner.render_to_pil()))
    assert "render_to_pil" in ui.renderer.calls
    # A drag turns the camera and shows full-size frames (no cheap frames without pyvr's renderer).
    az0 = ui.camera_controller.params.azimuth
    ax = ui.image_display.ax
    _event(ui, "button_press_event", ax, 0.5, 0.5)
    _event(ui, "motion_notify_event", ax, 0.7, 0.5)
    assert np.array(ui.image_display.image.get_array()).shape[:2] == (SIZE, SIZE)
    _event(ui, "button_release_event", ax, 0.7, 0.5)
    assert ui.camera_controller.params.azimuth < az0 - 0.05
    after = np.array(ui.image_display.image.get_array())
    assert np.abs(after.astype(int) - shown.astype(int)).max() > 20
    # Scroll, an opacity point, a preset and the keys work too.
    d0 = ui.camera_controller.params.distance
    _event(ui, "scroll_event", ax, 0.5, 0.5, step=1)
    assert ui.camera_controller.params.distance == pytest.approx(0.9 * d0)
    fx, fy = ui.opacity_editor.ax.transAxes.inverted().transform(
        ui.opacity_editor.ax.transData.transform((0.5, 0.8)))
    _event(ui, "button_press_event", ui.opacity_editor.ax, fx, fy)
    _event(ui, "button_release_event", ui.opacity_editor.ax, fx, fy)
    assert len(ui.state.control_points) == 3
    ui._on_preset_change("balanced")
    assert ui.renderer.get_config().step_size == RenderConfig.balanced().step_size
    assert "Switched to 'balanced' preset" in capsys.readouterr().out
    ui.fig.canvas.callbacks.process("key_press_event", KeyEvent("key_press_event", ui.fig.canvas, "l"))
    assert ui.renderer.get_light().is_linked and ui.state.light_linked_to_camera
    # The histogram spans pyvr 0.4.1's [0, 1] (the wrapper has no value_range).
    assert ui.histogram_bin_edges[0] == 0.0 and ui.histogram_bin_edges[-1] == 1.0


def test_high_quality_capture_on_such_a_renderer_restores_its_config(old_ui, tmp_path):
    before = old_ui.renderer.get_config()
    name = old_ui.capture_high_quality_image(str(tmp_path / "hq.png"))
    from PIL import Image

    assert np.array(Image.open(name)).shape == (SIZE, SIZE, 4)
    assert old_ui.renderer.get_config() is before


def test_the_window_survives_a_stand_in_renderer(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path)
    stand_in = MagicMock()
    stand_in.render_to_pil.return_value = np.full((SIZE, SIZE, 3), 7, np.uint8)
    monkeypatch.setattr(matplotlib_interface, "VolumeRenderer", MagicMock(return_value=stand_in))
    ui = matplotlib_interface.InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE)
    img = ui._render_volume()
    assert img.shape == (SIZE, SIZE, 3) and img.max() == 7
    stand_in.set_transfer_functions.assert_called_once()
    ui._on_preset_change("preview")
    stand_in.set_config.assert_called_once()


def test_newer_consumers_name_the_renderer_they_need(volume):
    from pyvr import distributed

    wrapper = OldAPIRenderer(8, 8)
    with pytest.raises(TypeError, match="Expected VolumeRenderer instance"):
        distributed.render(wrapper, volume)
    with pytest.raises(TypeError, match="Expected VolumeRenderer instance"):
        distributed.render_path(wrapper, [])


def test_duck_typed_transfer_functions_use_pyvr_041s_protocol_only(volume):
    """An object with ``lut_size`` and ``to_lut`` is a transfer function, as
    in pyvr 0.4.1; any other attribute it has (even one named value_range)
    is not read."""

    class Ramp:
        lut_size = 64
        value_range = "not pyvr's"

        def to_lut(self, size=None):
            return np.linspace(0.0, 1.0, size or self.lut_size)

    class Grey(Ramp):
        def to_lut(self, size=None):
            return np.repeat(np.linspace(0.0, 1.0, size or self.lut_size)[:, None], 3, axis=1)

    r = VolumeRenderer(16, 16)
    r.load_volume(volume)
    r.set_transfer_functions(Grey(), Ramp())
    assert r.value_range == volume.value_range
    np.testing.assert_allclose(r.lut[:, 3], np.linspace(0, 1, 64), atol=1e-7)


def test_gl_manager_is_a_stand_in_for_pyvr_041s_cleanup():
    r = VolumeRenderer(8, 6)
    m = r.gl_manager
    assert m is r.gl_manager and (m.width, m.height) == (8, 6)
    assert m.cleanup() is None
    assert "no OpenGL context" in repr(m)
    from pyvr.moderngl_renderer.renderer import ModernGLVolumeRenderer

    assert ModernGLVolumeRenderer is VolumeRenderer


def test_pyvr_041_messages_at_run_time(tmp_path):
    """A few of pyvr 0.4.1's messages, raised for real (the surface test
    reads them from the source)."""
    from pyvr.camera import Camera, CameraPath
    from pyvr.dataloaders import load_vtk_volume
    from pyvr.datasets import create_sample_volume as make

    vti = tmp_path / "a.vti"
    vti.write_text(
        '<VTKFile type="ImageData" version="1.0"><ImageData WholeExtent="0 1 0 1 0 1" Origin="0 0 0" '
        'Spacing="1 1 1"><Piece Extent="0 1 0 1 0 1"><PointData Scalars="density">'
        '<DataArray type="Float32" Name="density" format="ascii">0 1 2 3 4 5 6 7</DataArray>'
        "</PointData></Piece></ImageData></VTKFile>")
    with pytest.raises(ValueError, match=r"Scalar array 'Scalars_' not found in .*a\.vti\. "
                                         r"Available arrays: \['density'\]"):
        load_vtk_volume(vti)
    assert load_vtk_volume(vti, scalars_name="density").shape == (2, 2, 2)
    with pytest.raises(ValueError, match="^n_frames must be at least 1$"):
        CameraPath([Camera(), Camera.front_view()]).generate_frames(0)
    with pytest.raises(ValueError, match="Unknown shape: x. Available shapes: sphere, torus, double_sphere"):
        make(8, "x")
    with pytest.raises(ValueError, match="target must be a 3D numpy array"):
        Camera(target=np.zeros(2))
