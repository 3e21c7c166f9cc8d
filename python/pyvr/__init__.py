"""pyvr: direct volume rendering of 3-D numpy arrays.

The API is pyvr 0.4.1's; the engine is Rust (``pyvr._core``) rendering with
wgpu compute shaders. ``import pyvr`` needs numpy and scipy only; matplotlib,
Pillow and moderngl are imported when a feature needs them.
"""

from . import bricks, camera, dataloaders, datasets, distributed, lighting, moderngl_renderer, transferfunctions, volume
from .animation import save_animation
from .config import RenderConfig
from .dataloaders import load
from .renderer import VolumeRenderer

__version__ = "0.5.0"


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
