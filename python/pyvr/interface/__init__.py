"""pyvr's interactive matplotlib interface (pyvr 0.4.1's API).

>>> from pyvr.interface import InteractiveVolumeRenderer
>>> InteractiveVolumeRenderer(volume).show()

Needs matplotlib and Pillow: ``pip install 'pyvr-rs[plot]'``. For Jupyter,
see ``pyvr.notebook``.
"""

from .._extras import require

require("matplotlib", "plot", "pyvr.interface")
require("PIL", "plot", "pyvr.interface")

from .matplotlib_interface import InteractiveVolumeRenderer  # noqa: E402
from .state import InterfaceState  # noqa: E402
from .widgets import ColorSelector, ImageDisplay, OpacityEditor  # noqa: E402

__all__ = ["InteractiveVolumeRenderer", "ImageDisplay", "OpacityEditor", "ColorSelector", "InterfaceState"]
