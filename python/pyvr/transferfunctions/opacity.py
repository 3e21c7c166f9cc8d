"""Opacity transfer functions."""

from typing import List, Optional, Tuple

import numpy as np

from .base import BaseTransferFunction, InvalidControlPointError, validate_control_points_format


class OpacityTransferFunction(BaseTransferFunction):
    """Maps scalars in [0, 1] to opacity in [0, 1] by linear interpolation.

    The opacity is defined per ``reference_step_size`` of the render config:
    the renderer corrects it for its actual step (Beer–Lambert), so the same
    function looks the same at every quality preset.
    """

    def __init__(self, control_points: Optional[List[Tuple[float, float]]] = None, lut_size: int = 256, *, value_range=None):
        super().__init__(control_points, lut_size, value_range=value_range)

    def _get_default_control_points(self):
        return [(0.0, 0.0), (1.0, 1.0)]

    def _validate_control_points(self) -> None:
        validate_control_points_format(self.control_points, 1)
        self._validate_scalar_range()
        for i, (_, o) in enumerate(self.control_points):
            if not (0.0 <= o <= 1.0):
                raise InvalidControlPointError(f"Control point {i} opacity {o} outside valid range [0.0, 1.0]")

    @classmethod
    def linear(cls, low: float = 0.0, high: float = 1.0, lut_size: int = 256) -> "OpacityTransferFunction":
        """Opacity rising linearly from ``low`` at the low end to ``high`` at the high
        end."""
        return cls([(0.0, low), (1.0, high)], lut_size=lut_size)

    @classmethod
    def one_step(cls, step: float = 0.5, low: float = 0.0, high: float = 1.0, lut_size: int = 256):
        """Opacity ``low`` below the normalised value ``step`` and ``high`` from it on."""
        return cls([(0.0, low), (step, low), (step + 1e-12, high), (1.0, high)], lut_size=lut_size)

    @classmethod
    def peaks(cls, peaks: List[float], opacity: float = 1.0, eps: float = 0.02, lut_size: int = 256, base: float = 0.0):
        """Narrow triangular peaks of ``opacity`` at each position, ``base`` elsewhere."""
        if not peaks:
            raise ValueError("At least one peak position must be specified")
        for p in peaks:
            if not (0.0 <= p <= 1.0):
                raise ValueError(f"Peak position {p} must be between 0 and 1")
        points = [(0.0, base)]
        for p in sorted(peaks):
            left = max(0.0, p - eps)
            right = min(1.0, p + eps)
            if left > points[-1][0]:
                points.append((left, base))
            points.append((p, opacity))
            if right > p:
                points.append((right, base))
        if points[-1][0] < 1.0:
            points.append((1.0, base))
        return cls(points, lut_size=lut_size)

    def to_lut(self, size: Optional[int] = None) -> np.ndarray:
        """(n,) float32 opacities at ``linspace(0, 1, n)``; n = size or lut_size."""
        return self._table(size)[:, 0]

    def apply_to_array(self, scalar_array) -> np.ndarray:
        """The opacity of each value in ``scalar_array`` (normalised to [0, 1]), in an
        array of its shape."""
        return self._apply(scalar_array)[..., 0]

    def __repr__(self) -> str:
        return f"OpacityTransferFunction(control_points={self.control_points}, lut_size={self.lut_size})"
