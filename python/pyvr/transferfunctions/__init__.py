"""Transfer functions: map scalar values to colour and opacity."""

from .base import BaseTransferFunction, InvalidControlPointError, TransferFunctionError
from .color import ColorTransferFunction
from .opacity import OpacityTransferFunction
from .value_range import CT_WINDOWS, window_level

__version__ = "0.2.2"

__all__ = [
    "BaseTransferFunction",
    "ColorTransferFunction",
    "OpacityTransferFunction",
    "TransferFunctionError",
    "InvalidControlPointError",
    "CT_WINDOWS",
    "window_level",
]
