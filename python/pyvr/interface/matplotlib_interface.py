"""InteractiveVolumeRenderer: pyvr 0.4.1's matplotlib window around a
VolumeRenderer, with a camera, an opacity editor, colormap and quality
selectors, and cheap frames while the user drags."""

import time
import warnings
from collections import deque
from datetime import datetime
from typing import Optional

import matplotlib.pyplot as plt
import numpy as np

from .._numbers import check_count
from ..camera import Camera, CameraController
from ..config import RenderConfig
from ..interaction import DragQuality
from ..lighting import Light
from ..refinement import Refinement
from ..renderer import VolumeRenderer
from ..transferfunctions import ColorTransferFunction, OpacityTransferFunction
from ..transferfunctions.value_range import storage_unit
from ..volume import Volume
from . import cache
from .state import PRESETS, InterfaceState
from .widgets import ColorSelector, ImageDisplay, OpacityEditor, PresetSelector

# Matplotlib's default keys that would fight the interface's own. "quit" keeps
# ctrl+w and loses only q, which toggles auto-quality here.
_CLEARED_KEYMAPS = ("fullscreen", "home", "back", "forward", "pan", "zoom", "save", "grid", "yscale", "xscale")

HELP = (
    "drag: rotate  scroll: zoom  keys: r reset,\n"
    "s save, f fps, h histogram, l light link,\n"
    "q auto-quality, t trackball/orbit, esc,\n"
    "del remove point, ctrl+w close"
)


def _detect_preset_name(config: RenderConfig, volume: Optional[Volume] = None) -> str:
    """The preset ``config`` is (pyvr's, or its box-crossing form), else "balanced"."""
    def key(c):
        return (c.step_size, c.max_steps, c.early_ray_termination, c.opacity_threshold)

    for name in PRESETS:
        p = getattr(RenderConfig, name)()
        if key(config) == key(p) or (volume is not None and key(config) == key(_crossing(p, volume))):
            return name
    return "balanced"


def _crossing(cfg: RenderConfig, volume: Volume) -> RenderConfig:
    """The config with max_steps raised so rays cross the whole volume
    (pyvr's presets stop rays after a fixed length, shorter than the
    [-1, 1] box's diagonal for preview, fast and ultra_quality)."""
    lo, hi = np.asarray(volume.min_bounds, np.float64), np.asarray(volume.max_bounds, np.float64)
    needed = int(np.ceil(np.linalg.norm(hi - lo) / cfg.step_size)) + 2
    return cfg.with_max_steps(needed) if needed > cfg.max_steps else cfg


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
        self.camera_controller = CameraController(camera)
        self.state = InterfaceState()
        self.state.current_preset_name = _detect_preset_name(config, volume)
        self.state.light_linked_to_camera = light.is_linked
        self.drag_quality = DragQuality(self.renderer, target_fps=target_fps)
        self.refinement = Refinement(self.renderer, refine_frames)
        self._refine_timer = None
        self.histogram_bin_edges = None
        self.histogram_log_counts = None
        self.image_display: Optional[ImageDisplay] = None
        self.opacity_editor: Optional[OpacityEditor] = None
        self.color_selector: Optional[ColorSelector] = None
        self.preset_selector: Optional[PresetSelector] = None
        self.fig = None
        self.info_text = None
        self._cached_image: Optional[np.ndarray] = None
        self._last_render_time = 0.0
        self._min_render_interval = 0.05
        self._interacting = False
        self._drawn = False
        self._scroll_timer = None
        self._pending_timer = None
        self._event_time: Optional[float] = None
        # Event-to-pixels seconds of the latest frames, drag and full.
        self.drag_latencies: deque = deque(maxlen=200)
        self.release_latencies: deque = deque(maxlen=200)
        self._update_transfer_functions()
        self._load_histogram()

    # -- model -------------------------------------------------------------
    def _update_transfer_functions(self) -> None:
        ctf = ColorTransferFunction.from_colormap(self.state.current_colormap)
        otf = OpacityTransferFunction(control_points=list(self.state.control_points))
        self.renderer.set_transfer_functions(ctf, otf)
        self.state.needs_tf_update = False

    def _tf_data_range(self):
        r = self.renderer.value_range
        if r is not None:
            return r
        return (0.0, storage_unit(self.volume.data.dtype))

    def _load_histogram(self) -> None:
        print("Loading histogram...")
        self.histogram_bin_edges, self.histogram_log_counts = cache.get_or_compute_histogram(
            self.volume.data, 256, self._tf_data_range())
        print("Histogram loaded.")

    def _render_volume(self, cheap: bool = False) -> np.ndarray:
        """The frame for the controller's camera: (H, W, 4) uint8 RGBA, top
        row first (smaller while interacting). On a rendering error it warns
        and returns a black RGBA frame of the view's size."""
        try:
            self.renderer.set_camera(self.camera_controller.params)
            if cheap:
                img = self.drag_quality.render_drag(origin="upper")
            else:
                img = self.drag_quality.render_full(origin="upper")
        except Exception as e:  # the window must survive any one bad frame
            warnings.warn(f"Rendering error: {e}", RuntimeWarning, stacklevel=2)
            img = np.zeros((self.height, self.width, 4), np.uint8)
            img[..., 3] = 255
        self._cached_image = img
        return img

    @property
    def _cheap(self) -> bool:
        return self._interacting and self.state.auto_quality_enabled

    # -- display -----------------------------------------------------------
    def _update_display(self, force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self._last_render_time < self._min_render_interval:
            # Too soon after the last frame: render this state a moment
            # later unless another event does first (the mouse may stop here).
            self.state.needs_render = True
            self._render_later()
            return
        if self.state.needs_tf_update:
            self._update_transfer_functions()
        cheap = self._cheap
        img = self._render_volume(cheap=cheap)
        self._last_render_time = time.perf_counter()
        self.state.needs_render = False
        if self.image_display is None:
            return
        self.image_display.update_image(img)
        if cheap:
            self.refinement.stop()
            self._blit_image()
        else:
            self._update_info()
            self.fig.canvas.draw_idle()
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

    def _render_later(self) -> None:
        if self.fig is None:
            return
        self._restart_timer("_pending_timer", max(1, int(self._min_render_interval * 1000)), self._render_pending)

    def _refine_later(self) -> None:
        if self.fig is None or not self.refinement.pending:
            return
        # Between frames the event loop runs: any event is handled first.
        self._restart_timer("_refine_timer", 1, self._refine_step)

    def _restart_timer(self, name: str, interval_ms: int, callback) -> None:
        """(Re)start the single-shot timer kept in attribute ``name``."""
        timer = getattr(self, name)
        if timer is None:
            timer = self.fig.canvas.new_timer(interval=interval_ms)
            timer.single_shot = True
            timer.add_callback(callback)
            setattr(self, name, timer)
        timer.stop()
        timer.start()

    def _refine_step(self) -> None:
        """One more unbiased frame into the still view's running mean."""
        if self._interacting or not self.refinement.pending:
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

    def _render_pending(self) -> None:
        if self.state.needs_render:
            self._update_display(force=True)

    def _blit_image(self) -> None:
        """Redraw only the image axes (a full figure redraw costs more than a
        cheap frame); falls back to a full redraw before the first one."""
        canvas = self.fig.canvas
        ax = self.image_display.ax
        if not getattr(canvas, "supports_blit", False) or not self._drawn:
            canvas.draw()
            return
        for artist in self.image_display.artists():
            ax.draw_artist(artist)
        canvas.blit(ax.bbox)

    def _update_info(self) -> None:
        if self.info_text is None:
            return
        c = self.camera_controller.params
        light = "follows camera" if self.state.light_linked_to_camera else "fixed"
        quality = "on" if self.state.auto_quality_enabled else "off"
        lines = [
            f"camera: az {np.degrees(c.azimuth):.0f}, el {np.degrees(c.elevation):.0f} deg, d {float(c.distance):.2f}",
            f"rotate: {self.state.camera_control_mode}   light: {light}",
            f"preset: {self.state.current_preset_name}   auto-quality: {quality}",
            f"dragging: {self.drag_quality.describe()}",
            f"last frame: {self.drag_quality.last_render_seconds * 1e3:.0f} ms",
            HELP,
        ]
        self.info_text.set_text("\n".join(lines))

    def _build_figure(self):
        """Make the figure, widgets and event connections (``show`` then
        opens the window; tests and screenshots use the figure directly)."""
        for name in _CLEARED_KEYMAPS:
            if f"keymap.{name}" in plt.rcParams:
                plt.rcParams[f"keymap.{name}"] = []
        if "keymap.quit" in plt.rcParams:
            plt.rcParams["keymap.quit"] = [k for k in plt.rcParams["keymap.quit"] if k != "q"]
        self.fig = plt.figure(figsize=(18, 8))
        gs = self.fig.add_gridspec(3, 3, width_ratios=[2, 1, 1], height_ratios=[3, 1, 1])
        self.image_display = ImageDisplay(self.fig.add_subplot(gs[:, 0]), show_fps=self.state.show_fps)
        self.opacity_editor = OpacityEditor(self.fig.add_subplot(gs[0, 1:]), show_histogram=self.state.show_histogram)
        self.opacity_editor.set_histogram(self.histogram_bin_edges, self.histogram_log_counts)
        self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)
        self.color_selector = ColorSelector(self.fig.add_subplot(gs[1:, 1]), on_change=self._on_colormap_change,
                                            initial_colormap=self.state.current_colormap)
        self.preset_selector = PresetSelector(self.fig.add_subplot(gs[1, 2]),
                                              initial_preset=self.state.current_preset_name,
                                              on_change=self._on_preset_change)
        info_ax = self.fig.add_subplot(gs[2, 2])
        info_ax.axis("off")
        self.info_text = info_ax.text(0.0, 1.0, "", va="top", fontsize=7, family="monospace",
                                      transform=info_ax.transAxes)
        connect = self.fig.canvas.mpl_connect
        self._cids = [
            connect("button_press_event", self._on_mouse_press),
            connect("button_release_event", self._on_mouse_release),
            connect("motion_notify_event", self._on_mouse_move),
            connect("scroll_event", self._on_scroll),
            connect("key_press_event", self._on_key_press),
            connect("close_event", self._on_close),
            connect("draw_event", self._on_draw),
        ]
        self.fig.tight_layout()
        self._update_display(force=True)
        return self.fig

    def show(self) -> None:
        """Open the window (blocks until it is closed, as plt.show does)."""
        self._build_figure()
        plt.show()

    def update(self) -> None:
        """Redraw with the current state (e.g. after changing it from code)."""
        self._update_display(force=True)

    # -- events ------------------------------------------------------------
    def _begin_interaction(self) -> None:
        if not self._interacting:
            self._interacting = True
            self.drag_quality.start()

    def _end_interaction(self) -> None:
        if self._interacting:
            self._interacting = False
            self._update_display(force=True)

    def _on_mouse_press(self, event) -> None:
        self._event_time = time.perf_counter()
        if self.image_display is not None and event.inaxes is self.image_display.ax and event.button == 1:
            self.state.is_dragging_camera = True
            self.state.drag_start_pos = (event.x, event.y)
            self._begin_interaction()
        elif self.opacity_editor is not None and event.inaxes is self.opacity_editor.ax:
            self._on_opacity_press(event)

    def _on_opacity_press(self, event) -> None:
        if event.xdata is None or event.ydata is None:
            return
        hit = self.opacity_editor.find_point(self.state.control_points, event.xdata, event.ydata)
        if event.button == 3:
            if hit is not None and 0 < hit < len(self.state.control_points) - 1:
                self.state.remove_control_point(hit)
                self._refresh_opacity(force=True)
            return
        if event.button != 1:
            return
        if hit is None:
            x = min(max(float(event.xdata), 0.0), 1.0)
            y = min(max(float(event.ydata), 0.0), 1.0)
            hit = self.state.add_control_point(x, y)
        self.state.select_control_point(hit)
        self.state.is_dragging_control_point = True
        self._begin_interaction()
        self._refresh_opacity(force=True)

    def _on_mouse_move(self, event) -> None:
        if self.state.is_dragging_camera and self.state.drag_start_pos is not None:
            self._event_time = time.perf_counter()
            x0, y0 = self.state.drag_start_pos
            dx, dy = event.x - x0, event.y - y0
            if self.state.camera_control_mode == "trackball":
                # Matplotlib's y grows upward; the trackball's downward.
                self.camera_controller.trackball(dx, -dy, self.width, self.height)
            else:
                self.camera_controller.orbit(-0.005 * dx, 0.005 * dy)
            self.state.drag_start_pos = (event.x, event.y)
            self._update_display()
        elif self.state.is_dragging_control_point and self.state.selected_control_point is not None:
            if event.inaxes is not self.opacity_editor.ax or event.xdata is None:
                return
            self._event_time = time.perf_counter()
            self.state.update_control_point(self.state.selected_control_point, event.xdata, event.ydata)
            self._refresh_opacity()

    def _on_mouse_release(self, event) -> None:
        self._event_time = time.perf_counter()
        self.state.is_dragging_camera = False
        self.state.is_dragging_control_point = False
        self.state.drag_start_pos = None
        self._end_interaction()

    def _on_scroll(self, event) -> None:
        if self.image_display is None or event.inaxes is not self.image_display.ax:
            return
        self._event_time = time.perf_counter()
        self.camera_controller.zoom(0.9 if event.step > 0 else 1.1)
        self._begin_interaction()
        self._update_display()
        self._restart_timer("_scroll_timer", 500, self._on_scroll_end)

    def _on_scroll_end(self) -> None:
        if not (self.state.is_dragging_camera or self.state.is_dragging_control_point):
            self._event_time = time.perf_counter()
            self._end_interaction()

    def _refresh_opacity(self, force: bool = False) -> None:
        self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)
        self.state.needs_tf_update = True
        self._update_display(force=force)
        if self._cheap:
            # The editor changed too: blit it alongside the image.
            ax = self.opacity_editor.ax
            if self._drawn:
                ax.draw_artist(self.opacity_editor.line)
                ax.draw_artist(self.opacity_editor.points)
                ax.draw_artist(self.opacity_editor.selected)
                self.fig.canvas.blit(ax.bbox)

    def _on_colormap_change(self, name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_colormap(name)
        self._update_display(force=True)

    def _on_preset_change(self, name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_preset(name)
        self.renderer.set_config(self._preset(name))
        self._update_display(force=True)

    def _on_key_press(self, event) -> None:
        key = event.key
        self._event_time = time.perf_counter()
        if key == "r":
            self.camera_controller.params = Camera.isometric_view(distance=3.0)
            self._update_display(force=True)
        elif key == "s":
            self._save_current_image()
        elif key == "f":
            self.state.show_fps = not self.state.show_fps
            self.image_display.set_fps_visible(self.state.show_fps)
            self.fig.canvas.draw_idle()
        elif key == "h":
            self.state.show_histogram = not self.state.show_histogram
            self.opacity_editor.set_histogram_visible(self.state.show_histogram)
            self.fig.canvas.draw_idle()
        elif key == "l":
            if self.state.light_linked_to_camera:
                self.renderer.get_light().unlink_from_camera()
                self.state.light_linked_to_camera = False
                self._update_display(force=True)
            else:
                self.set_camera_linked_lighting()
        elif key == "q":
            self.state.auto_quality_enabled = not self.state.auto_quality_enabled
            self._update_info()
            self.fig.canvas.draw_idle()
        elif key == "t":
            self.state.camera_control_mode = "orbit" if self.state.camera_control_mode == "trackball" else "trackball"
            self._update_info()
            self.fig.canvas.draw_idle()
        elif key == "escape":
            self.state.select_control_point(None)
            self.opacity_editor.update_plot(self.state.control_points, None)
            self.fig.canvas.draw_idle()
        elif key in ("delete", "backspace"):
            i = self.state.selected_control_point
            if i is not None and 0 < i < len(self.state.control_points) - 1:
                self.state.remove_control_point(i)
                self._refresh_opacity(force=True)

    def _on_draw(self, event) -> None:
        # Blitting draws over the last full drawing, so there must be one.
        self._drawn = True

    def _on_close(self, event) -> None:
        for timer in (self._scroll_timer, self._pending_timer):
            if timer is not None:
                timer.stop()

    # -- public actions ----------------------------------------------------
    def _save_current_image(self, filename: Optional[str] = None) -> str:
        from PIL import Image

        if filename is None:
            filename = f"pyvr_render_{datetime.now():%Y%m%d_%H%M%S}.png"
        img = self._cached_image if self._cached_image is not None else self._render_volume()
        Image.fromarray(img).save(filename)
        print(f"Saved {filename}")
        return filename

    def _preset(self, name: str) -> RenderConfig:
        return _crossing(getattr(RenderConfig, name)(), self.volume)

    def set_high_quality_mode(self) -> None:
        """Switch to the high_quality preset."""
        self.state.set_preset("high_quality")
        self.renderer.set_config(self._preset("high_quality"))
        if self.preset_selector is not None:
            self.preset_selector.set_preset("high_quality", notify=False)
        self._update_display(force=True)

    def set_camera_linked_lighting(self, azimuth_offset: float = 0.0, elevation_offset: float = 0.0) -> None:
        """Make the light follow the camera, turned by these offsets (radians)."""
        light = self.renderer.get_light()
        light.link_to_camera(azimuth_offset=azimuth_offset, elevation_offset=elevation_offset)
        self.renderer.set_light(light)
        self.state.light_linked_to_camera = True
        self._update_display(force=True)

    def capture_high_quality_image(self, filename: Optional[str] = None) -> str:
        """Render the current view with the ultra_quality preset (rays long
        enough to cross the volume) and save it as a PNG; returns the name."""
        from PIL import Image

        if filename is None:
            filename = f"pyvr_hq_render_{datetime.now():%Y%m%d_%H%M%S}.png"
        cfg = self._preset("ultra_quality")
        self.renderer.set_camera(self.camera_controller.params)
        img = self.renderer.render(origin="upper", config=cfg)
        Image.fromarray(img).save(filename)
        print(f"Saved {filename}")
        return filename
