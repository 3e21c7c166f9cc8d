"""pyvr: direct volume rendering of 3-D numpy arrays.

The API is pyvr 0.4.1's; the engine is Rust (``pyvr._core``) rendering with
wgpu compute shaders. ``import pyvr`` needs numpy and scipy only; matplotlib,
Pillow and moderngl are imported when a feature needs them.
"""

import os as _os

# Mesa's Vulkan device-select layer connects to Wayland to find the display's
# GPU, and without a valid XDG_RUNTIME_DIR (scripts, SSH sessions, services)
# it prints "XDG_RUNTIME_DIR is invalid" on every Vulkan instance. It cannot
# use Wayland there anyway, and wgpu picks its adapter itself: turn it off.
if not _os.path.isdir(_os.environ.get("XDG_RUNTIME_DIR") or "/nonexistent"):
    _os.environ.setdefault("NODEVICE_SELECT", "1")

from . import bricks, camera, dataloaders, datasets, distributed, lighting, moderngl_renderer, transferfunctions, volume
from .animation import save_animation
from .config import RenderConfig
from .dataloaders import load
from ._core import __version__
from .renderer import VolumeRenderer


def __getattr__(name):
    # pyvr 0.4.1 imported its interface with the package; it needs
    # matplotlib, so here it is imported on first use of ``pyvr.interface``.
    if name == "interface":
        import importlib

        return importlib.import_module(".interface", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "camera",
    "dataloaders",
    "datasets",
    "lighting",
    "moderngl_renderer",
    "transferfunctions",
    "volume",
    "RenderConfig",
    "VolumeRenderer",
    "load",
    "save_animation",
]
