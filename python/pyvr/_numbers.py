"""Number checks shared by the API: numpy scalars count as numbers (pyvr
0.4.1 rejected np.float32); bools and complex numbers do not (``True`` as a
step size is a mistake, not 1.0)."""

import numbers
from typing import Optional

import numpy as np


def is_number(x) -> bool:
    """True for Python and numpy real numbers; False for bool and complex."""
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


def is_vec3(x) -> bool:
    return isinstance(x, np.ndarray) and x.shape == (3,)


def finite_vec3(name: str, x) -> None:
    """ValueError unless ``x`` is a (3,) numpy array of finite real numbers."""
    if not is_vec3(x):
        raise ValueError(f"{name} must be a 3D numpy array")
    if not (np.issubdtype(x.dtype, np.integer) or np.issubdtype(x.dtype, np.floating)):
        raise ValueError(f"{name} must hold real numbers, got dtype {x.dtype}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be finite, got {x}")


def check_count(name: str, x, *, low: int = 1, high: Optional[int] = None) -> int:
    """``x`` as an int in [low, high] (no upper bound for None): TypeError
    for non-integers (bool included), ValueError naming the range otherwise."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(x).__name__}")
    if int(x) < low:
        raise ValueError(f"{name} must be at least {low}, got {x}")
    if high is not None and int(x) > high:
        raise ValueError(f"{name} must be at most {high}, got {x}")
    return int(x)
