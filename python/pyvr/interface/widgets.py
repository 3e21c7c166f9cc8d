"""The interface's matplotlib widgets: the rendered image, the opacity
editor, the colormap and preset selectors, and a frame-rate counter.

Names, attributes and messages are pyvr 0.4.1's (``radio``,
``current_preset``, ``histogram_bars``, ...), so code written against its
widgets keeps working. Widgets do not redraw the whole figure while the
interface blits (``ImageDisplay.redraw_on_update``)."""

import time
from collections import deque
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
from matplotlib.widgets import RadioButtons

from .state import PRESETS


class FPSCounter:
    """Frames per second over the last ``window_size`` frame intervals."""

    def __init__(self, window_size: int = 30):
        self.window_size = window_size
        self.frame_times: deque = deque(maxlen=window_size)
        self.last_time: Optional[float] = None

    def tick(self) -> None:
        """Record that a frame was shown now."""
        now = time.perf_counter()
        if self.last_time is not None:
            self.frame_times.append(now - self.last_time)
        self.last_time = now

    def get_fps(self) -> float:
        """Mean frame rate over the window; 0.0 before two ticks."""
        if not self.frame_times:
            return 0.0
        mean = sum(self.frame_times) / len(self.frame_times)
        return 1.0 / mean if mean > 0 else 0.0

    def reset(self) -> None:
        self.frame_times.clear()
        self.last_time = None


class ImageDisplay:
    """The rendered frame (top row first), stretched over a fixed extent so
    smaller frames rendered while dragging fill the same view, with a
    frame-rate overlay."""

    def __init__(self, ax, show_fps: bool = True):
        self.ax = ax
        self.image = None
        self.show_fps = show_fps
        self.fps_text = None
        self.fps_counter = FPSCounter(window_size=30)
        self._extent = None
        # Whether update_image asks for a figure redraw; the interface
        # draws (or blits) itself and turns this off.
        self.redraw_on_update = True
        ax.set_title("Volume Rendering", fontsize=12, fontweight="bold")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_facecolor("black")

    def update_image(self, image_array: np.ndarray) -> None:
        """Show an (H, W, 3) or (H, W, 4) frame."""
        a = np.asarray(image_array)
        if a.ndim != 3 or a.shape[2] not in (3, 4):
            got = a.shape[2] if a.ndim == 3 else f"an array of {a.ndim} dimensions"
            raise ValueError(f"Image must have 3 or 4 channels, got {got}")
        if self.image is None:
            # Image pixels with y growing upward, as matplotlib's events
            # give them (xdata, ydata); the first row is shown at the top.
            h, w = a.shape[:2]
            self._extent = (0, w, 0, h)
            self.image = self.ax.imshow(a, extent=self._extent, interpolation="bilinear", zorder=0)
        else:
            self.image.set_data(a)
        if self.show_fps:
            self.fps_counter.tick()
            self._update_fps_display(a)
        if self.redraw_on_update:
            self.ax.figure.canvas.draw_idle()

    def _update_fps_display(self, frame: Optional[np.ndarray] = None) -> None:
        text = f"FPS: {self.fps_counter.get_fps():.1f}"
        if frame is not None:
            text += f"  {frame.shape[1]}x{frame.shape[0]}"
        if self.fps_text is None:
            self.fps_text = self.ax.text(0.02, 0.98, text, transform=self.ax.transAxes, fontsize=10,
                                         verticalalignment="top", color="#00ff00", family="monospace",
                                         bbox=dict(boxstyle="round,pad=0.3", facecolor="black", alpha=0.7))
        else:
            self.fps_text.set_text(text)

    def set_fps_visible(self, visible: bool) -> None:
        """Show or hide the frame-rate overlay (hiding resets its counter)."""
        self.show_fps = bool(visible)
        if self.fps_text is not None:
            self.fps_text.set_visible(self.show_fps)
        if not self.show_fps:
            self.fps_counter.reset()

    def artists(self) -> list:
        """The artists a blit redraws."""
        return [a for a in (self.image, self.fps_text) if a is not None]

    def clear(self) -> None:
        """Remove the image and the overlay from the axes."""
        if self.image is not None:
            self.image.remove()
            self.image = None
        if self.fps_text is not None:
            self.fps_text.remove()
            self.fps_text = None
        self.fps_counter.reset()
        self.ax.figure.canvas.draw_idle()


# Control points: selected, end points (x fixed), and the others.
_POINT_STYLE = {"selected": ("#ff4444", 120), "end": ("#4444ff", 80), "inner": ("#44ff44", 60)}


class OpacityEditor:
    """The opacity transfer function as draggable control points over the
    volume's log histogram (both on [0, 1] along x). ``line`` and ``points``
    are created by the first ``update_plot``; ``histogram_bars`` by the
    first ``set_histogram`` while the histogram is shown."""

    PICK_RADIUS = 0.05

    def __init__(self, ax, show_histogram: bool = True):
        self.ax = ax
        self.line = None
        self.points = None
        self.histogram_bars = None
        self.show_histogram = show_histogram
        self._histogram_data = None
        ax.set_title("Opacity Transfer Function", fontsize=11, fontweight="bold")
        ax.set_xlabel("Scalar Value (transfer function domain)", fontsize=9)
        ax.set_ylabel("Opacity", fontsize=9)
        ax.set_xlim(-0.05, 1.05)
        ax.set_ylim(-0.05, 1.05)
        ax.grid(True, alpha=0.3, linestyle="--", linewidth=0.5)
        ax.tick_params(labelsize=8)
        ax.set_facecolor("#f8f8f8")

    def set_histogram(self, bin_edges: np.ndarray, log_counts: np.ndarray) -> None:
        """The backdrop: ``log_counts`` per bin, scaled to a peak of 1, with
        the edges mapped so the first is x = 0 and the last x = 1 (the
        transfer function's domain, whatever units the bins are in). While
        the histogram is hidden the data is kept and drawn when shown."""
        self._histogram_data = (np.asarray(bin_edges, np.float64), np.asarray(log_counts, np.float64))
        if self.show_histogram:
            self._draw_histogram()

    def _draw_histogram(self) -> None:
        edges, counts = self._histogram_data
        top = counts.max() if counts.size and counts.max() > 0 else 1.0
        lo, hi = edges[0], edges[-1]
        x = (edges - lo) / (hi - lo) if hi > lo else edges
        if self.histogram_bars is not None:
            self.histogram_bars.remove()
        self.histogram_bars = self.ax.bar((x[:-1] + x[1:]) / 2, counts / top, width=np.diff(x),
                                          color="#a0b0c0", alpha=0.3, zorder=1, edgecolor="none")
        self.ax.figure.canvas.draw_idle()

    def update_plot(self, control_points: Sequence[Tuple[float, float]], selected_index: Optional[int] = None) -> None:
        """Draw the curve and its points: the selected one red, the end
        points (which move only up and down) blue, the others green."""
        if len(control_points) == 0:
            return
        pts = np.asarray(control_points, np.float64).reshape(-1, 2)
        last = len(pts) - 1
        kinds = ["selected" if i == selected_index else "end" if i in (0, last) else "inner" for i in range(len(pts))]
        colors = [_POINT_STYLE[k][0] for k in kinds]
        sizes = [_POINT_STYLE[k][1] for k in kinds]
        if self.line is None:
            (self.line,) = self.ax.plot(pts[:, 0], pts[:, 1], "b-", linewidth=2.5, alpha=0.7, zorder=3)
        else:
            self.line.set_data(pts[:, 0], pts[:, 1])
        if self.points is None:
            self.points = self.ax.scatter(pts[:, 0], pts[:, 1], c=colors, s=sizes, zorder=5, edgecolors="black",
                                          linewidths=1)
        else:
            self.points.set_offsets(pts)
            self.points.set_color(colors)
            self.points.set_sizes(sizes)
            self.points.set_edgecolor("black")

    def find_point(self, control_points, x: float, y: float) -> Optional[int]:
        """Index of the control point within PICK_RADIUS of (x, y), nearest first."""
        pts = np.asarray(control_points, np.float64).reshape(-1, 2)
        d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
        i = int(np.argmin(d))
        return i if d[i] <= self.PICK_RADIUS else None

    def artists(self) -> list:
        """The artists a blit redraws."""
        return [a for a in (self.line, self.points) if a is not None]

    def set_histogram_visible(self, visible: bool) -> None:
        """Show or hide the data's histogram behind the opacity curve."""
        self.show_histogram = bool(visible)
        if self.histogram_bars is None and self.show_histogram and self._histogram_data is not None:
            self._draw_histogram()
        elif self.histogram_bars is not None:
            for bar in self.histogram_bars:
                bar.set_visible(self.show_histogram)
        self.ax.figure.canvas.draw_idle()

    def clear(self) -> None:
        """Remove the curve, its points and the histogram."""
        for name in ("line", "points", "histogram_bars"):
            artist = getattr(self, name)
            if artist is not None:
                artist.remove()
                setattr(self, name, None)
        self.ax.figure.canvas.draw_idle()


class _Choice:
    """Radio buttons over a list of names, shown as labels, whose choice can
    also be set from code (``notify=False``: without calling ``on_change``)."""

    NAMES: List[str] = []
    LABELS: List[str] = []

    def _make_radio(self, active: str) -> None:
        self._quiet = False
        self.radio = RadioButtons(ax=self.ax, labels=self.LABELS, active=self.NAMES.index(active))
        for label in self.radio.labels:
            label.set_fontsize(9)
        self.radio.on_clicked(self._on_selection)

    def _select(self, name: str, notify: bool) -> None:
        """Move the radio buttons to ``name``; they call ``_on_selection``."""
        self._quiet = not notify
        try:
            self.radio.set_active(self.NAMES.index(name))
        finally:
            self._quiet = False

    def _chosen(self, name: str) -> None:
        if self.on_change is not None and not getattr(self, "_quiet", False):
            self.on_change(name)


class ColorSelector(_Choice):
    """Chooses the colour transfer function's matplotlib colormap, with a
    preview bar of the current one (``preview_ax``, ``colormap_preview``).
    An ``initial_colormap`` outside AVAILABLE_COLORMAPS (one chosen in
    code) is offered as one more button."""

    AVAILABLE_COLORMAPS = ["viridis", "plasma", "inferno", "magma", "cividis", "gray", "bone", "copper", "hot",
                           "cool", "turbo", "jet"]

    def __init__(self, ax, on_change: Optional[Callable[[str], None]] = None, initial_colormap: str = "viridis"):
        if not isinstance(initial_colormap, str):
            raise TypeError(f"initial_colormap must be a colormap name, got {type(initial_colormap)}")
        self.ax = ax
        self.current_colormap = initial_colormap
        self.on_change = on_change
        self.NAMES = self.LABELS = self.AVAILABLE_COLORMAPS + [initial_colormap] * (
            initial_colormap not in self.AVAILABLE_COLORMAPS)
        ax.set_title("Color Transfer Function", fontsize=11, fontweight="bold")
        self._create_colormap_preview()
        self._make_radio(initial_colormap)

    def _unknown(self, name) -> str:
        return f"Colormap '{name}' not available. Choose from: {self.NAMES}"

    def _create_colormap_preview(self) -> None:
        # Below the buttons, so it hides none of them.
        pos = self.ax.get_position()
        self.preview_ax = self.ax.figure.add_axes([pos.x0, pos.y0 - 0.035, pos.width, 0.025])
        self.preview_ax.axis("off")
        gradient = np.linspace(0.0, 1.0, 256).reshape(1, -1)
        self.colormap_preview = self.preview_ax.imshow(gradient, aspect="auto", cmap=self.current_colormap,
                                                       extent=[0, 1, 0, 1])

    def _on_selection(self, label: str) -> None:
        """The radio buttons' callback (label = colormap name)."""
        self.current_colormap = label
        self.colormap_preview.set_cmap(label)
        self.ax.figure.canvas.draw_idle()
        self._chosen(label)

    def set_colormap(self, colormap_name: str, notify: bool = True) -> None:
        """Select a colormap from code; ``on_change`` is called unless
        ``notify=False``."""
        if colormap_name not in self.NAMES:
            raise ValueError(self._unknown(colormap_name))
        self.current_colormap = colormap_name
        self._select(colormap_name, notify)
        self.colormap_preview.set_cmap(colormap_name)


class PresetSelector(_Choice):
    """Chooses the RenderConfig quality preset."""

    AVAILABLE_PRESETS = list(PRESETS)
    PRESET_LABELS = ["Preview (fastest)", "Fast", "Balanced", "High Quality", "Ultra (slowest)"]

    def __init__(self, ax, initial_preset: str = "fast", on_change: Optional[Callable[[str], None]] = None):
        if initial_preset not in self.AVAILABLE_PRESETS:
            raise ValueError(self._invalid(initial_preset))
        self.ax = ax
        self.on_change = on_change
        self.current_preset = initial_preset
        self.NAMES, self.LABELS = self.AVAILABLE_PRESETS, self.PRESET_LABELS
        ax.set_title("Rendering Quality", fontsize=11, fontweight="bold")
        ax.axis("off")
        self._make_radio(initial_preset)

    def _invalid(self, name) -> str:
        return f"Invalid preset '{name}'. Choose from: {self.AVAILABLE_PRESETS}"

    def _on_selection(self, label: str) -> None:
        """The radio buttons' callback (label = the preset's display label)."""
        self.current_preset = self.AVAILABLE_PRESETS[self.PRESET_LABELS.index(label)]
        self._chosen(self.current_preset)

    def set_preset(self, preset_name: str, notify: bool = True) -> None:
        """Select a preset from code; ``on_change`` is called unless
        ``notify=False``."""
        if preset_name not in self.AVAILABLE_PRESETS:
            raise ValueError(self._invalid(preset_name))
        self.current_preset = preset_name
        self._select(preset_name, notify)

    def get_preset(self) -> str:
        return self.current_preset
