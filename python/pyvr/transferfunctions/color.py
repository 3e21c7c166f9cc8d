"""Colour transfer functions."""

from typing import List, Optional, Tuple

import numpy as np

from .._core import colormap_table
from .._numbers import check_count
from .base import MAX_LUT_SIZE, BaseTransferFunction, InvalidControlPointError, validate_control_points_format

RGB = Tuple[float, float, float]


class ColorTransferFunction(BaseTransferFunction):
    """Maps scalars in [0, 1] to RGB by linear interpolation of control points."""

    def __init__(self, control_points: Optional[List[Tuple[float, RGB]]] = None, lut_size: int = 256, *, value_range=None):
        super().__init__(control_points, lut_size, value_range=value_range)

    def _get_default_control_points(self):
        return [(0.0, (0.0, 0.0, 0.0)), (1.0, (1.0, 1.0, 1.0))]

    def _validate_control_points(self) -> None:
        validate_control_points_format(self.control_points, 3)
        self._validate_scalar_range()
        for i, (_, rgb) in enumerate(self.control_points):
            for j, c in enumerate(rgb):
                if not (0.0 <= c <= 1.0):
                    raise InvalidControlPointError(
                        f"Control point {i} RGB component {j} value {c} outside valid range [0.0, 1.0]"
                    )

    @classmethod
    def grayscale(cls, lut_size: int = 256) -> "ColorTransferFunction":
        """Black at the low end to white at the high end."""
        return cls([(0.0, (0.0, 0.0, 0.0)), (1.0, (1.0, 1.0, 1.0))], lut_size=lut_size)

    @classmethod
    def single_color(cls, color, lut_size: int = 256) -> "ColorTransferFunction":
        """One RGB ``color`` (three numbers in [0, 1]) at every value."""
        return cls([(0.0, color), (1.0, color)], lut_size=lut_size)

    @classmethod
    def two_color_ramp(cls, color1, color2, lut_size: int = 256) -> "ColorTransferFunction":
        """A linear ramp from ``color1`` at the low end to ``color2`` at the high end."""
        return cls([(0.0, color1), (1.0, color2)], lut_size=lut_size)

    @classmethod
    def from_colormap(cls, colormap_name: str, value_range=(0.0, 1.0), lut_size: int = 256) -> "ColorTransferFunction":
        """Sample a named colormap into ``lut_size`` control points over ``value_range``.

        Uses matplotlib's colormaps when matplotlib is installed; without it,
        pyvr's built-in tables (viridis, plasma, inferno, magma, cividis,
        gray, bone, copper, hot, cool, turbo, jet, coolwarm, Greys) serve.
        """
        x = np.linspace(0.0, 1.0, check_count("lut_size", lut_size, high=MAX_LUT_SIZE))
        colors = _sample_colormap(colormap_name, x)
        vmin, vmax = value_range
        x_mapped = vmin + x * (vmax - vmin)
        points = [
            (float(xm), (float(c[0]), float(c[1]), float(c[2])))
            for xm, c in zip(x_mapped, colors)
        ]
        return cls(points, lut_size=lut_size)

    def to_lut(self, size: Optional[int] = None) -> np.ndarray:
        """(n, 3) float32 RGB at ``linspace(0, 1, n)``; n = size or lut_size."""
        return self._table(size)

    def apply_to_array(self, scalar_array) -> np.ndarray:
        """The RGB colour of each value in ``scalar_array`` (normalised to [0, 1]): an
        array of its shape plus a last axis of 3."""
        return self._apply(scalar_array)

    def get_color_at(self, scalar: float) -> Tuple[float, float, float]:
        """The RGB colour at one normalised value."""
        return tuple(self._apply(np.array([scalar]))[0].tolist())

    def __repr__(self) -> str:
        return f"ColorTransferFunction({len(self.control_points)} control points, lut_size={self.lut_size})"


def _sample_colormap(name: str, x: np.ndarray) -> np.ndarray:
    try:
        import matplotlib
    except ImportError:
        table = colormap_table(name)
        if table is None:
            from .._core import colormap_names

            raise ValueError(
                f"Unknown colormap name '{name}': matplotlib is not installed and the built-in "
                f"colormaps are {colormap_names()}"
            ) from None
        # matplotlib's rule for float input: entry min(int(x * N), N - 1).
        idx = np.minimum((x * len(table)).astype(int), len(table) - 1)
        return table[idx]
    try:
        cmap = matplotlib.colormaps.get_cmap(name)
    except Exception as e:  # matplotlib raises ValueError/KeyError by version
        raise ValueError(f"Unknown colormap name '{name}': {e}") from None
    colors = cmap(x)
    return colors[:, :3] if colors.shape[1] == 4 else colors
