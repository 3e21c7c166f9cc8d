"""Volume data with world bounds and optional normals."""

from .data import Volume, VolumeError

__all__ = ["Volume", "VolumeError"]
