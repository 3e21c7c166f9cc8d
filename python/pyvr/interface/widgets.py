"""The interface's matplotlib widgets: the rendered image, the opacity
editor, the colormap and preset selectors, and a frame-rate counter."""

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
        self._last: Optional[float] = None

    def tick(self) -> None:
        now = time.perf_counter()
        if self._last is not None:
            self.frame_times.append(now - self._last)
        self._last = now

    def get_fps(self) -> float:
        if not self.frame_times:
            return 0.0
        mean = float(np.mean(self.frame_times))
        return 1.0 / mean if mean > 0 else 0.0

    def reset(self) -> None:
        self.frame_times.clear()
        self._last = None


class ImageDisplay:
    """The rendered frame (top row first), stretched over a fixed extent so
    smaller frames rendered while dragging fill the same view."""

    def __init__(self, ax, show_fps: bool = True):
        self.ax = ax
        self.show_fps = show_fps
        self.fps_counter = FPSCounter(window_size=30)
        self.image = None
        self._extent = None
        ax.set_facecolor("black")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title("Volume rendering")
        self.fps_text = ax.text(0.02, 0.97, "", transform=ax.transAxes, color="white", va="top", fontsize=9,
                                family="monospace")
        self.fps_text.set_visible(show_fps)

    def update_image(self, image: np.ndarray) -> None:
        a = np.asarray(image)
        if a.ndim != 3 or a.shape[2] not in (3, 4):
            raise ValueError(f"Image must have 3 or 4 channels, got {a.shape[2] if a.ndim == 3 else a.ndim}")
        if self.image is None:
            h, w = a.shape[:2]
            self._extent = (0, w, h, 0)
            self.image = self.ax.imshow(a, extent=self._extent, interpolation="bilinear", zorder=0)
        else:
            self.image.set_data(a)
        self.fps_counter.tick()
        if self.show_fps:
            self.fps_text.set_text(f"{self.fps_counter.get_fps():5.1f} fps  {a.shape[1]}x{a.shape[0]}")

    def set_fps_visible(self, visible: bool) -> None:
        self.show_fps = bool(visible)
        self.fps_text.set_visible(self.show_fps)

    def artists(self) -> list:
        return [a for a in (self.image, self.fps_text) if a is not None]

    def clear(self) -> None:
        if self.image is not None:
            self.image.remove()
            self.image = None
        self.fps_text.set_text("")
        self.fps_counter.reset()


class OpacityEditor:
    """The opacity transfer function as draggable control points over the
    volume's log histogram (both on [0, 1] along x)."""

    PICK_RADIUS = 0.05

    def __init__(self, ax, show_histogram: bool = True):
        self.ax = ax
        self.show_histogram = show_histogram
        self._histogram = None
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.05)
        ax.set_title("Opacity (click: add/select, drag: move, right-click: remove)", fontsize=9)
        ax.set_xlabel("value (transfer function domain)", fontsize=8)
        ax.set_ylabel("opacity", fontsize=8)
        (self.line,) = ax.plot([], [], "-", color="tab:blue", lw=1.5, zorder=3)
        self.points = ax.scatter([], [], s=40, color="tab:blue", zorder=4, edgecolor="white")
        self.selected = ax.scatter([], [], s=90, color="tab:red", zorder=5, edgecolor="black")

    def set_histogram(self, bin_edges: np.ndarray, log_counts: np.ndarray) -> None:
        if self._histogram is not None:
            self._histogram.remove()
        counts = np.asarray(log_counts, np.float64)
        top = counts.max() if counts.size and counts.max() > 0 else 1.0
        lo, hi = float(bin_edges[0]), float(bin_edges[-1])
        x = (np.asarray(bin_edges, np.float64) - lo) / (hi - lo)
        self._histogram = self.ax.stairs(counts / top, x, fill=True, color="0.8", zorder=1)
        self._histogram.set_visible(self.show_histogram)

    def update_plot(self, control_points: Sequence[Tuple[float, float]], selected_index: Optional[int] = None) -> None:
        pts = np.asarray(control_points, np.float64).reshape(-1, 2)
        self.line.set_data(pts[:, 0], pts[:, 1])
        self.points.set_offsets(pts)
        if selected_index is None:
            self.selected.set_offsets(np.empty((0, 2)))
        else:
            self.selected.set_offsets(pts[selected_index:selected_index + 1])

    def find_point(self, control_points, x: float, y: float) -> Optional[int]:
        """Index of the control point within PICK_RADIUS of (x, y), nearest first."""
        pts = np.asarray(control_points, np.float64).reshape(-1, 2)
        d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
        i = int(np.argmin(d))
        return i if d[i] <= self.PICK_RADIUS else None

    def set_histogram_visible(self, visible: bool) -> None:
        self.show_histogram = bool(visible)
        if self._histogram is not None:
            self._histogram.set_visible(self.show_histogram)

    def clear(self) -> None:
        self.line.set_data([], [])
        self.points.set_offsets(np.empty((0, 2)))
        self.selected.set_offsets(np.empty((0, 2)))


class _Radio:
    """RadioButtons whose choice can also be set from code."""

    def __init__(self, ax, names: List[str], labels: List[str], active: str, title: str,
                 on_change: Optional[Callable[[str], None]]):
        self.names = list(names)
        self.on_change = on_change
        self._current = active
        ax.set_title(title, fontsize=9)
        self.buttons = RadioButtons(ax, labels, active=self.names.index(active))
        for t in self.buttons.labels:
            t.set_fontsize(8)
        self._labels = list(labels)
        self._quiet = False
        self.buttons.on_clicked(self._clicked)

    def _clicked(self, label: str) -> None:
        self._current = self.names[self._labels.index(label)]
        if self.on_change is not None and not self._quiet:
            self.on_change(self._current)

    def _set(self, name: str, notify: bool = True) -> None:
        self._quiet = not notify
        try:
            self.buttons.set_active(self.names.index(name))
        finally:
            self._quiet = False
        self._current = name


class ColorSelector(_Radio):
    """Chooses the colour transfer function's matplotlib colormap."""

    AVAILABLE_COLORMAPS = ["viridis", "plasma", "inferno", "magma", "cividis", "gray", "bone", "copper", "hot",
                           "cool", "turbo", "jet"]

    def __init__(self, ax, on_change: Optional[Callable[[str], None]] = None, initial_colormap: str = "viridis"):
        if initial_colormap not in self.AVAILABLE_COLORMAPS:
            initial_colormap = "viridis"
        super().__init__(ax, self.AVAILABLE_COLORMAPS, self.AVAILABLE_COLORMAPS, initial_colormap, "Colormap",
                         on_change)

    @property
    def current_colormap(self) -> str:
        return self._current

    def set_colormap(self, name: str, notify: bool = True) -> None:
        if name not in self.AVAILABLE_COLORMAPS:
            raise ValueError(f"Unknown colormap '{name}'. Available: {self.AVAILABLE_COLORMAPS}")
        self._set(name, notify)


class PresetSelector(_Radio):
    """Chooses the RenderConfig quality preset."""

    AVAILABLE_PRESETS = list(PRESETS)
    PRESET_LABELS = ["Preview (fastest)", "Fast", "Balanced", "High Quality", "Ultra (slowest)"]

    def __init__(self, ax, initial_preset: str = "fast", on_change: Optional[Callable[[str], None]] = None):
        if initial_preset not in self.AVAILABLE_PRESETS:
            raise ValueError(f"Invalid preset '{initial_preset}'. Choose from: {self.AVAILABLE_PRESETS}")
        super().__init__(ax, self.AVAILABLE_PRESETS, self.PRESET_LABELS, initial_preset, "Quality preset",
                         on_change)

    def set_preset(self, name: str, notify: bool = True) -> None:
        if name not in self.AVAILABLE_PRESETS:
            raise ValueError(f"Invalid preset '{name}'. Choose from: {self.AVAILABLE_PRESETS}")
        self._set(name, notify)

    def get_preset(self) -> str:
        return self._current
