"""The matplotlib interface driven headless (Agg) with synthesized mouse,
scroll and key events on the real figure: every binding changes the state
it should and the pixels shown."""

import matplotlib

matplotlib.use("Agg")

from unittest.mock import MagicMock

import numpy as np
import pytest
from matplotlib.backend_bases import KeyEvent, MouseEvent

from pyvr import VolumeRenderer
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.interface import ColorSelector, ImageDisplay, InteractiveVolumeRenderer, InterfaceState, OpacityEditor
from pyvr.interface import cache, matplotlib_interface, state, widgets
from pyvr.interface.widgets import FPSCounter, PresetSelector
from pyvr.volume import Volume

SIZE = 64


@pytest.fixture(scope="module")
def volume():
    d = create_sample_volume(32, "double_sphere")
    return Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]), max_bounds=np.array([1.0, 1, 1]))


@pytest.fixture
def ui(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "cache")
    monkeypatch.chdir(tmp_path)
    ivr = InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE)
    ivr._min_render_interval = 0.0  # every synthesized event renders
    # A budget no frame meets: drag frames go to the coarsest scale, whatever this machine's speed.
    ivr.drag_quality.target_fps = 1e5
    ivr._build_figure()
    ivr.fig.canvas.draw()
    yield ivr
    matplotlib.pyplot.close(ivr.fig)


def mouse(ui, name, ax, fx, fy, button=1, step=0):
    """Dispatch a mouse event at axes fraction (fx, fy) of ``ax``."""
    x, y = ax.transAxes.transform((fx, fy))
    canvas = ui.fig.canvas
    if name == "scroll_event":
        ev = MouseEvent(name, canvas, x, y, button="up" if step > 0 else "down", step=step)
    else:
        ev = MouseEvent(name, canvas, x, y, button=button)
    canvas.callbacks.process(name, ev)


def data_point(ui, ax, sx, sy):
    """Axes fraction of data point (sx, sy) in the opacity editor."""
    return ax.transAxes.inverted().transform(ax.transData.transform((sx, sy)))


def key(ui, k):
    ui.fig.canvas.callbacks.process("key_press_event", KeyEvent("key_press_event", ui.fig.canvas, k))


def shown(ui):
    return np.array(ui.image_display.image.get_array())


def drag_image(ui, dx_frac, dy_frac=0.0, steps=3):
    ax = ui.image_display.ax
    mouse(ui, "button_press_event", ax, 0.5, 0.5)
    for i in range(1, steps + 1):
        mouse(ui, "motion_notify_event", ax, 0.5 + dx_frac * i / steps, 0.5 + dy_frac * i / steps)
    during = shown(ui)
    mouse(ui, "button_release_event", ax, 0.5 + dx_frac, 0.5 + dy_frac)
    return during


def test_public_names_and_module_level_renderer():
    import pyvr.interface as iface

    assert set(iface.__all__) == {"InteractiveVolumeRenderer", "ImageDisplay", "OpacityEditor", "ColorSelector",
                                  "InterfaceState"}
    assert matplotlib_interface.VolumeRenderer is __import__("pyvr").VolumeRenderer
    assert widgets.PresetSelector is PresetSelector and state.InterfaceState is InterfaceState


def test_constructor_uses_the_module_level_renderer(volume, monkeypatch, tmp_path):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path)
    made = {}
    real = matplotlib_interface.VolumeRenderer

    def spy(**kwargs):
        made.update(kwargs)
        return real(**kwargs)

    monkeypatch.setattr(matplotlib_interface, "VolumeRenderer", spy)
    ivr = InteractiveVolumeRenderer(volume, width=32, height=24)
    assert made["width"] == 32 and made["height"] == 24
    assert ivr.state.current_preset_name == "fast"  # the default config is pyvr's fast preset
    assert ivr.renderer.get_config().step_size == 0.02
    # ...with rays long enough to cross the [-1, 1] box (pyvr's 100 steps of 0.02 stop at 2 units).
    assert ivr.renderer.get_config().max_steps * 0.02 >= 2 * np.sqrt(3)
    assert ivr.camera_controller.params.azimuth == pytest.approx(np.pi / 4)


def test_trackball_drag_turns_the_camera_and_the_pixels(ui):
    before = shown(ui).copy()
    az0 = ui.camera_controller.params.azimuth
    during = drag_image(ui, 0.15)
    after = shown(ui)
    assert ui.camera_controller.params.azimuth < az0 - 0.1  # dragging right turns the view as pyvr's trackball
    # While dragging the frame is smaller (cheaper); after release full size again.
    assert during.shape[0] < SIZE and after.shape[:2] == (SIZE, SIZE)
    assert np.abs(after.astype(int) - before.astype(int)).max() > 20
    assert len(ui.drag_latencies) >= 3 and len(ui.release_latencies) >= 1


def test_orbit_mode_and_vertical_drag(ui):
    key(ui, "t")
    assert ui.state.camera_control_mode == "orbit"
    el0, az0 = ui.camera_controller.params.elevation, ui.camera_controller.params.azimuth
    ax = ui.image_display.ax
    mouse(ui, "button_press_event", ax, 0.5, 0.5)
    mouse(ui, "motion_notify_event", ax, 0.5, 0.6)
    mouse(ui, "button_release_event", ax, 0.5, 0.6)
    p = ui.camera_controller.params
    # The drag is measured in image pixels (ydata, growing upward).
    to_image = ax.transData.inverted()
    y0, y1 = (to_image.transform((x, y))[1] for x, y in ax.transAxes.transform([(0.5, 0.5), (0.5, 0.6)]))
    assert y1 > y0
    assert p.elevation == pytest.approx(el0 + 0.005 * (y1 - y0)) and p.azimuth == pytest.approx(az0)
    key(ui, "t")
    assert ui.state.camera_control_mode == "trackball"


def test_scroll_zooms_and_settles_to_full_quality(ui):
    d0 = ui.camera_controller.params.distance
    before = shown(ui).copy()
    mouse(ui, "scroll_event", ui.image_display.ax, 0.5, 0.5, step=1)
    assert ui.camera_controller.params.distance == pytest.approx(d0 * 0.9)
    assert shown(ui).shape[0] < SIZE  # cheap until the wheel rests
    ui._on_scroll_end()  # what the 500 ms timer calls
    after = shown(ui)
    assert after.shape[:2] == (SIZE, SIZE)
    assert (after[..., 3] > 0).sum() > (before[..., 3] > 0).sum()  # nearer: the volume covers more pixels
    mouse(ui, "scroll_event", ui.image_display.ax, 0.5, 0.5, step=-1)
    assert ui.camera_controller.params.distance == pytest.approx(d0 * 0.9 * 1.1)


def test_a_throttled_move_is_rendered_a_moment_later(ui):
    ui._min_render_interval = 10.0  # every move after the first comes too soon
    ui._last_render_time = 0.0
    ax = ui.image_display.ax
    mouse(ui, "button_press_event", ax, 0.5, 0.5)
    before = shown(ui).copy()
    mouse(ui, "motion_notify_event", ax, 0.6, 0.5)
    first = shown(ui).copy()
    assert first.shape != before.shape or not np.array_equal(first, before)  # the first move drew
    mouse(ui, "motion_notify_event", ax, 0.7, 0.5)  # throttled: not drawn yet
    assert np.array_equal(shown(ui), first) and ui.state.needs_render
    ui._render_pending()  # what the timer calls
    assert not np.array_equal(shown(ui), first) and not ui.state.needs_render


def test_a_still_view_refines_to_the_accumulated_mean(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "cache")
    monkeypatch.chdir(tmp_path)
    ui = InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE, refine_frames=5)
    ui._min_render_interval = 0.0
    ui._build_figure()
    try:
        full = shown(ui).copy()
        assert np.array_equal(full, ui.renderer.render(origin="upper"))
        # What the timer calls: frames 1-3 keep the full frame, 4 and 5 show
        # the running mean of unbiased frames, then it stops.
        for k in range(1, 6):
            ui._refine_step()
            expected = full if k < 4 else ui.renderer.render(origin="upper", accumulate=k)
            assert np.array_equal(shown(ui), expected), k
        assert ui.refinement.count == 5 and not ui.refinement.pending
        # A drag stops it; the full frame on release starts it over.
        drag_image(ui, 0.1)
        assert ui.refinement.count == 0 and ui.refinement.pending
    finally:
        matplotlib.pyplot.close(ui.fig)
    with pytest.raises(ValueError, match="refine_frames"):
        InteractiveVolumeRenderer(volume, width=8, height=8, refine_frames=-2)


def test_auto_quality_key_keeps_full_frames_while_dragging(ui):
    key(ui, "q")
    assert not ui.state.auto_quality_enabled
    during = drag_image(ui, 0.1)
    assert during.shape[:2] == (SIZE, SIZE)
    key(ui, "q")
    assert ui.state.auto_quality_enabled


def test_opacity_editor_add_drag_remove(ui):
    ax = ui.opacity_editor.ax
    before = shown(ui).copy()
    fx, fy = data_point(ui, ax, 0.5, 0.9)
    mouse(ui, "button_press_event", ax, fx, fy)
    assert len(ui.state.control_points) == 3 and ui.state.selected_control_point == 1
    assert ui.state.control_points[1] == pytest.approx((0.5, 0.9), abs=0.01)
    gx, gy = data_point(ui, ax, 0.3, 0.95)
    mouse(ui, "motion_notify_event", ax, gx, gy)
    mouse(ui, "button_release_event", ax, gx, gy)
    assert ui.state.control_points[1] == pytest.approx((0.3, 0.95), abs=0.01)
    lut = ui.renderer.lut[:, 3]
    assert lut[int(0.3 * 255)] == pytest.approx(0.95, abs=0.02)  # the renderer got the new function
    after = shown(ui)
    assert (after[..., 3].astype(int) - before[..., 3].astype(int)).mean() > 10  # more opaque
    # Right-click on the point removes it; end points cannot be removed.
    mouse(ui, "button_press_event", ax, gx, gy, button=3)
    assert len(ui.state.control_points) == 2
    ex, ey = data_point(ui, ax, 1.0, 1.0)
    mouse(ui, "button_press_event", ax, ex, ey, button=3)
    assert len(ui.state.control_points) == 2


def test_end_points_move_only_vertically_and_delete_key(ui):
    ax = ui.opacity_editor.ax
    fx, fy = data_point(ui, ax, 1.0, 1.0)
    mouse(ui, "button_press_event", ax, fx, fy)
    assert ui.state.selected_control_point == 1
    gx, gy = data_point(ui, ax, 0.7, 0.4)
    mouse(ui, "motion_notify_event", ax, gx, gy)
    mouse(ui, "button_release_event", ax, gx, gy)
    assert ui.state.control_points[-1] == pytest.approx((1.0, 0.4), abs=0.01)
    key(ui, "escape")
    assert ui.state.selected_control_point is None
    hx, hy = data_point(ui, ax, 0.5, 0.1)
    mouse(ui, "button_press_event", ax, hx, hy)
    mouse(ui, "button_release_event", ax, hx, hy)
    assert len(ui.state.control_points) == 3
    key(ui, "delete")
    assert len(ui.state.control_points) == 2


def _click_radio(ui, selector, label):
    text = selector.radio.labels[selector.LABELS.index(label)]
    bbox = text.get_window_extent(ui.fig.canvas.get_renderer())
    canvas = ui.fig.canvas
    for name in ("button_press_event", "button_release_event"):
        ev = MouseEvent(name, canvas, bbox.x0 + 2, (bbox.y0 + bbox.y1) / 2, button=1)
        canvas.callbacks.process(name, ev)


def test_colormap_and_preset_selectors_by_click(ui):
    _click_radio(ui, ui.color_selector, "gray")
    assert ui.state.current_colormap == "gray"
    img = shown(ui).astype(int)
    lit = img[..., 3] > 0
    assert lit.sum() > 50
    # gray colormap: red, green and blue equal where anything is drawn
    assert np.abs(img[..., 0] - img[..., 1])[lit].max() <= 1 and np.abs(img[..., 1] - img[..., 2])[lit].max() <= 1
    fast = shown(ui).copy()
    _click_radio(ui, ui.preset_selector, "Balanced")
    assert ui.state.current_preset_name == "balanced"
    assert ui.renderer.get_config().step_size == 0.01
    finer = shown(ui)
    assert np.abs(finer.astype(int) - fast.astype(int)).max() >= 1  # half the step: a (slightly) different frame


def test_reset_key_and_light_link_key(ui):
    start = shown(ui).copy()
    drag_image(ui, 0.2)
    assert not np.array_equal(shown(ui), start)
    key(ui, "r")
    p = ui.camera_controller.params
    assert (p.azimuth, p.elevation, p.distance) == pytest.approx((np.pi / 4, np.pi / 6, 3.0))
    before = shown(ui).copy()
    assert np.array_equal(before, start)  # the first view again, pixel for pixel
    key(ui, "l")
    light = ui.renderer.get_light()
    assert ui.state.light_linked_to_camera and light.is_linked
    pos, _ = ui.camera_controller.params.get_camera_vectors()
    np.testing.assert_allclose(light.position, pos, atol=1e-5)  # a headlight
    assert np.abs(shown(ui).astype(int) - before.astype(int)).max() > 10  # lit from elsewhere now
    drag_image(ui, 0.1)
    pos, _ = ui.camera_controller.params.get_camera_vectors()
    np.testing.assert_allclose(light.position, pos, atol=1e-5)  # and it followed the drag
    key(ui, "l")
    assert not light.is_linked and not ui.state.light_linked_to_camera


def test_the_o_key_switches_to_parallel_rays_and_back(ui):
    start = shown(ui).copy()
    key(ui, "o")
    p = ui.camera_controller.params
    assert p.projection == "orthographic" and ui.renderer.camera.projection == "orthographic"
    ortho = shown(ui).copy()
    # Another picture, and the one the renderer gives for that camera.
    assert np.abs(ortho.astype(int) - start.astype(int)).max() > 10
    key(ui, "r")
    assert ui.camera_controller.params.projection == "orthographic"  # the view resets, not the projection
    key(ui, "o")
    key(ui, "r")
    assert ui.camera_controller.params.projection == "perspective"
    assert np.array_equal(shown(ui), start)


def test_the_value_under_the_mouse_and_a_double_click_to_turn_about_it(ui):
    ax = ui.image_display.ax
    mouse(ui, "motion_notify_event", ax, 0.5, 0.5)
    label = ax.get_xlabel()
    col, row = int(0.5 * ui.width), int(0.5 * ui.height)
    picked = ui.renderer.pick(col, row)
    assert picked.hit and label == f"value {float(picked.value):.4g} at voxel {tuple(int(i) for i in picked.index)}"
    mouse(ui, "motion_notify_event", ax, 0.01, 0.01)  # a corner: the ray meets nothing there
    assert ax.get_xlabel() == ""
    # A double-click makes the point under it the view's centre, same direction.
    before = ui.camera_controller.params.get_camera_vectors()[0] - ui.camera_controller.params.target
    x, y = ax.transAxes.transform((0.5, 0.5))
    ev = MouseEvent("button_press_event", ui.fig.canvas, x, y, button=1, dblclick=True)
    ui.fig.canvas.callbacks.process("button_press_event", ev)
    p = ui.camera_controller.params
    np.testing.assert_allclose(p.target, picked.position, atol=1e-5)
    np.testing.assert_allclose(p.get_camera_vectors()[0] - p.target, before, atol=1e-4)
    assert ui.renderer.camera is p or np.allclose(ui.renderer.camera.target, p.target)


def test_fps_histogram_and_save_keys(ui, tmp_path):
    key(ui, "f")
    assert not ui.state.show_fps and not ui.image_display.fps_text.get_visible()
    key(ui, "h")
    assert not ui.state.show_histogram and not any(b.get_visible() for b in ui.opacity_editor.histogram_bars)
    key(ui, "s")
    saved = list(tmp_path.glob("pyvr_render_*.png"))
    assert len(saved) == 1
    from PIL import Image

    assert np.array_equal(np.array(Image.open(saved[0])), ui._cached_image)


def test_quit_keymap_keeps_ctrl_w_only(ui):
    quit_keys = matplotlib.rcParams["keymap.quit"]
    assert "q" not in quit_keys and "ctrl+w" in quit_keys
    assert matplotlib.rcParams["keymap.save"] == []


def test_high_quality_capture_and_mode(ui, tmp_path):
    name = ui.capture_high_quality_image(str(tmp_path / "hq.png"))
    from PIL import Image

    img = np.array(Image.open(name))
    assert img.shape == (SIZE, SIZE, 4) and img[..., 3].max() > 0
    assert ui.state.current_preset_name == "fast"  # the preset in use is unchanged
    ui.set_high_quality_mode()
    assert ui.state.current_preset_name == "high_quality" and ui.preset_selector.get_preset() == "high_quality"
    assert ui.renderer.get_config().step_size == 0.005


def test_camera_linked_lighting_offsets(ui):
    ui.set_camera_linked_lighting(azimuth_offset=np.pi / 2)
    c = ui.camera_controller.params.copy()
    c.azimuth += np.pi / 2
    pos, _ = c.get_camera_vectors()
    np.testing.assert_allclose(ui.renderer.get_light().position, pos, atol=1e-5)


def test_render_error_gives_pyvrs_placeholder_and_a_warning(ui, monkeypatch):
    def boom(**kwargs):
        raise RuntimeError("device lost")

    monkeypatch.setattr(ui.renderer, "render", boom)
    ui.state.needs_render = True
    with pytest.warns(RuntimeWarning, match="Rendering error: device lost"):
        img = ui._render_volume()
    assert img.shape == (SIZE, SIZE, 3) and img.max() == 0


# -- a renderer with pyvr 0.4.1's API only ---------------------------------
# The window drives any renderer through pyvr 0.4.1's API (a user's wrapper,
# pyvr 0.4.1's own class, a test stand-in); pyvr's renderer adds cheap drag
# frames, refinement and the value-range histogram.


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
def old_ui(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "cache")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(matplotlib_interface, "VolumeRenderer", OldAPIRenderer)
    ui = InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE)
    ui._min_render_interval = 0.0
    ui._build_figure()
    ui.fig.canvas.draw()
    yield ui
    matplotlib.pyplot.close(ui.fig)


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
    mouse(ui, "button_press_event", ax, 0.5, 0.5)
    mouse(ui, "motion_notify_event", ax, 0.7, 0.5)
    assert np.array(ui.image_display.image.get_array()).shape[:2] == (SIZE, SIZE)
    mouse(ui, "button_release_event", ax, 0.7, 0.5)
    assert ui.camera_controller.params.azimuth < az0 - 0.05
    after = np.array(ui.image_display.image.get_array())
    assert np.abs(after.astype(int) - shown.astype(int)).max() > 20
    # Scroll, an opacity point, a preset and the keys work too.
    d0 = ui.camera_controller.params.distance
    mouse(ui, "scroll_event", ax, 0.5, 0.5, step=1)
    assert ui.camera_controller.params.distance == pytest.approx(0.9 * d0)
    fx, fy = ui.opacity_editor.ax.transAxes.inverted().transform(
        ui.opacity_editor.ax.transData.transform((0.5, 0.8)))
    mouse(ui, "button_press_event", ui.opacity_editor.ax, fx, fy)
    mouse(ui, "button_release_event", ui.opacity_editor.ax, fx, fy)
    assert len(ui.state.control_points) == 3
    ui._on_preset_change("balanced")
    assert ui.renderer.get_config().step_size == 0.01
    assert "Switched to 'balanced' preset" in capsys.readouterr().out
    key(ui, "l")
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
    ui = InteractiveVolumeRenderer(volume, width=SIZE, height=SIZE)
    img = ui._render_volume()
    assert img.shape == (SIZE, SIZE, 3) and img.max() == 7
    stand_in.set_transfer_functions.assert_called_once()
    ui._on_preset_change("preview")
    stand_in.set_config.assert_called_once()


def test_histogram_cache_lives_in_its_folder(volume, tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "c")
    edges, counts = cache.get_or_compute_histogram(volume.data, 64)
    files = list((tmp_path / "c").glob("*.npz"))
    assert len(files) == 1 and len(counts) == 64 and edges[0] == 0.0 and edges[-1] == 1.0
    ref = np.log10(np.histogram(volume.data, bins=64, range=(0, 1))[0] + 1.0)
    np.testing.assert_allclose(counts, ref)
    again = cache.get_cached_histogram(volume.data)
    np.testing.assert_array_equal(again[1], counts)
    assert cache.clear_histogram_cache() == 1 and cache.get_cached_histogram(volume.data) is None
    # In data units: the range the transfer function spans.
    hu = (volume.data * 2000 - 1000).astype(np.int16)
    e2, c2 = cache.compute_log_histogram(hu, 32, value_range=(-1000, 1000))
    assert e2[0] == -1000 and e2[-1] == 1000 and c2.max() > 0
    assert "site-packages" not in str(cache._cache_dir())


def test_interface_state_rules():
    s = InterfaceState()
    with pytest.raises(ValueError, match="Must have at least 2 control points"):
        InterfaceState(control_points=[(0.0, 0.0)])
    with pytest.raises(ValueError, match="Control point opacity 2.0 out of range"):
        InterfaceState(control_points=[(0.0, 0.0), (1.0, 2.0)])
    i = s.add_control_point(0.5, 0.5)
    assert i == 1
    with pytest.raises(ValueError, match="Scalar 1.5 out of range"):
        s.add_control_point(1.5, 0.5)
    with pytest.raises(ValueError, match="Cannot remove first or last control point"):
        s.remove_control_point(0)
    s.select_control_point(1)
    s.add_control_point(0.7, 0.2)
    s.update_control_point(1, 0.9, 0.3)  # passes the 0.7 point: re-sorted, selection follows
    assert s.control_points == [(0.0, 0.0), (0.7, 0.2), (0.9, 0.3), (1.0, 1.0)] and s.selected_control_point == 2
    s.update_control_point(0, 0.4, 0.6)
    assert s.control_points[0] == (0.0, 0.6)
    with pytest.raises(ValueError, match="Invalid preset 'x'"):
        s.set_preset("x")
    with pytest.raises(IndexError):
        s.select_control_point(9)


def test_widgets_standalone():
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4)
    d = ImageDisplay(axes[0])
    with pytest.raises(ValueError, match="Image must have 3 or 4 channels, got 2"):
        d.update_image(np.zeros((4, 4, 2), np.uint8))
    d.update_image(np.zeros((4, 4, 3), np.uint8))
    e = OpacityEditor(axes[1])
    e.update_plot([(0, 0), (0.5, 0.2), (1, 1)], selected_index=1)
    assert e.find_point([(0, 0), (0.5, 0.2), (1, 1)], 0.52, 0.21) == 1
    assert e.find_point([(0, 0), (0.5, 0.2), (1, 1)], 0.3, 0.6) is None
    seen = []
    c = ColorSelector(axes[2], on_change=seen.append)
    c.set_colormap("magma")
    assert seen == ["magma"] and c.current_colormap == "magma"
    with pytest.raises(ValueError, match="Colormap 'nope' not available. Choose from"):
        c.set_colormap("nope")
    # A colormap chosen in code, outside the buttons' list, is one more button.
    t = ColorSelector(fig.add_axes([0, 0, 0.1, 0.1]), initial_colormap="twilight")
    assert t.current_colormap == "twilight" and t.radio.labels[-1].get_text() == "twilight"
    assert ColorSelector.AVAILABLE_COLORMAPS[-1] == "jet"
    p = PresetSelector(axes[3], initial_preset="balanced")
    assert p.get_preset() == "balanced"
    assert PresetSelector.PRESET_LABELS[-1] == "Ultra (slowest)"
    plt.close(fig)
    f = FPSCounter(window_size=3)
    assert f.get_fps() == 0.0
    f.frame_times.extend([0.1, 0.1, 0.1])
    assert f.get_fps() == pytest.approx(10.0)
    f.reset()
    assert f.get_fps() == 0.0


def test_import_pyvr_does_not_load_matplotlib():
    import subprocess
    import sys

    code = "import sys, pyvr; print(any(m.startswith(('matplotlib', 'jupyter_rfb', 'imageio', 'tqdm')) for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_real_tk_window_under_xvfb(tmp_path):
    """The same interface in a real window (TkAgg under Xvfb): blitting on a
    GUI canvas, and matplotlib's timer restoring full quality after a scroll."""
    import json
    import os
    import subprocess
    import sys

    script = os.path.join(os.path.dirname(__file__), "interface_window.py")
    env = dict(os.environ, PYVR_CACHE_DIR=str(tmp_path))
    run = subprocess.run(["xvfb-run", "-a", sys.executable, script], capture_output=True, text=True, timeout=300,
                         env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    seen = json.loads(run.stdout.strip().splitlines()[-1])
    assert seen["drag_frame"][0] < 128 and seen["release_frame"][:2] == [128, 128]
    assert seen["scroll_frame"][0] < 128  # cheap while the wheel turns...
    assert seen["settled_frame"][:2] == [128, 128]  # ...full again when the timer fires
    assert seen["drawn"] and seen["azimuth"] < np.pi / 4 - 0.05


@pytest.mark.parametrize("half_width, centre", [(1e30, 0.0), (1e-30, 0.0), (1e6, 0.0), (1e30, 1e30)])
def test_boxes_far_from_pyvrs_scale_are_framed_like_its_own(half_width, centre, monkeypatch, tmp_path):
    # pyvr's presets and home view are made for the [-1, 1] box; a box 1e30
    # wide made the constructor raise (max_steps past 2^32) and would have
    # put the camera inside it. Scaled to the box, the frame is the [-1, 1]
    # box's frame exactly (the engines are scale-free).
    monkeypatch.setattr(cache, "CACHE_DIR", tmp_path / "cache")
    x = np.linspace(-1, 1, 16)
    data = np.exp(-3 * (x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)).astype(np.float32)

    def frame(h, c):
        vol = Volume(data, min_bounds=np.full(3, c - h, np.float32), max_bounds=np.full(3, c + h, np.float32))
        ui = InteractiveVolumeRenderer(vol, width=48, height=40)
        return ui, ui.renderer.render(dtype=np.float32)

    home, expected = frame(1.0, 0.0)
    # pyvr's own box keeps pyvr's view: isometric at distance 3, at the origin.
    assert home.camera_controller.params.distance == 3.0 and not np.any(home.camera_controller.params.target)
    ui, img = frame(half_width, centre)
    assert img[..., 3].max() > 0.5
    assert np.abs(img - expected).max() * 255 < 0.01
    # The home view key brings back the scaled view.
    ui._build_figure()
    ui.camera_controller.orbit(1.0, 0.2)
    ui._reset_view()
    assert np.isclose(ui.camera_controller.params.distance, 3.0 * half_width, rtol=1e-6)
    matplotlib.pyplot.close(ui.fig)
