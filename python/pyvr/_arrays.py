"""Arrays whose voxels are not (all) in memory (numpy memmaps, zarr, dask,
xarray), recognised without importing those packages."""

from typing import Any

import numpy as np


def is_lazy(data: Any) -> bool:
    """True for arrays whose voxels are not (all) in memory: numpy memmaps,
    zarr arrays, dask arrays, xarray DataArrays."""
    if isinstance(data, np.memmap):
        return True
    if isinstance(data, np.ndarray):
        return False
    mod = type(data).__module__.split(".")[0]
    return mod in ("zarr", "dask", "xarray") and hasattr(data, "shape") and hasattr(data, "dtype")


def check_array_like(data: Any) -> None:
    """A lazy array must look like a 3-D array of real numbers."""
    shape = getattr(data, "shape", None)
    if shape is None or len(shape) != 3:
        raise ValueError(f"Volume data must be 3D, got shape {shape}")
    dt = np.dtype(data.dtype)
    if (not np.issubdtype(dt, np.number) and dt != np.bool_) or np.issubdtype(dt, np.complexfloating):
        raise TypeError(f"Volume data must be a real numeric array, got dtype {dt}")
