"""Number checks that accept numpy scalars (pyvr 0.4.1 rejected np.float32)."""

import numbers

import numpy as np


def is_number(x) -> bool:
    """True for Python and numpy real numbers, including bool (as pyvr)."""
    return isinstance(x, (numbers.Real, np.bool_)) and not isinstance(x, complex)


def is_vec3(x) -> bool:
    return isinstance(x, np.ndarray) and x.shape == (3,)
