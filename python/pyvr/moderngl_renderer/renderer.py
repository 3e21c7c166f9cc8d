"""Compatibility path: pyvr 0.4.1 defined its renderer in this module.

``from pyvr.moderngl_renderer.renderer import VolumeRenderer`` gives the
wgpu renderer, :class:`pyvr.renderer.VolumeRenderer`; OpenGL is no longer
used, so the module's ``ModernGLManager`` has no counterpart here.
Kept for compatibility only.
"""

from ..camera import Camera
from ..lighting import Light
from ..renderer import VolumeRenderer
from ..transferfunctions import ColorTransferFunction, OpacityTransferFunction
from ..volume import Volume

ModernGLVolumeRenderer = VolumeRenderer

__all__ = ["VolumeRenderer", "ModernGLVolumeRenderer", "Camera", "Light", "ColorTransferFunction",
           "OpacityTransferFunction", "Volume"]
