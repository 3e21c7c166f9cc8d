"""Cheap frames while the user drags, full quality when they let go.

Both interactive views (the matplotlib interface and the notebook widget)
use :class:`DragQuality`. While a drag, scroll or control-point move is in
progress each frame is rendered with a coarser step and at a fraction of
the view's resolution, chosen from measured times so that an event turns
into pixels within the frame budget (1/10 s by default, on any machine);
the display stretches the smaller frame to the view. On release one frame
is rendered at the renderer's own config and size.

The coarser step keeps the look: opacity correction makes a transfer
function's colour and opacity the same at every step (only detail and
sampling noise differ), and ``max_steps`` is raised so that rays always
cross the whole volume.
"""

import math
import time
import warnings
from typing import Optional, Tuple

import numpy as np

from .config import RenderConfig

# Fractions of the view's width and height a drag frame may use, coarsest last.
SCALES = (1.0, 0.75, 0.5, 0.375, 0.25, 0.1875, 0.125)


class DragQuality:
    """Chooses and renders the frames shown while the user interacts.

    renderer: the VolumeRenderer whose config and size are "full quality".
    target_fps: frames per second to keep while dragging (event to pixels).
    samples_per_diagonal: the drag step is at most the box's diagonal over
    this many samples (never finer than the renderer's own step).
    """

    def __init__(self, renderer, target_fps: float = 10.0, samples_per_diagonal: int = 96):
        if not (isinstance(target_fps, (int, float)) and math.isfinite(target_fps) and target_fps > 0):
            raise ValueError(f"target_fps must be a positive number, got {target_fps!r}")
        if isinstance(samples_per_diagonal, bool) or not isinstance(samples_per_diagonal, int) or samples_per_diagonal < 8:
            raise ValueError(f"samples_per_diagonal must be an integer of at least 8, got {samples_per_diagonal!r}")
        self.renderer = renderer
        self.target_fps = float(target_fps)
        self.samples_per_diagonal = samples_per_diagonal
        self.level = 2  # index into SCALES; refined from measurements
        self._per_pixel: Optional[float] = None  # seconds per pixel of a drag frame
        self._overhead = 0.0  # seconds an event costs besides rendering (display)
        self.last_render_seconds = 0.0

    @property
    def budget(self) -> float:
        """Seconds from an event to its pixels that the drag frames aim at
        (80 % of 1/target_fps, leaving room for the event loop)."""
        return 0.8 / self.target_fps

    def config(self) -> RenderConfig:
        """The renderer's config with the drag step; rays still cross the box."""
        cfg = self.renderer.get_config()
        vol = self.renderer.get_volume()
        lo, hi = np.asarray(vol.min_bounds, np.float64), np.asarray(vol.max_bounds, np.float64)
        diagonal = float(np.linalg.norm(hi - lo))
        step = max(float(cfg.step_size), diagonal / self.samples_per_diagonal)
        with warnings.catch_warnings():
            # A step that is large in world units (a box in millimetres) is
            # still 1/96 of the box: no "very large step" note every frame.
            warnings.simplefilter("ignore", UserWarning)
            return cfg.replace(step_size=step, max_steps=int(math.ceil(diagonal / step)) + 2)

    def size(self) -> Tuple[int, int]:
        """The drag frame's (width, height) at the current level."""
        s = SCALES[self.level]
        return (max(1, round(self.renderer.width * s)), max(1, round(self.renderer.height * s)))

    @property
    def scale(self) -> float:
        """The fraction of the view's width and height that frames take while dragging,
        at the current level."""
        return SCALES[self.level]

    def start(self) -> None:
        """A drag begins: pick the level from what past frames cost."""
        if self._per_pixel is None:
            return
        spare = self.budget - self._overhead
        pixels = self.renderer.width * self.renderer.height
        for i, s in enumerate(SCALES):
            if self._per_pixel * pixels * s * s <= spare:
                self.level = i
                return
        self.level = len(SCALES) - 1

    def render_drag(self, **options) -> np.ndarray:
        """One drag frame (options as VolumeRenderer.render)."""
        w, h = self.size()
        t0 = time.perf_counter()
        img = self.renderer.render(size=(w, h), config=self.config(), **options)
        self.last_render_seconds = time.perf_counter() - t0
        per_pixel = self.last_render_seconds / (w * h)
        self._per_pixel = per_pixel if self._per_pixel is None else 0.5 * (self._per_pixel + per_pixel)
        return img

    def render_full(self, **options) -> np.ndarray:
        """One frame at the renderer's own config and size."""
        t0 = time.perf_counter()
        img = self.renderer.render(**options)
        self.last_render_seconds = time.perf_counter() - t0
        return img

    def record(self, event_to_pixels: float) -> None:
        """Feed back a drag frame's whole latency (event to pixels shown):
        coarser next time when over budget, finer when well under it."""
        self._overhead = max(0.0, event_to_pixels - self.last_render_seconds)
        if event_to_pixels > self.budget and self.level < len(SCALES) - 1:
            self.level += 1
        elif self.level > 0:
            s0, s1 = SCALES[self.level], SCALES[self.level - 1]
            # Predicted latency one level finer: rendering grows with pixels.
            finer = self._overhead + self.last_render_seconds * (s1 * s1) / (s0 * s0)
            if finer < 0.85 * self.budget:
                self.level -= 1

    def describe(self) -> str:
        """The current drag frame as text: its size, its share of the view, its step."""
        cfg = self.config()
        w, h = self.size()
        return f"{w}x{h} ({self.scale:.3g} of the view), step {cfg.step_size:.3g}"
