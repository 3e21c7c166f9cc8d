"""Synthetic volumes for examples, tests and benchmarks, one real volume
shipped with pyvr (``fuel``), and a reader for VTK image data files."""

from .files import fuel, fuel_path
from .synthetic import compute_normal_volume, create_sample_volume, shepp_logan_3d
from .vti import VtiImage, load_vti

__all__ = ["create_sample_volume", "compute_normal_volume", "shepp_logan_3d", "load_vti", "VtiImage", "fuel", "fuel_path"]
