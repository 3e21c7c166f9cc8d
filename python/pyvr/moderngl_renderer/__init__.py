"""Compatibility path for pyvr 0.4.1 imports.

``from pyvr.moderngl_renderer import VolumeRenderer`` keeps working and
gives the wgpu renderer (``pyvr.renderer.VolumeRenderer``); OpenGL is no
longer used. ``ModernGLVolumeRenderer`` is the same class.
"""

from ..camera import Camera, CameraController
from ..datasets import compute_normal_volume, create_sample_volume
from ..renderer import VolumeRenderer
from ..transferfunctions import ColorTransferFunction, OpacityTransferFunction

ModernGLVolumeRenderer = VolumeRenderer

__all__ = [
    "ColorTransferFunction",
    "OpacityTransferFunction",
    "ModernGLVolumeRenderer",
    "VolumeRenderer",
    "CameraController",
    "Camera",
    "create_sample_volume",
    "compute_normal_volume",
]
