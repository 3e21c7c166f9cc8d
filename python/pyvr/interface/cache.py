"""Cached log histograms of volumes, for the opacity editor's backdrop.

The cache lives in the user's cache folder (``$PYVR_CACHE_DIR``, else
``$XDG_CACHE_HOME/pyvr/histogram_cache``, else
``~/.cache/pyvr/histogram_cache``); pyvr 0.4.1 wrote it beside the installed
package. Entries are ``.npz`` files read without pickle.
"""

import hashlib
import os
import warnings
from pathlib import Path
from typing import Optional, Tuple

import numpy as np


def _cache_dir() -> Path:
    if os.environ.get("PYVR_CACHE_DIR"):
        return Path(os.environ["PYVR_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "pyvr" / "histogram_cache"


CACHE_DIR = _cache_dir()

Histogram = Tuple[np.ndarray, np.ndarray]


def compute_volume_hash(volume_data: np.ndarray, value_range: Tuple[float, float] = (0.0, 1.0)) -> str:
    """sha256 (hex) of the shape, dtype, value range and 1000 evenly spaced
    voxels: cheap at any size, and different for the usual different volumes."""
    a = np.asarray(volume_data)
    flat = a.reshape(-1)
    idx = np.linspace(0, flat.size - 1, num=min(1000, flat.size)).astype(np.int64) if flat.size else []
    h = hashlib.sha256()
    h.update(str(a.shape).encode())
    h.update(str(a.dtype).encode())
    h.update(np.asarray(value_range, np.float64).tobytes())
    h.update(np.ascontiguousarray(flat[idx]).tobytes())
    return h.hexdigest()


def compute_log_histogram(volume_data: np.ndarray, num_bins: int = 256,
                          value_range: Tuple[float, float] = (0.0, 1.0)) -> Histogram:
    """(bin_edges, log10(counts + 1)) of the finite voxels over ``value_range``
    (the values the transfer function's [0, 1] spans; default pyvr's)."""
    if isinstance(num_bins, bool) or not isinstance(num_bins, (int, np.integer)) or num_bins < 1:
        raise ValueError(f"num_bins must be a positive integer, got {num_bins!r}")
    lo, hi = (float(v) for v in value_range)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"value_range must be two finite numbers, low < high, got {value_range!r}")
    counts, edges = np.histogram(np.asarray(volume_data).reshape(-1), bins=int(num_bins), range=(lo, hi))
    return edges, np.log10(counts.astype(np.float64) + 1.0)


def _path(key: str) -> Path:
    return CACHE_DIR / f"{key}.npz"


def get_cached_histogram(volume_data: np.ndarray, value_range=(0.0, 1.0)) -> Optional[Histogram]:
    path = _path(compute_volume_hash(volume_data, value_range))
    try:
        with np.load(path, allow_pickle=False) as f:
            return f["bin_edges"], f["log_counts"]
    except (OSError, KeyError, ValueError):
        return None


def cache_histogram(volume_data: np.ndarray, bin_edges: np.ndarray, counts: np.ndarray, value_range=(0.0, 1.0)) -> None:
    """Store a histogram; a cache folder that cannot be written is skipped
    with a warning."""
    path = _path(compute_volume_hash(volume_data, value_range))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        np.savez(tmp, bin_edges=bin_edges, log_counts=counts)
        os.replace(tmp, path)  # readers never see a half-written file
    except OSError as e:
        warnings.warn(f"Failed to cache histogram: {e}", UserWarning, stacklevel=2)


def get_or_compute_histogram(volume_data: np.ndarray, num_bins: int = 256, value_range=(0.0, 1.0)) -> Histogram:
    cached = get_cached_histogram(volume_data, value_range)
    if cached is not None and len(cached[1]) == num_bins:
        return cached
    edges, counts = compute_log_histogram(volume_data, num_bins, value_range)
    cache_histogram(volume_data, edges, counts, value_range)
    return edges, counts


def clear_histogram_cache() -> int:
    """Delete the cached histograms; returns how many were deleted."""
    n = 0
    if CACHE_DIR.is_dir():
        for p in CACHE_DIR.glob("*.npz"):
            try:
                p.unlink()
                n += 1
            except OSError:
                pass
    return n
