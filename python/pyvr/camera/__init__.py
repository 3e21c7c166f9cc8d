"""Camera parameters, spherical placement and interactive control."""

from .camera import Camera, CameraError, degrees_to_radians, radians_to_degrees, validate_camera_angles
from .control import CameraController, CameraPath, get_camera_pos, get_camera_pos_from_params

__version__ = "0.2.1"

__all__ = [
    "get_camera_pos",
    "get_camera_pos_from_params",
    "Camera",
    "CameraPath",
    "CameraController",
    "CameraError",
    "validate_camera_angles",
    "degrees_to_radians",
    "radians_to_degrees",
]
