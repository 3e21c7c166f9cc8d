"""What every reader returns: the voxels in pyvr's axis order with the
file's geometry, and how that becomes a Volume."""

import os
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from ..volume import Volume


class FileFormatError(ValueError):
    """A file that cannot be read as the format it claims: truncated, sizes
    that disagree, absurd dimensions, unknown types. Names the file.
    ``available_arrays``: when the array asked for is not in the file, the
    names of those that are (else None)."""

    available_arrays = None


class Malformed(Exception):
    """Raised inside a reader for a malformed part of a file; ``names_file``
    turns it into a FileFormatError that names the file."""

    def __init__(self, message: str, *, available_arrays=None):
        super().__init__(message)
        self.available_arrays = available_arrays


@contextmanager
def names_file(path):
    try:
        yield
    except Malformed as e:
        err = FileFormatError(f"{path}: {e}")
        err.available_arrays = e.available_arrays
        raise err from None


def choose_key(path, keys, key, what="arrays"):
    """``key`` if ``keys`` holds it, the only key when ``key`` is None, else
    a ValueError listing them."""
    keys = list(keys)
    if key is None:
        if len(keys) != 1:
            raise ValueError(f"{path} holds {what} {keys}: pass key= to choose one")
        return keys[0]
    if key not in keys:
        raise ValueError(f"{path} has no array {key!r}; it holds {keys}")
    return key


@dataclass
class GridImage:
    """A regular grid read from a file.

    ``data[i, j, k]`` is the sample at ``origin + (i, j, k) * spacing``: axis 0
    along the file's x, as pyvr's Volume wants it. ``spacing`` and ``origin``
    are in the file's spatial unit (``units``, e.g. "mm", or None when the file
    does not say); ``value_unit`` names the values' unit where the format
    carries one (e.g. "HU" for CT).
    """

    data: np.ndarray
    spacing: np.ndarray
    origin: np.ndarray
    name: str
    format: str
    units: Optional[str] = None
    value_unit: Optional[str] = None
    extra: dict = field(default_factory=dict)

    def bounds(self) -> Tuple[np.ndarray, np.ndarray]:
        """The box the voxels fill, cell-centred: each sample owns one
        spacing around it, so the box is ``shape * spacing`` long and starts
        half a spacing before the origin."""
        lo = np.asarray(self.origin, np.float64) - 0.5 * np.asarray(self.spacing, np.float64)
        return lo, lo + np.array(self.data.shape, np.float64) * self.spacing


def memory_limit() -> int:
    """Bytes of physical memory (a bound for any one array a reader makes)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 40


def check_shape(path, shape, dtype) -> Tuple[int, int, int]:
    """Dimensions as three positive ints whose array fits in memory, checked
    before anything of that size is allocated."""
    try:
        dims = tuple(int(d) for d in shape)
    except (TypeError, ValueError):
        raise FileFormatError(f"{path}: dimensions {shape!r} are not integers") from None
    if len(dims) != 3:
        raise FileFormatError(f"{path}: a volume needs 3 dimensions, the file has {len(dims)}: {dims}")
    if any(d < 1 for d in dims):
        raise FileFormatError(f"{path}: Invalid dimensions: {dims} (each must be positive)")
    nbytes = int(np.prod(dims, dtype=object)) * np.dtype(dtype).itemsize
    if nbytes > memory_limit():
        raise FileFormatError(
            f"{path}: dimensions {dims} of {np.dtype(dtype).name} need {nbytes / 2**30:.1f} GiB, "
            f"more than this machine's {memory_limit() / 2**30:.1f} GiB of memory"
        )
    return dims


def check_spacing(path, spacing) -> np.ndarray:
    s = np.asarray(spacing, dtype=np.float64).reshape(-1)
    if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise FileFormatError(f"{path}: spacing must be three positive numbers, got {list(np.ravel(spacing))}")
    return s


def to_volume(image: GridImage, *, box: str = "unit", normals: bool = False,
              value_range="data") -> Volume:
    """A Volume of ``image``'s voxels (the array itself, never copied).

    box: ``"unit"`` (default) scales the physical box, keeping its
    proportions, so that its longest side spans [-1, 1] and centres it at the
    origin (pyvr's loader rule, so the presets' step sizes and the default
    cameras suit it); ``"physical"`` keeps the file's own coordinates.
    Either way ``volume.metadata`` records the physical geometry and
    ``world_per_unit``, the world length of one physical unit.
    value_range: ``"data"`` (default) makes the transfer functions span the
    data's finite min..max; None keeps pyvr's rule ([0, 1] for floats, the
    type's range for uint8/uint16); or a (low, high) pair in data units.
    """
    if box not in ("unit", "physical"):
        raise ValueError(f"box must be 'unit' or 'physical', got {box!r}")
    lo, hi = image.bounds()
    if box == "unit":
        scale = 2.0 / float(np.max(hi - lo))
        centre = 0.5 * (lo + hi)
        wlo, whi = (lo - centre) * scale, (hi - centre) * scale
    else:
        scale = 1.0
        wlo, whi = lo, hi
    data = image.data
    vr = None
    if isinstance(value_range, str):
        if value_range != "data":
            raise ValueError(f"value_range must be 'data', None or (low, high), got {value_range!r}")
        from ..volume.data import data_range

        vr = data_range(data)
    elif value_range is not None:
        from ..transferfunctions.value_range import check_value_range

        vr = check_value_range(value_range)
    metadata = {
        "format": image.format,
        "spacing": np.asarray(image.spacing, np.float64).copy(),
        "origin": np.asarray(image.origin, np.float64).copy(),
        "physical_bounds": (lo, hi),
        "units": image.units,
        "value_unit": image.value_unit,
        "world_per_unit": scale,
        "dtype": str(data.dtype),
        **image.extra,
    }
    vol = Volume(
        data=data,
        min_bounds=wlo.astype(np.float32),
        max_bounds=whi.astype(np.float32),
        name=image.name,
        value_range=vr,
        metadata=metadata,
    )
    if normals:
        vol.compute_normals()
    return vol
