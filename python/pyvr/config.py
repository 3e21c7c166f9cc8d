"""Rendering configuration: quality presets that trade step size for time.

``RenderConfig`` is implemented in Rust (``pyvr._core``) with pyvr 0.4.1's
fields, defaults, presets, validation messages and repr. Two fields are
additions at the end of the signature, so positional calls keep working:

* ``reference_step_size`` (0.01): the step at which transfer-function
  opacities are defined (Beer–Lambert opacity correction).
* ``opacity_correction`` ("exponential"): ``1 - exp(-a*d/ref)`` as pyvr, or
  "power": ``1 - (1-a)**(d/ref)`` as VTK.

Unlike pyvr, ``reference_step_size <= 0`` and non-finite values raise
ValueError, and numpy scalars are accepted wherever numbers are.
"""

from ._core import RenderConfig


class RenderConfigError(ValueError):
    """Kept for compatibility with pyvr 0.4.1 (never raised)."""


__all__ = ["RenderConfig", "RenderConfigError"]
