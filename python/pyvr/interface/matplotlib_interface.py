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

from collections import deque
from datetime import datetime
from typing import Optional

import matplotlib
import matplotlib.pyplot as plt

import numpy as np
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
from .framing import _crossing, _home_camera, _home_light
from .state import PRESETS, InterfaceState
from .events import EventHandlers
from .frames import FramePipeline
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
    "  o: Toggle orthographic   Double-click: rotate about that point\n"
)


def _on_off(flag) -> str:
    return "ON" if flag else "OFF"


class InteractiveVolumeRenderer(FramePipeline, EventHandlers):
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
        camera = _home_camera(volume) if camera is None else camera
        light = _home_light(volume) if light is None else light
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
        self._drawn_key = None  # _figure_key() at the last full drawing
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
            status.append(f"  Dragging: {self.drag_quality.describe()}")
        return _CONTROLS + "\n".join(status)

    def _update_status_display(self) -> None:
        """Rewrite the info panel and redraw the figure."""
        self._drawn_key = self._figure_key()
        if self.info_text is not None:
            self.info_text.set_text(self._drawn_key[0])
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
