"""How a volume is stored on the engines: the dtype and precision chosen,
the texel bytes, the device's limits and this machine's memory, checked
before any copy; the value map from data values to the transfer
functions' domain."""

import glob
import os
from typing import Optional, Tuple

import numpy as np

from . import _core
from .transferfunctions.value_range import sample_map
from .volume import Volume


def _storage_dtype(dtype) -> np.dtype:
    """The dtype the engine stores data of ``dtype`` as (see prepare_voxels)."""
    native = np.dtype(dtype).newbyteorder("=")
    if native in (np.uint8, np.uint16):
        return native
    if native == np.bool_:
        return np.dtype(np.uint8)
    return np.dtype(np.float32)


def device_texel_bytes(data, has_normals: bool, precision: str) -> Tuple[int, int]:
    """Bytes per voxel the engine stores for ``data``: (the largest texture
    it cannot do without, all its textures at most). Float values with
    normals share one float texel (value, normal): 8 bytes at float16, 16 at
    float32 where the device filters float32 textures, the values are finite
    and the texels fit one upload; else the normals are a texture of their
    own (4 bytes), beside 4-byte values. 16-bit fixed point: 2 bytes, or 8
    with normals."""
    t = 4 if isinstance(data, np.ma.MaskedArray) else _storage_dtype(data.dtype).itemsize
    if precision == "fixed16":
        t = 8 if has_normals else 2
        return t, t
    if precision == "float16" and t == 4:
        t = 8 if has_normals else 2
        return t, t
    if not has_normals:
        return t, t
    return max(t, 4), 16 if t == 4 else t + 4


PRECISIONS = ("auto", "float32", "float16", "fixed16")


# "auto" stores float data in 16-bit fixed point where the transfer
# functions' value range spans at least half the data's range: a value then
# moves by at most 2 / 131068 (1.5e-5) of the functions' domain.
FIXED16_MAX_SPAN = 2.0


# The last-level cache assumed where the system does not say.
DEFAULT_CPU_CACHE = 32 * 2**20


# At equal samples fixed point's 8-byte texels are slower than float32's
# 16 until the latter are several times the CPU's cache: decoding costs
# more than the misses it saves (benches/volume_size.py).
CACHE_FACTOR = 4


# The most cache the rule above counts on: a VM reports its host's last
# level cache, shared with every other guest, and fixed point's speed
# there follows the guest's share, not the cache reported.
TRUSTED_CPU_CACHE = 32 * 2**20


def cpu_cache_bytes() -> int:
    """The largest CPU cache this machine reports (Linux sysfs), else
    DEFAULT_CPU_CACHE."""
    sizes = []
    for path in glob.glob("/sys/devices/system/cpu/cpu0/cache/index*/size"):
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        unit = {"K": 2**10, "M": 2**20, "G": 2**30}.get(text[-1:].upper(), 1)
        digits = text[:-1] if unit > 1 else text
        if digits.isdigit():
            sizes.append(int(digits) * unit)
    return max(sizes, default=DEFAULT_CPU_CACHE)


def _fixed16_range(data) -> Optional[Tuple[float, float]]:
    """The (least, largest) value 16-bit fixed point would span, in the
    units the engine samples (integers as fractions of their type's range),
    or None where it cannot code the data (NaN, infinities, masked voxels,
    or integers spanning more than 65534 steps)."""
    if isinstance(data, np.ma.MaskedArray):
        if np.ma.getmaskarray(data).any():
            return None
        data = np.ma.getdata(data)
    a = np.asarray(data)
    if a.size == 0:
        return None
    stored = _storage_dtype(a.dtype)
    if stored != np.float32:
        scale = 255 if a.dtype == np.bool_ else 1
        lo, hi = int(a.min()) * scale, int(a.max()) * scale
        if hi - lo > 65534:
            return None
        unit = 255.0 if stored == np.uint8 else 65535.0
        return (lo / unit, hi / unit)
    # min and max propagate NaN; the stored values are float32.
    lo, hi = float(np.float32(a.min())), float(np.float32(a.max()))
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return None
    return (lo, hi)


def _check_fixed16(volume: Volume, fixed_range) -> None:
    if not device_limits().get("norm16_textures", False):
        raise ValueError("precision='fixed16' needs 16-bit normalized textures, which this device lacks: "
                         "use 'auto', 'float32' or 'float16'")
    if fixed_range is None:
        raise ValueError("precision='fixed16' needs finite values (no NaN, infinities or masked voxels) and "
                         "integers spanning at most 65534 steps: use 'auto' or 'float32'")


def _auto_precision(volume: Volume, fixed_range, scale: float) -> str:
    """What precision='auto' stores ``volume`` as, under a value map of
    ``scale`` (samples to the transfer functions' domain): 16-bit fixed
    point where it was measured faster (benches/volume_size.py,
    benches/scene_content.py): integers with normals (one 8-byte fetch
    instead of a value interpolated by hand beside 8-bit normals), and
    float data with normals on a CPU device when its float32 texels
    (16 bytes a voxel) take over CACHE_FACTOR times the CPU's largest
    cache (at most TRUSTED_CPU_CACHE). Float data only where 16 bits
    resolve the transfer functions' value range (FIXED16_MAX_SPAN)."""
    limits = device_limits()
    if volume.normals is None or fixed_range is None or not limits.get("norm16_textures", False):
        return "float32"
    if _storage_dtype(volume.data.dtype) != np.float32:
        return "fixed16"
    outgrows = 16 * volume.data.size > CACHE_FACTOR * min(cpu_cache_bytes(), TRUSTED_CPU_CACHE)
    if limits.get("cpu_device", False) and outgrows and scale * (fixed_range[1] - fixed_range[0]) <= FIXED16_MAX_SPAN:
        return "fixed16"
    return "float32"


def prepare_voxels(data: np.ndarray) -> np.ndarray:
    """The array the engine stores: uint8/uint16 kept (1 or 2 bytes per
    voxel, read as fractions of their range), bool as uint8 0/255, anything
    else float32. A masked array's masked voxels become NaN (missing data:
    empty), its integers the fractions they are read as. C-contiguous and
    aligned; the caller's array is never modified."""
    if isinstance(data, np.ma.MaskedArray):
        from .transferfunctions.value_range import storage_unit

        mask = np.ma.getmaskarray(data)
        values = prepare_voxels(np.ma.getdata(data))
        if not mask.any():
            return values
        out = values.astype(np.float32) / np.float32(storage_unit(values.dtype))
        out[mask] = np.nan
        return out
    a = np.asarray(data)
    if not np.issubdtype(a.dtype, np.number) and a.dtype != np.bool_ or np.issubdtype(a.dtype, np.complexfloating):
        raise TypeError(f"Volume data must be a real numeric array, got dtype {a.dtype}")
    out = np.require(a, dtype=_storage_dtype(a.dtype), requirements=["C", "A"])
    if a.dtype == np.bool_:
        out = out * np.uint8(255)
    return out


def prepare_normals(normals: Optional[np.ndarray]) -> Optional[np.ndarray]:
    if normals is None:
        return None
    n = np.asarray(normals)
    if not np.issubdtype(n.dtype, np.number) or np.issubdtype(n.dtype, np.complexfloating):
        raise TypeError(f"normals must be a real numeric array, got dtype {n.dtype}")
    return np.require(n, dtype=np.float32, requirements=["C", "A"])


_LIMITS: dict = {}


def device_limits() -> dict:
    """This process's device limits (queried once per process)."""
    pid = os.getpid()
    if pid not in _LIMITS:
        _LIMITS.clear()
        _LIMITS[pid] = _core.device_limits()
    return _LIMITS[pid]


def _check_volume_fits(volume: Volume, precision: str) -> None:
    """Device and host limits, checked before any copy of the data."""
    shape = volume.data.shape
    limits = device_limits()
    axis = limits["max_texture_dimension_3d"]
    if max(shape) > axis:
        raise ValueError(
            f"volume shape {shape} has an axis over this device's 3-D texture limit of {axis} voxels: "
            "downsample it (e.g. volume.data[::2, ::2, ::2]) or crop it"
        )
    voxels = int(np.prod(shape, dtype=np.int64))
    stored = _storage_dtype(volume.data.dtype)
    largest, total = device_texel_bytes(volume.data, volume.normals is not None, precision)
    device_bytes = voxels * largest
    if device_bytes > limits["max_buffer_size"]:
        raise ValueError(
            f"volume shape {shape} needs {device_bytes} bytes on the device, over its limit of "
            f"{limits['max_buffer_size']} bytes per upload; downsample or crop it"
            + (", or load it with precision='float16'" if largest == 4 and precision == "float32" else "")
        )
    plain = type(volume.data) is np.ndarray and volume.data.dtype == stored and volume.data.flags.c_contiguous
    copy = 0 if plain else voxels * 4
    from ._memory import check_fits

    # A converted copy, then packing and the driver's staging copy of what
    # the device stores (textures of values and of normals); float16's
    # empty-cell grid is built from a float32 copy of the rounded values.
    stored_bytes = voxels * total
    rounded = voxels * 4 if precision == "float16" else 0
    check_fits(f"loading volume {shape}", copy + 2 * stored_bytes + rounded, "downsample or crop the volume")


_F32 = np.finfo(np.float32)


def check_float32_storage(data: np.ndarray) -> None:
    """A ValueError, before anything is stored, for float data with finite
    values past float32's largest: the engines store voxels as float32,
    where they would become inf."""
    a = np.asarray(data)
    if a.dtype.kind != "f" or a.dtype.itemsize <= 4 or a.size == 0:
        return
    # Slab by slab: the temporaries stay small whatever the volume's size.
    rows = max(1, (16 << 20) // max(1, a[0].nbytes))
    largest = 0.0
    for start in range(0, a.shape[0], rows):
        slab = np.abs(a[start:start + rows])
        largest = max(largest, float(np.max(slab, where=np.isfinite(slab), initial=0.0)))
    if largest > float(_F32.max):
        raise ValueError(f"volume values reach {largest:.3g}, past float32's largest {float(_F32.max):.3g}, which "
                         "the engines store voxels as: scale the data (and its value range) into float32's range")


def _value_map_for(value_range, dtype) -> tuple:
    """The (scale, offset) taking ``dtype``'s device samples to the transfer
    functions' [0, 1] over ``value_range``, or a ValueError when it is not
    finite (a range so wide that high - low overflows, or so narrow that
    its inverse does)."""
    if value_range is not None:
        lo, hi = value_range
        # The engines sample float32: two values closer than its spacing
        # there (or than its smallest normal number, which GPUs flush
        # below) are one value to them.
        resolvable = max(float(_F32.tiny) * 2.0**23, max(abs(lo), abs(hi)) * 2.0**-22)
        if hi - lo < resolvable:
            raise ValueError(f"value_range {value_range} is narrower than float32, which the engines sample, "
                             f"can resolve there (at least {resolvable:.3g} wide): scale the data and its range")
    scale, offset = sample_map(value_range, dtype)
    if not (np.isfinite(scale) and scale > 0 and np.isfinite(offset)):
        raise ValueError(f"value_range {value_range} cannot map {np.dtype(dtype).name} values onto the transfer "
                         "functions: its width must be a finite positive number whose inverse is finite too")
    return (scale, offset)
