"""Synthetic volumes for examples, tests and benchmarks, and a reader for
VTK image data files."""

from .synthetic import compute_normal_volume, create_sample_volume
from .vti import VtiImage, load_vti

__all__ = ["create_sample_volume", "compute_normal_volume", "load_vti", "VtiImage"]
