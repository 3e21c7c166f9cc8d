"""Volumes in bricks: larger than one 3-D texture, than a device memory
budget, or than host memory (numpy memmaps, zarr and dask arrays, xarray
DataArrays).

The volume is cut into a regular grid of bricks, each stored with ghost
voxels around it (enough for a half step, an isosurface bracket and the
gradient's stencil). A frame dispatches the bricks front to back along every
ray; each marches only the segments of the global, entry-anchored segment
grid whose midpoints fall inside it, and the rays' state carries from brick
to brick, so the image equals the single-texture one (tests/test_bricks.py).
Bricks no sample of which can show under the transfer function are never
read. When every brick fits within the memory budget they stay on the
device; otherwise each frame streams them in, one at a time, and host memory
holds at most one brick (plus its converted copy) at once. Loading reads
nothing: each brick is read when a frame first needs it.
"""

from __future__ import annotations

from typing import Any, Iterator, Optional, Sequence, Tuple

import numpy as np

from ._arrays import check_array_like, is_lazy  # noqa: F401 (part of this module's API)

#: Core side of a brick chosen by default, in voxels.
DEFAULT_BRICK_SIDE = 256
#: Device bytes the bricks of one volume may keep resident by default.
DEFAULT_MEMORY_BUDGET = 4 << 30


def xarray_bounds(arr: Any) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """The box of an xarray DataArray's cell-centred coordinates (evenly
    spaced ones only), in dimension order; None if it has none."""
    lo, hi = [], []
    for dim, n in zip(arr.dims, arr.shape):
        if dim not in arr.coords or n < 2:
            return None
        c = np.asarray(arr.coords[dim].values, dtype=np.float64)
        step = np.diff(c)
        if not (np.all(step > 0) and np.allclose(step, step[0], rtol=1e-6)):
            raise ValueError(
                f"coordinate {dim!r} must increase evenly to give the voxel spacing, got steps from "
                f"{step.min():.6g} to {step.max():.6g}"
            )
        lo.append(c[0] - step[0] / 2)
        hi.append(c[-1] + step[0] / 2)
    return np.array(lo, np.float32), np.array(hi, np.float32)


def as_volume(data: Any):
    """A Volume around an array or lazy array-like; an xarray DataArray's
    evenly spaced coordinates give the box (cell centres)."""
    from .volume import Volume

    kw = {}
    if type(data).__module__.split(".")[0] == "xarray":
        box = xarray_bounds(data)
        if box is not None:
            kw = {"min_bounds": box[0], "max_bounds": box[1]}
        name = getattr(data, "name", None)
        if name is not None:
            kw["name"] = str(name)
    return Volume(data=data, **kw)


def read_block(data: Any, ranges: Sequence[Sequence[int]]) -> np.ndarray:
    """The voxels ``ranges`` ((lo, hi) per axis) of any supported array, in memory."""
    sl = tuple(slice(int(lo), int(hi)) for lo, hi in ranges)
    mod = type(data).__module__.split(".")[0]
    if mod == "xarray":
        data = data.data
        mod = type(data).__module__.split(".")[0]
    if isinstance(data, np.memmap):
        direct = _read_file_block(data, ranges)
        if direct is not None:
            return direct
    if isinstance(data, np.memmap):
        _check_mapped_file(data)
    try:
        block = data[sl]
        if mod == "dask":
            block = block.compute()
    except (OSError, MemoryError):
        raise
    except Exception as e:
        # A corrupt chunk of a zarr store, a failing dask task: the
        # library's error, with what was being read and from where.
        from .dataloaders.image import FileFormatError

        raise FileFormatError(f"reading voxels {[tuple(map(int, r)) for r in ranges]} of {_source(data)} failed "
                              f"({type(e).__name__}: {e})") from e
    if isinstance(data, np.memmap):
        block = np.array(block)
        _release_pages(data)
    return np.asarray(block)


def _source(data: Any) -> str:
    """Where an array not in memory reads from, as far as it says."""
    for attr in ("filename", "store", "name"):
        value = getattr(data, attr, None)
        if value:
            return f"{type(data).__name__} {value}"
    return type(data).__name__


def _check_mapped_file(mm: np.memmap) -> None:
    """A clear error, before any page is touched, when a memmap's file is
    now shorter than its mapping: reading such a page kills the process
    with SIGBUS."""
    import mmap
    import os

    base = mm
    while base is not None and not isinstance(base, mmap.mmap):
        base = getattr(base, "base", None)
    filename = getattr(mm, "filename", None)
    if base is None or not filename:
        return
    # numpy maps from the offset rounded down to the allocation granularity.
    start = int(getattr(mm, "offset", 0)) // mmap.ALLOCATIONGRANULARITY * mmap.ALLOCATIONGRANULARITY
    try:
        size = os.path.getsize(filename)
    except OSError as e:
        raise ValueError(f"{filename}: the memmap's file cannot be read any more ({e})") from None
    if size < start + len(base):
        raise ValueError(f"{filename} ends before the memmap's shape {mm.shape} says it does "
                         f"({size} bytes, the mapping needs {start + len(base)})")


def _read_file_block(mm: np.memmap, ranges) -> Optional[np.ndarray]:
    """A block of a C-ordered memmap read from its file with pread, one
    slab of whole rows at a time: the process never maps the file's pages
    (a fault maps its neighbours too, tens of MiB per brick). None when the
    memmap is a view or not C-ordered."""
    import mmap
    import os

    # A copy-on-write map ("c") may hold changes the file does not.
    if not (mm.ndim == 3 and len(ranges) == 3 and isinstance(mm.base, mmap.mmap) and mm.flags.c_contiguous
            and getattr(mm, "filename", None) and getattr(mm, "mode", None) in ("r", "r+", "w+")):
        return None
    (i0, i1), (j0, j1), (k0, k1) = [(int(lo), int(hi)) for lo, hi in ranges]
    n1, n2 = mm.shape[1], mm.shape[2]
    row = n2 * mm.dtype.itemsize
    out = np.empty((i1 - i0, j1 - j0, k1 - k0), dtype=mm.dtype)
    with open(mm.filename, "rb") as f:
        # The path may now name another file (saved over by rename): the
        # mapping still holds the one the volume was made from, so read
        # through it. The first read records which file that is.
        st = os.fstat(f.fileno())
        seen = mm.__dict__.setdefault("_pyvr_file", (st.st_dev, st.st_ino))
        if seen != (st.st_dev, st.st_ino):
            return None
        for i in range(i0, i1):
            start = mm.offset + (i * n1 + j0) * row
            want = (j1 - j0) * row
            buf = os.pread(f.fileno(), want, start)
            if len(buf) != want:
                raise ValueError(f"{mm.filename} ends before the memmap's shape {mm.shape} says it does")
            out[i - i0] = np.frombuffer(buf, dtype=mm.dtype).reshape(j1 - j0, n2)[:, k0:k1]
    return out


def _release_pages(mm: np.memmap) -> None:
    """Drops a memmap's file pages from this process (they stay in the page
    cache): read pages count in the process's memory until unmapped, so
    streaming a large file brick by brick would otherwise fill it."""
    import mmap

    m = getattr(mm, "_mmap", None)
    # Never for copy-on-write maps ("c"): their changed pages live nowhere else.
    if m is not None and getattr(mm, "mode", None) in ("r", "r+", "readonly", "readwrite") \
            and hasattr(mmap, "MADV_DONTNEED"):
        try:
            m.madvise(mmap.MADV_DONTNEED)
        except (OSError, ValueError):
            pass


def check_brick_shape(requested) -> Tuple[int, int, int]:
    """``brick_shape`` as three positive integers, or a clear error."""
    from ._numbers import check_count

    if isinstance(requested, (str, bytes)) or not hasattr(requested, "__len__") or len(requested) != 3:
        raise ValueError(f"brick_shape must be three positive integers, got {requested!r}")
    for v in requested:
        check_count("brick_shape", v)
    return tuple(int(v) for v in requested)


def brick_shape_for(shape, ghost: int, max_side: int, requested=None) -> Tuple[int, int, int]:
    """The core shape of a brick: ``requested`` when given, else cubes of
    DEFAULT_BRICK_SIDE, within the device's texture limit with ghosts."""
    core = check_brick_shape(requested) if requested is not None else (DEFAULT_BRICK_SIDE,) * 3
    limit = max_side - 2 * ghost
    if limit < 1:
        raise ValueError(
            f"bricks need {ghost} ghost voxels a side, which this device's 3-D texture limit of {max_side} "
            "cannot hold: use a smaller step_size"
        )
    return tuple(min(c, limit, n) for c, n in zip(core, shape))


class BrickedVolume:
    """The bricks of one loaded volume and how they reach the device."""

    def __init__(self, data, normals, shape, bounds, precision: str, core, ghost: int, memory_budget: int):
        self.data = data
        self.normals = normals
        self.shape = tuple(int(v) for v in shape)
        self.bounds = bounds
        self.precision = precision
        self.core = core
        self.ghost = ghost
        self.memory_budget = memory_budget
        self.ranges: list = []
        self.resident = False

    def texel_bytes(self) -> int:
        """Bytes one voxel takes on the device at this volume's precision, normals
        included."""
        from ._storage import device_texel_bytes

        return device_texel_bytes(self.data, self.normals is not None, self.precision)[1]

    def device_bytes(self) -> int:
        """Bytes all bricks (the voxel ranges they hold) take on the device."""
        return sum(int(np.prod([hi - lo for lo, hi in r])) for r in self.ranges) * self.texel_bytes()

    def layout(self, engine) -> None:
        """Lays the bricks out in ``engine``. Nothing is read here: a brick
        is read when a frame first needs it, and its value ranges, kept
        from then on, let later frames skip it while nothing in it can
        show. Bricks stay on the device when all fit in the memory budget."""
        engine.set_brick_layout(self.shape, *self.bounds, self.core, self.ghost)
        self.ranges = [tuple(tuple(r) for r in b) for b in engine.brick_ranges()]
        self.resident = self.device_bytes() <= self.memory_budget

    def read(self, i: int):
        """Brick ``i``'s voxels and normals, in memory and ready to upload."""
        from ._storage import prepare_normals, prepare_voxels

        r = self.ranges[i]
        block = prepare_voxels(read_block(self.data, r))
        normals = None
        if self.normals is not None:
            normals = prepare_normals(read_block(self.normals, list(r) + [(0, 3)]))
        return block, normals

    def bricks_of(self, engine, order) -> Iterator[int]:
        """Bricks of a frame in order, each on the device while it is used."""
        for i in order:
            if not engine.brick_resident(i):
                # Read while the device renders the brick before; then let it
                # finish, so that streamed bricks never pile up on the device.
                block, normals = self.read(i)
                if not self.resident:
                    engine.wait_idle()
                engine.set_brick(i, block, normals, self.precision)
                del block, normals
            yield i
            if not self.resident:
                engine.evict_brick(i)

    def render(self, engine, camera_args, light_args, cfg, keep_state: bool = False, only=None):
        """One frame through ``engine``; ``only``: render just these bricks
        (a partial image of them)."""
        order = engine.begin_bricks(camera_args, light_args, cfg, keep_state)
        if only is not None:
            keep = set(only)
            order = [i for i in order if i in keep]
        for i in self.bricks_of(engine, order):
            engine.render_brick(i)
        return engine.end_bricks()


def ghost_for(step: float, bounds, shape) -> int:
    """Ghost voxels for segments of ``step`` in a volume of ``shape`` in ``bounds``."""
    from . import _core

    spacing = np.subtract(bounds[1], bounds[0]) / np.asarray(shape, dtype=np.float64)
    return _core.brick_ghost(float(step), tuple(float(v) for v in spacing))
