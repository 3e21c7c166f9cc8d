"""InteractiveVolumeRenderer: pyvr 0.4.1's matplotlib window around a
VolumeRenderer, with a camera, an opacity editor, colormap and quality
selectors, and cheap frames while the user drags.

The window drives its renderer through pyvr 0.4.1's renderer API only
(``set_camera``, ``set_config``, ``get_light``/``set_light``,
``load_volume``, ``set_transfer_functions``, ``render_to_pil``), so a
wrapper, a stand-in or pyvr 0.4.1's own renderer works in it. With
:class:`pyvr.VolumeRenderer` (or a subclass) it also uses what only that
renderer has: cheap frames while dragging, refinement of a still view, and
the histogram in the transfer function's value range.
"""

import time
import warnings
from collections import deque
from datetime import datetime
from typing import Optional

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backend_tools import Cursors
from matplotlib.gridspec import GridSpec

from .. import renderer as _engine
from .._numbers import check_count
from ..camera import Camera, CameraController
from ..config import RenderConfig
from ..interaction import DragQuality
from ..lighting import Light
from ..refinement import Refinement
from ..renderer import VolumeRenderer  # module level: code that patches it keeps working
from ..transferfunctions import ColorTransferFunction, OpacityTransferFunction
from ..transferfunctions.value_range import storage_unit
from ..volume import Volume
from . import cache
from .state import PRESETS, InterfaceState
from .widgets import ColorSelector, ImageDisplay, OpacityEditor, PresetSelector

# Matplotlib's default keys that would fight the interface's own. "quit"
# keeps ctrl+w and loses only q, which toggles auto-quality here.
_CLEARED_KEYMAPS = ("fullscreen", "home", "back", "forward", "pan", "zoom", "save", "quit", "grid", "yscale",
                    "xscale")

_CONTROLS = (
    "Mouse Controls:\n"
    "  Image: Drag=rotate, Scroll=zoom\n"
    "  Opacity: L-click=add/select, R-click=remove, Drag=move\n\n"
    "Keyboard Shortcuts:\n"
    "  r: Reset view          s: Save image\n"
    "  f: Toggle FPS          h: Toggle histogram\n"
    "  l: Toggle light link   q: Toggle auto-quality\n"
    "  t: Toggle control mode Esc: Deselect\n"
    "  Del: Remove selected   ctrl+w: Close\n"
)


def _crossing(cfg: RenderConfig, volume: Volume) -> RenderConfig:
    """The config with max_steps raised so rays cross the whole volume
    (pyvr's presets stop rays after a fixed length, shorter than the
    [-1, 1] box's diagonal for preview, fast and ultra_quality)."""
    lo, hi = np.asarray(volume.min_bounds, np.float64), np.asarray(volume.max_bounds, np.float64)
    needed = int(np.ceil(np.linalg.norm(hi - lo) / cfg.step_size)) + 2
    return cfg.with_max_steps(needed) if needed > cfg.max_steps else cfg


def _on_off(flag) -> str:
    return "ON" if flag else "OFF"


class InteractiveVolumeRenderer:
    """A matplotlib window to explore a Volume.

    >>> InteractiveVolumeRenderer(volume).show()

    While the mouse drags (rotation, an opacity point) or the wheel zooms,
    frames are rendered cheaper (``DragQuality``: coarser step, smaller
    frame) to keep ``target_fps``; full quality returns on release, or
    0.5 s after the last scroll. ``q`` turns this off.

    ``refine_frames=n`` (default 0, off) refines the view while it stands
    still: after the full frame, unbiased frames are rendered one per timer
    tick and, from the fourth on, their running mean is shown
    (``pyvr.refinement``); any event starts over.
    """

    def __init__(self, volume: Volume, width: int = 512, height: int = 512, config: Optional[RenderConfig] = None,
                 camera: Optional[Camera] = None, light: Optional[Light] = None, *, target_fps: float = 10.0,
                 refine_frames: int = 0):
        if not isinstance(volume, Volume):
            raise TypeError(f"Expected Volume instance, got {type(volume)}")
        check_count("refine_frames", refine_frames, low=0, high=1 << 16)  # before the volume is loaded
        # The default is pyvr's (fast), with rays that reach the far side.
        config = _crossing(RenderConfig.fast(), volume) if config is None else config
        camera = Camera.isometric_view(distance=3.0) if camera is None else camera
        light = Light.directional([1, -1, 0]) if light is None else light
        self.volume = volume
        self.width = width
        self.height = height
        self.renderer = VolumeRenderer(width=width, height=height, config=config, light=light)
        self.renderer.set_camera(camera)
        self.renderer.load_volume(volume)
        # What only pyvr's own renderer offers is used only with it.
        self._native = isinstance(self.renderer, _engine.VolumeRenderer)
        self.camera_controller = CameraController(camera)
        self.state = InterfaceState()
        self.state.current_preset_name = self._detect_preset_name(config)
        self.state.light_linked_to_camera = light.is_linked
        self.drag_quality = DragQuality(self.renderer, target_fps=target_fps) if self._native else None
        self.refinement = Refinement(self.renderer, refine_frames) if self._native else None
        self.image_display: Optional[ImageDisplay] = None
        self.opacity_editor: Optional[OpacityEditor] = None
        self.color_selector: Optional[ColorSelector] = None
        self.preset_selector: Optional[PresetSelector] = None
        self.fig = None
        self.info_text = None
        self._cached_image: Optional[np.ndarray] = None
        self._last_render_time = 0.0  # time.time() of the latest frame
        self._min_render_interval = 0.05
        self._interacting = False
        self._drawn = False
        self._timers = {}
        self._event_time: Optional[float] = None
        # Event-to-pixels seconds of the latest frames, drag and full.
        self.drag_latencies: deque = deque(maxlen=200)
        self.release_latencies: deque = deque(maxlen=200)
        self._update_transfer_functions()
        self._load_histogram()

    # -- model -------------------------------------------------------------
    def _detect_preset_name(self, config: RenderConfig) -> str:
        """The preset ``config`` is (pyvr's, or its box-crossing form), else "balanced"."""
        def key(c):
            return (c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold)

        for name in PRESETS:
            p = getattr(RenderConfig, name)()
            if key(config) in (key(p), key(_crossing(p, self.volume))):
                return name
        return "balanced"

    def _preset(self, name: str) -> RenderConfig:
        return _crossing(getattr(RenderConfig, name)(), self.volume)

    def _update_transfer_functions(self) -> None:
        ctf = ColorTransferFunction.from_colormap(self.state.current_colormap)
        otf = OpacityTransferFunction(control_points=list(self.state.control_points))
        self.renderer.set_transfer_functions(ctf, otf)
        self.state.needs_tf_update = False

    def _tf_data_range(self):
        """The values the transfer function's [0, 1] spans."""
        r = self.renderer.value_range if self._native else None
        return r if r is not None else (0.0, storage_unit(self.volume.data.dtype))

    def _load_histogram(self) -> None:
        print("Loading histogram...")
        self.histogram_bin_edges, self.histogram_log_counts = cache.get_or_compute_histogram(
            self.volume.data, 256, self._tf_data_range())
        print("Histogram loaded.")

    @property
    def _cheap(self) -> bool:
        return self._native and self._interacting and self.state.auto_quality_enabled

    def _render_volume(self) -> np.ndarray:
        """The frame for the controller's camera, top row first (smaller
        while interacting); the cached frame while nothing changed. On a
        rendering error it warns and returns pyvr's placeholder, a black
        (height, width, 3) frame."""
        if not self.state.needs_render and self._cached_image is not None:
            return self._cached_image
        try:
            self.renderer.set_camera(self.camera_controller.params)
            if self._cheap:
                img = self.drag_quality.render_drag(origin="upper")
            elif self._native:
                img = self.drag_quality.render_full(origin="upper")
            else:
                img = np.array(self.renderer.render_to_pil())
        except Exception as e:  # the window must survive any one bad frame
            warnings.warn(f"Rendering error: {e}", RuntimeWarning, stacklevel=2)
            return np.zeros((self.height, self.width, 3), np.uint8)
        self._cached_image = img
        return img

    # -- display -----------------------------------------------------------
    def _should_render(self) -> bool:
        """Whether the throttle lets a frame through now (and, if so, starts
        the next interval)."""
        now = time.time()
        if now - self._last_render_time > self._min_render_interval:
            self._last_render_time = now
            return True
        return False

    def _update_display(self, force_render: bool = False) -> None:
        """Bring everything shown up to date with the state: the transfer
        functions, a camera-linked light, the frame (throttled unless
        ``force_render``; a throttled frame is rendered a moment later
        unless another event comes first) and the opacity editor."""
        self._refresh_image(force_render)
        if self.opacity_editor is not None:
            self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)

    def _refresh_image(self, force_render: bool = False) -> None:
        if self.state.needs_tf_update:
            self._update_transfer_functions()
            self.state.needs_render = True
        self._follow_camera_with_light()
        if not self.state.needs_render:
            return
        if force_render or self._should_render():
            self._show_frame()
        else:
            self._later("pending", max(1, int(self._min_render_interval * 1000)), self._render_pending)

    def _follow_camera_with_light(self) -> None:
        light = self.renderer.get_light()
        if not light.is_linked:
            return
        try:
            light.update_from_camera(self.camera_controller.params)
            self.renderer.set_light(light)
            self.state.needs_render = True
        except Exception as e:
            print(f"Warning: Failed to update linked light: {e}")
            light.unlink_from_camera()  # one failure, not one per frame
            self.state.light_linked_to_camera = False

    def _show_frame(self) -> None:
        cheap = self._cheap
        img = self._render_volume()
        self._last_render_time = time.time()
        self.state.needs_render = False
        if self.image_display is None:
            return
        self.image_display.redraw_on_update = False  # drawn below: blitted while cheap
        self.image_display.update_image(img)
        if cheap:
            self.refinement.stop()
            if self.fig is not None:
                self._blit(self.image_display)
        else:
            self._update_status_display()
            if self.refinement is not None:
                self.refinement.restart()
                self._refine_later()
        if self._event_time is not None:
            latency = time.perf_counter() - self._event_time
            if cheap:
                self.drag_latencies.append(latency)
                self.drag_quality.record(latency)
            else:
                self.release_latencies.append(latency)
            self._event_time = None

    def _later(self, name: str, interval_ms: int, callback) -> None:
        """(Re)start the single-shot timer ``name`` (none before the figure)."""
        if self.fig is None:
            return
        timer = self._timers.get(name)
        if timer is None:
            timer = self._timers[name] = self.fig.canvas.new_timer(interval=interval_ms)
            timer.single_shot = True
            timer.add_callback(callback)
        timer.stop()
        timer.start()

    def _render_pending(self) -> None:
        if self.state.needs_render:
            self._update_display(force_render=True)

    def _refine_later(self) -> None:
        if self.refinement.pending:
            # Between frames the event loop runs: any event is handled first.
            self._later("refine", 1, self._refine_step)

    def _refine_step(self) -> None:
        """One more unbiased frame into the still view's running mean."""
        if self._interacting or self.refinement is None or not self.refinement.pending:
            return
        try:
            img = self.refinement.step()
        except Exception as e:  # the window must survive any one bad frame
            warnings.warn(f"Rendering error: {e}", RuntimeWarning, stacklevel=2)
            self.refinement.stop()
            return
        if img is not None and self.image_display is not None:
            self._cached_image = img
            self.image_display.update_image(img)
            self.fig.canvas.draw_idle()
        self._refine_later()

    def _blit(self, widget) -> None:
        """Redraw only ``widget``'s axes (a full figure redraw costs more than
        a cheap frame); a full redraw before the first one."""
        canvas = self.fig.canvas
        if not getattr(canvas, "supports_blit", False) or not self._drawn:
            canvas.draw_idle()
            return
        for artist in widget.artists():
            widget.ax.draw_artist(artist)
        canvas.blit(widget.ax.bbox)

    def _get_full_info_text(self) -> str:
        """The info panel: the controls, then the current status."""
        light = self.renderer.get_light()
        status = [
            "",
            "Current Status:",
            f"  Control Mode: {self.state.camera_control_mode.capitalize()}",
            f"  Preset: {self.state.current_preset_name}",
            f"  FPS: {_on_off(self.state.show_fps)}",
            f"  Histogram: {_on_off(self.state.show_histogram)}",
            f"  Light Linked: {'YES' if light.is_linked else 'NO'}",
            f"  Auto-Quality: {_on_off(self.state.auto_quality_enabled)}",
        ]
        offsets = light.get_offsets() if light.is_linked else None
        if isinstance(offsets, dict):
            status.append(f"    (offsets: az={offsets['azimuth']:.2f}, el={offsets['elevation']:.2f})")
        if self._native:
            c = self.camera_controller.params
            status += [
                f"  Camera: az {np.degrees(c.azimuth):.0f}, el {np.degrees(c.elevation):.0f} deg, "
                f"d {float(c.distance):.2f}",
                f"  Dragging: {self.drag_quality.describe()}",
                f"  Last frame: {self.drag_quality.last_render_seconds * 1e3:.0f} ms",
            ]
        return _CONTROLS + "\n".join(status)

    def _update_status_display(self) -> None:
        """Rewrite the info panel and redraw the figure."""
        if self.info_text is not None:
            self.info_text.set_text(self._get_full_info_text())
        if self.fig is not None:
            self.fig.canvas.draw_idle()

    def _create_layout(self) -> tuple:
        """The figure and its axes: the image on the left (all rows), the
        opacity editor over the colormap selector in the middle, the info
        panel over the preset selector on the right. Returns (figure,
        {"image", "opacity", "color", "preset", "info"})."""
        fig = plt.figure(figsize=(18, 8))
        fig.suptitle("PyVR Interactive Volume Renderer", fontsize=14, fontweight="bold")
        gs = GridSpec(3, 3, figure=fig, width_ratios=[2.0, 1.0, 1.0], height_ratios=[3, 1, 1], hspace=0.45,
                      wspace=0.3)
        axes = {
            "image": fig.add_subplot(gs[:, 0]),
            "opacity": fig.add_subplot(gs[0, 1]),
            "color": fig.add_subplot(gs[1:, 1]),
            "info": fig.add_subplot(gs[0:2, 2]),
            "preset": fig.add_subplot(gs[2, 2]),
        }
        return fig, axes

    def _setup_info_display(self, ax) -> None:
        ax.axis("off")
        self.info_text = ax.text(0.02, 0.98, self._get_full_info_text(), transform=ax.transAxes, fontsize=8,
                                 verticalalignment="top", family="monospace",
                                 bbox=dict(boxstyle="round", facecolor="wheat", alpha=0.3))

    def _build_figure(self):
        """Make the figure, widgets and event connections (``show`` then
        opens the window; tests and screenshots use the figure directly)."""
        if not getattr(self, "_original_keymaps", None):  # the user's keys, not those of an earlier window
            self._original_keymaps = {k: list(matplotlib.rcParams[f"keymap.{k}"]) for k in _CLEARED_KEYMAPS
                                      if f"keymap.{k}" in matplotlib.rcParams}
        for name, keys in self._original_keymaps.items():
            matplotlib.rcParams[f"keymap.{name}"] = ["ctrl+w"] if name == "quit" and "ctrl+w" in keys else []
        self.fig, axes = self._create_layout()
        self.image_display = ImageDisplay(axes["image"], show_fps=self.state.show_fps)
        self.opacity_editor = OpacityEditor(axes["opacity"], show_histogram=self.state.show_histogram)
        self.color_selector = ColorSelector(axes["color"], on_change=self._on_colormap_change,
                                            initial_colormap=self.state.current_colormap)
        self.preset_selector = PresetSelector(axes["preset"], initial_preset=self.state.current_preset_name,
                                              on_change=self._on_preset_change)
        self.opacity_editor.set_histogram(self.histogram_bin_edges, self.histogram_log_counts)
        self._setup_info_display(axes["info"])
        connect = self.fig.canvas.mpl_connect
        self._cids = [connect(name, handler) for name, handler in (
            ("button_press_event", self._on_mouse_press),
            ("button_release_event", self._on_mouse_release),
            ("motion_notify_event", self._on_mouse_move),
            ("scroll_event", self._on_scroll),
            ("key_press_event", self._on_key_press),
            ("axes_enter_event", self._update_cursor),
            ("close_event", self._on_close),
            ("draw_event", self._on_draw),
        )]
        self.state.needs_render = True
        self._update_display(force_render=True)
        return self.fig

    def show(self) -> None:
        """Open the window (blocks until it is closed, as plt.show does)."""
        self._build_figure()
        plt.show()

    def update(self) -> None:
        """Redraw with the current state (e.g. after changing it from code)."""
        self.state.needs_tf_update = True
        self.state.needs_render = True
        self._update_display(force_render=True)

    def _restore_matplotlib_keymaps(self) -> None:
        """Give matplotlib back the keys the window took over."""
        for name, keys in getattr(self, "_original_keymaps", {}).items():
            matplotlib.rcParams[f"keymap.{name}"] = keys
        self._original_keymaps = {}

    # -- interaction quality ---------------------------------------------
    def _switch_to_interaction_quality(self) -> None:
        """An interaction begins: cheap frames until it ends."""
        if not self._interacting:
            self._interacting = True
            if self.drag_quality is not None:
                self.drag_quality.start()

    def _restore_quality_after_interaction(self) -> None:
        """The interaction ended: one frame at the renderer's own quality."""
        self._interacting = False
        self.state.needs_render = True
        self._update_display(force_render=True)

    # -- events ------------------------------------------------------------
    def _in(self, widget, event) -> bool:
        return widget is not None and event.inaxes is not None and event.inaxes == widget.ax

    def _on_mouse_press(self, event) -> None:
        self._event_time = time.perf_counter()
        if self._in(self.image_display, event):
            if event.button == 1:
                self.state.is_dragging_camera = True
                self.state.drag_start_pos = (event.xdata, event.ydata)
                if self.state.auto_quality_enabled:
                    self._switch_to_interaction_quality()
        elif self._in(self.opacity_editor, event):
            if event.button == 1:
                self._handle_opacity_left_click(event)
            elif event.button == 3:
                self._handle_opacity_right_click(event)

    def _find_control_point_near(self, x: float, y: float, threshold: float = 0.05) -> Optional[int]:
        """Index of the control point nearest (x, y) if closer than ``threshold``."""
        pts = np.asarray(self.state.control_points, np.float64)
        d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
        i = int(np.argmin(d))
        return i if d[i] < threshold else None

    def _handle_opacity_left_click(self, event) -> None:
        """Select the point under the click, else add one there; either way
        it can then be dragged."""
        x, y = event.xdata, event.ydata
        if x is None or y is None:
            return
        i = self._find_control_point_near(x, y)
        if i is None:
            i = self.state.add_control_point(float(np.clip(x, 0.0, 1.0)), float(np.clip(y, 0.0, 1.0)))
        self.state.select_control_point(i)
        self.state.is_dragging_control_point = True
        self.state.drag_start_pos = (x, y)
        if self.state.auto_quality_enabled:
            self._switch_to_interaction_quality()
        self._update_display(force_render=True)

    def _handle_opacity_right_click(self, event) -> None:
        """Remove the point under the click (not the end points)."""
        if event.xdata is None or event.ydata is None:
            return
        self._remove_point(self._find_control_point_near(event.xdata, event.ydata))

    def _remove_point(self, i: Optional[int]) -> None:
        """Remove control point ``i`` and show the result; nothing for None
        or an end point."""
        if i is None:
            return
        try:
            self.state.remove_control_point(i)
        except ValueError:
            return  # an end point
        self._update_display(force_render=True)

    def _on_mouse_move(self, event) -> None:
        if self.state.is_dragging_camera:
            if not self._in(self.image_display, event) or event.xdata is None or self.state.drag_start_pos is None:
                return
            self._event_time = time.perf_counter()
            x0, y0 = self.state.drag_start_pos
            dx, dy = event.xdata - x0, event.ydata - y0
            if self.state.camera_control_mode == "trackball":
                # The image's y grows upward, the trackball's downward.
                self.camera_controller.trackball(dx=dx, dy=-dy, viewport_width=self.width,
                                                 viewport_height=self.height, sensitivity=1.0)
            else:
                self.camera_controller.orbit(delta_azimuth=-0.005 * dx, delta_elevation=0.005 * dy)
            self.state.drag_start_pos = (event.xdata, event.ydata)
            self.state.needs_render = True
            self._update_display()
        elif self.state.is_dragging_control_point:
            i = self.state.selected_control_point
            if i is None or not self._in(self.opacity_editor, event) or event.xdata is None:
                return
            self._event_time = time.perf_counter()
            try:
                self.state.update_control_point(i, np.clip(event.xdata, 0.0, 1.0), np.clip(event.ydata, 0.0, 1.0))
            except (ValueError, IndexError):
                return
            self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)
            if self._native:  # other renderers show the new function on release
                self._refresh_image()
                if self._cheap and self._drawn:
                    self._blit(self.opacity_editor)
                elif self.fig is not None:
                    self.fig.canvas.draw_idle()

    def _on_mouse_release(self, event) -> None:
        self._event_time = time.perf_counter()
        if self.state.is_dragging_camera or self.state.is_dragging_control_point:
            self.state.is_dragging_camera = False
            self.state.is_dragging_control_point = False
            self.state.drag_start_pos = None
            self._restore_quality_after_interaction()

    def _on_scroll(self, event) -> None:
        if not self._in(self.image_display, event):
            return
        self._event_time = time.perf_counter()
        if self.state.auto_quality_enabled:
            self._switch_to_interaction_quality()
        self.camera_controller.zoom(factor=0.9 if event.step > 0 else 1.1)
        self.state.needs_render = True
        self._update_display()
        self._later("scroll", 500, self._on_scroll_end)

    def _on_scroll_end(self) -> None:
        if self._interacting and not (self.state.is_dragging_camera or self.state.is_dragging_control_point):
            self._event_time = time.perf_counter()
            self._restore_quality_after_interaction()

    def _update_cursor(self, event) -> None:
        """A hand over the image, a crosshair over the opacity editor."""
        if self.fig is None:
            return
        if self._in(self.image_display, event):
            cursor = Cursors.HAND
        elif self._in(self.opacity_editor, event):
            cursor = Cursors.SELECT_REGION
        else:
            cursor = Cursors.POINTER
        try:
            self.fig.canvas.set_cursor(cursor)
        except (SystemError, RuntimeError):
            pass  # some backends cannot change the cursor; it is only a hint

    def _on_colormap_change(self, colormap_name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_colormap(colormap_name)
        self._update_display()

    def _on_preset_change(self, preset_name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_preset(preset_name)
        config = self._preset(preset_name)
        self.renderer.set_config(config)
        self.state.needs_render = True
        self._update_display(force_render=True)
        print(f"Switched to '{preset_name}' preset (~{config.estimate_samples_per_ray()} samples/ray)")
        self._update_status_display()

    def _on_key_press(self, event) -> None:
        self._event_time = time.perf_counter()
        action = {
            "r": self._reset_view, "s": self._save_image, "f": self._toggle_fps, "h": self._toggle_histogram,
            "l": self._toggle_light_link, "q": self._toggle_auto_quality, "t": self._toggle_control_mode,
            "escape": self._deselect, "delete": self._delete_selected, "backspace": self._delete_selected,
        }.get(event.key)
        if action is not None:
            action()

    def _reset_view(self) -> None:
        self.camera_controller.params = Camera.isometric_view(distance=3.0)
        self.state.needs_render = True
        self._update_display(force_render=True)

    def _toggle_fps(self) -> None:
        self.state.show_fps = not self.state.show_fps
        if self.image_display is not None:
            self.image_display.set_fps_visible(self.state.show_fps)
        self._update_status_display()

    def _toggle_histogram(self) -> None:
        self.state.show_histogram = not self.state.show_histogram
        if self.opacity_editor is not None:
            self.opacity_editor.set_histogram_visible(self.state.show_histogram)
        print(f"Histogram {'visible' if self.state.show_histogram else 'hidden'}")
        self._update_status_display()

    def _toggle_light_link(self) -> None:
        try:
            self._switch_light_link()
        except Exception as e:  # the window must survive a bad light or camera
            print(f"Error toggling light linking: {e}")

    def _switch_light_link(self) -> None:
        light = self.renderer.get_light()
        if light.is_linked:
            light.unlink_from_camera()
            self.renderer.set_light(light)
            self.state.light_linked_to_camera = False
            print("Light unlinked from camera (fixed position)")
            self.state.needs_render = True
            self._update_display(force_render=True)
            self._update_status_display()
        else:
            self.set_camera_linked_lighting(quiet=True)
            print("Light linked to camera (will follow movement)")

    def _toggle_auto_quality(self) -> None:
        self.state.auto_quality_enabled = not self.state.auto_quality_enabled
        print(f"Automatic quality adjustment {'enabled' if self.state.auto_quality_enabled else 'disabled'}")
        self._update_status_display()

    def _toggle_control_mode(self) -> None:
        if self.state.camera_control_mode == "trackball":
            self.state.camera_control_mode = "orbit"
            print("Switched to orbit control (azimuth/elevation)")
        else:
            self.state.camera_control_mode = "trackball"
            print("Switched to trackball control (arcball)")
        self._update_status_display()

    def _deselect(self) -> None:
        if self.state.selected_control_point is not None:
            self.state.select_control_point(None)
            self._update_display()

    def _delete_selected(self) -> None:
        self._remove_point(self.state.selected_control_point)

    def _on_draw(self, event) -> None:
        # Blitting draws over the last full drawing, so there must be one.
        self._drawn = True

    def _on_close(self, event) -> None:
        for timer in self._timers.values():
            timer.stop()
        self._restore_matplotlib_keymaps()

    # -- public actions ----------------------------------------------------
    def _save_image(self, filename: Optional[str] = None) -> Optional[str]:
        """Save the frame shown as a PNG (``pyvr_render_<time>.png``)."""
        if self._cached_image is None:
            print("No rendered image to save")
            return None
        from PIL import Image

        if filename is None:
            filename = f"pyvr_render_{datetime.now():%Y%m%d_%H%M%S}.png"
        Image.fromarray(self._cached_image).save(filename)
        print(f"Saved rendering to {filename}")
        return filename

    def set_high_quality_mode(self) -> None:
        """Switch to the high_quality preset."""
        self.state.set_preset("high_quality")
        self.renderer.set_config(self._preset("high_quality"))
        if self.preset_selector is not None:
            self.preset_selector.set_preset("high_quality", notify=False)
        self.state.needs_render = True
        self._update_display(force_render=True)
        self._update_status_display()
        print("Switched to high quality mode")

    def set_camera_linked_lighting(self, azimuth_offset: float = 0.0, elevation_offset: float = 0.0, *,
                                   quiet: bool = False) -> None:
        """Make the light follow the camera, turned by these offsets (radians)."""
        light = self.renderer.get_light()
        light.link_to_camera(azimuth_offset=azimuth_offset, elevation_offset=elevation_offset)
        light.update_from_camera(self.camera_controller.params)
        self.renderer.set_light(light)
        self.state.light_linked_to_camera = True
        self.state.needs_render = True
        self._update_display(force_render=True)
        self._update_status_display()
        if not quiet:
            print(f"Light linked to camera (az_offset={azimuth_offset:.2f}, el_offset={elevation_offset:.2f})")

    def capture_high_quality_image(self, filename: Optional[str] = None) -> str:
        """Render the current view with the ultra_quality preset (rays long
        enough to cross the volume) and save it as a PNG; returns the name.
        The preset in use does not change."""
        from PIL import Image

        if filename is None:
            filename = f"pyvr_hq_render_{datetime.now():%Y%m%d_%H%M%S}.png"
        cfg = self._preset("ultra_quality")
        self.renderer.set_camera(self.camera_controller.params)
        if self._native:
            img = self.renderer.render(origin="upper", config=cfg)
        else:
            previous = self.renderer.get_config()
            self.renderer.set_config(cfg)
            try:
                img = np.array(self.renderer.render_to_pil())
            finally:
                self.renderer.set_config(previous)
        Image.fromarray(img).save(filename)
        print(f"High quality image saved to {filename}")
        return filename
