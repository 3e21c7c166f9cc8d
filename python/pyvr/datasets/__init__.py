"""Synthetic volumes for examples, tests and benchmarks."""

from .synthetic import compute_normal_volume, create_sample_volume

__all__ = ["create_sample_volume", "compute_normal_volume"]
