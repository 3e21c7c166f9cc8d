"""Transfer functions over the data's own units.

A transfer function's domain is [0, 1]. A value range ``(low, high)`` in
data units (Hounsfield units, a simulation's density) says which data
values that domain spans: value v is looked up at ``(v - low) / (high -
low)``, clamped to [0, 1]. The mapping is a scale and an offset applied to
each sample on the GPU (and in the float64 integrator); the volume is never
rescaled in a host copy, and integer data keeps its exact values.
"""

from typing import Dict, Optional, Tuple

import numpy as np

from .._numbers import is_number

ValueRange = Tuple[float, float]

#: Common CT windows as (window width, window level) in Hounsfield units.
CT_WINDOWS: Dict[str, Tuple[float, float]] = {
    "brain": (80.0, 40.0),
    "soft_tissue": (400.0, 40.0),
    "lung": (1500.0, -600.0),
    "bone": (2000.0, 500.0),
    "full": (4000.0, 1000.0),
}


def check_value_range(value_range) -> ValueRange:
    """``value_range`` as two finite floats with low < high, else ValueError."""
    try:
        lo, hi = value_range
    except (TypeError, ValueError):
        raise ValueError(f"value_range must be a (low, high) pair of numbers, got {value_range!r}") from None
    if not (is_number(lo) and is_number(hi)):
        raise ValueError(f"value_range must be a (low, high) pair of numbers, got {value_range!r}")
    lo, hi = float(lo), float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi)) or not hi > lo:
        raise ValueError(f"value_range must be finite with low < high, got ({lo}, {hi})")
    return (lo, hi)


def window_level(window: float, level: float) -> ValueRange:
    """The value range of a CT display window: ``level`` at its centre,
    ``window`` wide (e.g. ``window_level(400, 40)`` for soft tissue, which is
    ``(-160, 240)`` HU). Named windows are in ``CT_WINDOWS``."""
    if not (is_number(window) and is_number(level)) or not float(window) > 0:
        raise ValueError(f"window must be a positive number and level a number, got {window!r}, {level!r}")
    w, c = float(window), float(level)
    return check_value_range((c - 0.5 * w, c + 0.5 * w))


def storage_unit(dtype) -> float:
    """Data units per unit of what the device samples: uint8 and uint16 are
    stored as normalised integers (a sample reads value / 255 or / 65535);
    everything else reads its value."""
    dt = np.dtype(dtype).newbyteorder("=")  # byte order is storage, not meaning
    if dt == np.uint8:
        return 255.0
    if dt == np.uint16:
        return 65535.0
    return 1.0


def sample_map(value_range: Optional[ValueRange], dtype) -> Tuple[float, float]:
    """(scale, offset) taking a device sample of data of ``dtype`` to the
    transfer function's [0, 1]: ``tf = sample * scale + offset``."""
    if value_range is None:
        return (1.0, 0.0)
    lo, hi = value_range
    u = storage_unit(dtype)
    return (u / (hi - lo), -lo / (hi - lo))


def lut_at(lut: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A transfer-function table's RGBA at values ``v`` of its domain, as
    the engines read it: linear between entries at m / (M - 1), clamped to
    [0, 1]."""
    x = np.clip(v, 0.0, 1.0) * (len(lut) - 1)
    i = np.minimum(np.floor(x).astype(np.int64), len(lut) - 1)
    j = np.minimum(i + 1, len(lut) - 1)
    w = (x - i)[..., None]
    return lut[i] * (1 - w) + lut[j] * w
