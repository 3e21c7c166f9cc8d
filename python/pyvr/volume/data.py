"""The Volume: a 3-D array, its world box and optional normals (pyvr 0.4.1)."""

from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from .._numbers import finite_vec3


class VolumeError(ValueError):
    """Kept for compatibility with pyvr 0.4.1 (never raised)."""


def _f32(v):
    return np.array(v, dtype=np.float32)


@dataclass
class Volume:
    """``data[i, j, k]`` fills the box ``[min_bounds, max_bounds]`` with axis 0
    along world x, axis 1 along y, axis 2 along z; voxels are cell-centred.

    Any shape renders (pyvr scrambled shape[0] != shape[2]). Float data is
    used as given against the transfer function's [0, 1] domain; uint8 and
    uint16 data are read as fractions of their range (like GPU unorm
    textures) and stored in 1 or 2 bytes per voxel; other dtypes are
    converted to float32. NaN voxels are empty.

    Two fields are new (keyword-only in practice, after pyvr's five):
    ``value_range``, the (low, high) data values the transfer functions'
    [0, 1] domain spans for this volume (None: pyvr's rule above; a
    transfer function's own value_range takes precedence), and ``metadata``,
    what a loader knew about the file (physical spacing, origin, units).
    """

    data: np.ndarray
    normals: Optional[np.ndarray] = None
    min_bounds: np.ndarray = field(default_factory=lambda: _f32([-0.5, -0.5, -0.5]))
    max_bounds: np.ndarray = field(default_factory=lambda: _f32([0.5, 0.5, 0.5]))
    name: Optional[str] = None
    value_range: Optional[Tuple[float, float]] = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check the data (a 3-D array, in memory or lazy), normals (shape + (3,)) and
        bounds (min below max); raises ValueError or TypeError naming what is wrong."""
        from .._arrays import check_array_like, is_lazy

        if is_lazy(self.data):
            # Out of memory (memmap, zarr, dask, xarray): read brick by brick.
            check_array_like(self.data)
        elif not isinstance(self.data, np.ndarray):
            raise ValueError("Volume data must be a numpy array, or an array not in memory "
                             "(numpy memmap, zarr, dask or xarray)")
        if self.data.ndim != 3:
            raise ValueError(f"Volume data must be 3D, got shape {self.data.shape}")
        if (not np.issubdtype(self.data.dtype, np.number) and self.data.dtype != np.bool_) \
                or np.issubdtype(self.data.dtype, np.complexfloating):
            raise TypeError(f"Volume data must be a real numeric array, got dtype {self.data.dtype}")
        if self.normals is not None:
            if not isinstance(self.normals, np.ndarray) and not is_lazy(self.normals):
                raise ValueError("Normal volume must be a numpy array")
            if not np.issubdtype(self.normals.dtype, np.number) or np.issubdtype(self.normals.dtype, np.complexfloating):
                raise TypeError(f"normals must be a real numeric array, got dtype {self.normals.dtype}")
            if self.normals.shape != self.data.shape + (3,):
                raise ValueError(f"Normal volume must have shape {self.data.shape + (3,)}, got {self.normals.shape}")
        finite_vec3("min_bounds", self.min_bounds)
        finite_vec3("max_bounds", self.max_bounds)
        if np.any(self.max_bounds <= self.min_bounds):
            raise ValueError("max_bounds must be greater than min_bounds")
        if self.value_range is not None:
            from ..transferfunctions.value_range import check_value_range

            self.value_range = check_value_range(self.value_range)

    @property
    def shape(self):
        """The data's shape (x, y, z)."""
        return self.data.shape

    @property
    def dimensions(self) -> np.ndarray:
        """The box's size along each axis, ``max_bounds - min_bounds``."""
        return self.max_bounds - self.min_bounds

    @property
    def center(self) -> np.ndarray:
        """The box's centre."""
        return (self.min_bounds + self.max_bounds) / 2

    @property
    def has_normals(self) -> bool:
        """Whether per-voxel normals are stored."""
        return self.normals is not None

    @property
    def voxel_spacing(self) -> np.ndarray:
        """The box's size divided by the voxel counts, per axis."""
        return self.dimensions / np.array(self.data.shape)

    def histogram(self, bins: int = 256, value_range=None, *, log: bool = False):
        """Counts of the finite voxel values in ``bins`` equal bins over
        ``value_range`` (default: the volume's value_range, else its data
        range). Returns (counts, edges) as numpy's histogram does; with
        ``log=True`` counts are log10(1 + count), as a TF editor shows them.
        NaN and +-Inf voxels are not counted (they are empty to the renderer).
        """
        if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or bins < 1:
            raise ValueError(f"bins must be a positive integer, got {bins!r}")
        if value_range is None:
            value_range = self.value_range or data_range(self.data)
        else:
            from ..transferfunctions.value_range import check_value_range

            value_range = check_value_range(value_range)
        counts = np.zeros(int(bins), np.int64)
        edges = np.linspace(value_range[0], value_range[1], int(bins) + 1)
        # In slabs along axis 0, so a large volume needs no float copy of itself.
        d = self.data
        rows = max(1, (1 << 22) // max(1, d.shape[1] * d.shape[2]))
        for i in range(0, d.shape[0], rows):
            chunk = d[i:i + rows].astype(np.float64).ravel()
            chunk = chunk[np.isfinite(chunk)]
            counts += np.histogram(chunk, bins=edges)[0]
        if log:
            return np.log10(1.0 + counts), edges
        return counts, edges

    def compute_normals(self, method: str = "gradient") -> None:
        """Store normals computed from the data's gradient (``method='gradient'``, the
        only one): :func:`pyvr.datasets.compute_normal_volume`."""
        if method != "gradient":
            raise ValueError(f"Unsupported method: {method}")
        from ..datasets.synthetic import compute_normal_volume

        self.normals = compute_normal_volume(self.data)

    def normalize(self, method: str = "minmax") -> "Volume":
        """A new volume with the data scaled to [0, 1] (``'minmax'``) or to zero mean
        and unit deviation (``'zscore'``), as float32."""
        d = self.data.astype(np.float32)
        if method == "minmax":
            lo, hi = float(np.min(d)), float(np.max(d))
            d = np.zeros_like(d) if hi - lo < 1e-9 else (d - lo) / (hi - lo)
        elif method == "zscore":
            mu, sd = float(np.mean(d)), float(np.std(d))
            d = np.zeros_like(d) if sd < 1e-9 else (d - mu) / sd
        else:
            raise ValueError(f"Unsupported method: {method}")
        return Volume(
            data=d.astype(np.float32),
            normals=None if self.normals is None else self.normals.copy(),
            min_bounds=self.min_bounds.copy(),
            max_bounds=self.max_bounds.copy(),
            name=None if self.name is None else f"{self.name}_normalized",
            metadata=dict(self.metadata),
        )

    def copy(self) -> "Volume":
        """An independent copy of the data, normals, bounds and metadata."""
        return Volume(
            data=self.data.copy(),
            normals=None if self.normals is None else self.normals.copy(),
            min_bounds=self.min_bounds.copy(),
            max_bounds=self.max_bounds.copy(),
            name=self.name,
            value_range=self.value_range,
            metadata=dict(self.metadata),
        )

    def __repr__(self) -> str:
        name = f"'{self.name}'" if self.name is not None else "unnamed"
        normals = "with normals" if self.has_normals else "no normals"
        return f"Volume({name}, shape={self.shape}, bounds=[{self.min_bounds}, {self.max_bounds}], {normals})"


def data_range(data: np.ndarray) -> Tuple[float, float]:
    """(min, max) of the finite values; a constant or empty volume gets a
    range one unit wide so that the transfer function still has a domain."""
    a = np.asarray(data)
    if a.dtype.kind in "biu":
        lo, hi = float(a.min()), float(a.max())
    else:
        mask = np.isfinite(a)
        finite = a if mask.all() else a[mask]
        if finite.size == 0:
            return (0.0, 1.0)
        lo, hi = float(finite.min()), float(finite.max())
    if not hi > lo:
        hi = lo + 1.0
    return (lo, hi)
