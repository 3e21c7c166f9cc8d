"""Base class and validation shared by colour and opacity transfer functions."""

from abc import ABC, abstractmethod
from typing import List, Optional, Tuple

import numpy as np

from .._numbers import check_count, is_number

#: Largest table a transfer function tabulates (entries). A renderer's own
#: limit (its device's texture width) may be lower; it says so on use.
MAX_LUT_SIZE = 1 << 20


class TransferFunctionError(ValueError):
    """Base error for transfer functions."""


class InvalidControlPointError(TransferFunctionError):
    """A control point is malformed or out of range."""


class BaseTransferFunction(ABC):
    """A piecewise-linear function of the scalar value, given by control points.

    Subclasses define ``_get_default_control_points``,
    ``_validate_control_points`` and ``to_lut``. Any subclass whose ``to_lut``
    returns ``(size,)`` or ``(size, 3)`` values can be given to the renderer.
    """

    def __init__(self, control_points: Optional[List[Tuple]] = None, lut_size: int = 256, *, value_range=None):
        if control_points is None:
            control_points = self._get_default_control_points()
        self.control_points = sorted(_as_points(control_points), key=lambda p: p[0])
        self.lut_size = lut_size
        self.value_range = value_range
        self._validate_control_points()

    @property
    def lut_size(self) -> int:
        """Entries in the table ``to_lut()`` makes by default (1 to MAX_LUT_SIZE)."""
        return self._lut_size

    @lut_size.setter
    def lut_size(self, n) -> None:
        self._lut_size = check_count("lut_size", n, high=MAX_LUT_SIZE)

    @property
    def value_range(self) -> Optional[Tuple[float, float]]:
        """The (low, high) data values this function's [0, 1] domain spans,
        or None (the volume's value_range, else pyvr's rule). See
        :mod:`pyvr.transferfunctions.value_range`. Not the ``value_range``
        argument of ``ColorTransferFunction.from_colormap`` (pyvr's), which
        places the colormap inside [0, 1]."""
        return getattr(self, "_value_range", None)

    @value_range.setter
    def value_range(self, value_range) -> None:
        from .value_range import check_value_range

        self._value_range = None if value_range is None else check_value_range(value_range)

    @abstractmethod
    def _get_default_control_points(self) -> List[Tuple]:
        ...

    @abstractmethod
    def _validate_control_points(self) -> None:
        ...

    @abstractmethod
    def to_lut(self, size: Optional[int] = None) -> np.ndarray:
        """The lookup table the renderer samples: ``(size,)`` opacities or ``(size,
        3)`` colours, entry i at value i / (size - 1) of the value range (``size``
        defaults to ``lut_size``)."""
        ...

    def __call__(self, size: Optional[int] = None) -> np.ndarray:
        return self.to_lut(size)

    def _validate_scalar_range(self, min_val: float = 0.0, max_val: float = 1.0) -> None:
        for scalar, _ in self.control_points:
            if not (min_val <= scalar <= max_val):
                raise ValueError(f"Control point scalar {scalar} outside valid range [{min_val}, {max_val}]")

    def _get_scalar_values(self) -> np.ndarray:
        return np.array([p[0] for p in self.control_points])

    def _get_mapped_values(self) -> np.ndarray:
        return np.array([p[1] for p in self.control_points])

    def _table(self, size: Optional[int]) -> np.ndarray:
        """Values at ``linspace(0, 1, n)`` with numpy.interp rules, as (n, C) float32."""
        n = self.lut_size if size is None else check_count("size", size, high=MAX_LUT_SIZE)
        scalars = np.ascontiguousarray(self._get_scalar_values(), dtype=np.float64)
        values = np.asarray(self._get_mapped_values(), dtype=np.float64)
        values = values.reshape(len(scalars), -1)
        x = np.linspace(0.0, 1.0, int(n))
        return np.stack([np.interp(x, scalars, values[:, c]) for c in range(values.shape[1])], axis=-1).astype(np.float32)

    def _apply(self, scalar_array) -> np.ndarray:
        x = np.asarray(scalar_array, dtype=np.float64)
        scalars = self._get_scalar_values().astype(np.float64)
        values = np.asarray(self._get_mapped_values(), dtype=np.float64).reshape(len(scalars), -1)
        cols = [np.interp(x, scalars, values[:, c]) for c in range(values.shape[1])]
        return np.stack(cols, axis=-1).astype(np.float32)


def _as_points(control_points):
    """Control points as a list of (scalar, value): an (N, 2) or (N, 4)
    numpy array becomes rows (s, o) or (s, (r, g, b)), with numpy scalars."""
    if isinstance(control_points, np.ndarray):
        a = control_points
        if a.ndim != 2 or a.shape[1] not in (2, 4) or not np.issubdtype(a.dtype, np.number) \
                or np.issubdtype(a.dtype, np.complexfloating):
            raise InvalidControlPointError(
                f"control points as an array must be real numbers of shape (N, 2) (scalar, opacity) or "
                f"(N, 4) (scalar, r, g, b), got shape {a.shape} and dtype {a.dtype}"
            )
        a = a.astype(np.float64)
        return [(r[0], r[1]) if a.shape[1] == 2 else (r[0], tuple(r[1:])) for r in a]
    try:
        points = list(control_points)
    except TypeError:
        raise InvalidControlPointError(f"control points must be a sequence of (scalar, value) pairs, got {control_points!r}") from None
    return [tuple(p) if isinstance(p, np.ndarray) and p.ndim == 1 and len(p) == 2 else p for p in points]


def validate_control_points_format(control_points, expected_value_length: int) -> None:
    """Raise InvalidControlPointError with pyvr's messages for malformed points."""
    if not control_points:
        raise InvalidControlPointError("Control points cannot be empty")
    for i, point in enumerate(control_points):
        if not isinstance(point, (tuple, list)) or len(point) != 2:
            raise InvalidControlPointError(f"Control point {i} must be a (scalar, value) tuple, got {point}")
        scalar, value = point
        if not is_number(scalar):
            raise InvalidControlPointError(f"Control point {i} scalar must be numeric, got {type(scalar)}")
        if expected_value_length == 1:
            if not is_number(value):
                raise InvalidControlPointError(f"Control point {i} value must be numeric, got {type(value)}")
        else:
            if not isinstance(value, (tuple, list, np.ndarray)) or len(value) != expected_value_length:
                raise InvalidControlPointError(
                    f"Control point {i} value must be a {expected_value_length}-element sequence, got {value}"
                )
            for j, comp in enumerate(value):
                if not is_number(comp):
                    raise InvalidControlPointError(
                        f"Control point {i} value component {j} must be numeric, got {type(comp)}"
                    )
