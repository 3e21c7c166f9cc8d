"""Progressive refinement of a view that stands still.

Both interactive views (the notebook widget and the matplotlib interface)
can keep rendering after the full frame while nothing moves: unbiased frames
(``RenderConfig.unbiased``), one per step, whose running mean converges to
the exact integral and equals ``renderer.render(accumulate=k)`` after k
steps. A change of camera, light, config, transfer function, value range,
crop box, volume or size starts over.
"""

import pickle
from typing import Optional

import numpy as np

from ._numbers import check_count
from ._frames import UNBIASED_MODELS, _colour, mean_image, output_image

# The running mean is shown from this many frames on: four unbiased frames
# have half the noise of one (the full frame stays on show until then).
SHOW_FROM = 4


class Refinement:
    """The running mean of up to ``frames`` unbiased frames of ``renderer``'s
    current scene (0: off), composited over ``background`` (as in
    ``render``; None keeps it transparent)."""

    def __init__(self, renderer, frames: int = 0, background=None):
        self.renderer = renderer
        self.frames = check_count("refine_frames", frames, low=0, high=1 << 16)
        self.background = None if background is None else _colour(background)
        self.count = 0
        self._sum: Optional[np.ndarray] = None
        self._key: Optional[bytes] = None

    def _scene_key(self) -> bytes:
        r = self.renderer
        counters = r.counters()
        # Pickled: every config field and every array compares by value.
        return pickle.dumps((r._frame_camera(), r._light_args, r.get_config(), r.value_range, r.crop_box, r.clip_planes, r._caps,
                             counters["lut_uploads"], counters["volume_uploads"], r.width, r.height))

    def applies(self) -> bool:
        """Whether the renderer's config has unbiased frames to refine with."""
        if self.frames == 0:
            return False
        cfg = self.renderer.get_config()
        return cfg.model in UNBIASED_MODELS and not cfg.pre_integrated

    def restart(self) -> None:
        """Start over for the scene as it is now (after its full frame)."""
        self._key = self._scene_key() if self.applies() else None
        self._sum, self.count = None, 0

    def stop(self) -> None:
        """The view moves: nothing to refine until the next restart."""
        self._key = None

    def _current(self) -> bool:
        return self._key is not None and self.applies() and self._key == self._scene_key()

    @property
    def pending(self) -> bool:
        """Whether another step would add a frame to the current scene's mean."""
        return self.count < self.frames and self._current()

    @property
    def finished(self) -> bool:
        """Whether the current scene's mean holds every frame asked for."""
        return 0 < self.frames <= self.count and self._current()

    def step(self) -> Optional[np.ndarray]:
        """One more unbiased frame into the mean: the (H, W, 4) uint8 image
        to show, top row first, or None while fewer than SHOW_FROM frames
        (or all of them, when fewer are asked for) are in it."""
        cfg = self.renderer.get_config()
        seed = (cfg.jitter_seed + self.count) % 2**32
        if self._sum is None:
            self._sum = np.zeros((self.renderer.height, self.renderer.width, 4), np.float64)
        # The frame's pixels are added to the sums as it is made.
        self.renderer._render_frame(None, cfg.replace(unbiased=True, jitter_seed=seed), sums=self._sum)
        self.count += 1
        if self.count < min(SHOW_FROM, self.frames):
            return None
        return output_image(mean_image(self._sum, self.count), np.dtype(np.uint8), False, self.background, "upper")
