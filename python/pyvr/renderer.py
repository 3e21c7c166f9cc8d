"""VolumeRenderer: pyvr 0.4.1's renderer API on the Rust/wgpu engine.

Differences from pyvr 0.4.1 (each a fix, see the README's migration notes):
``render()`` returns a (H, W, 4) uint8 array of straight RGBA (row 0 at the
bottom, as pyvr's bytes were ordered) instead of bytes with colour
multiplied by alpha twice; early termination and the opacity threshold are
honoured; rays stop at the box exit with the last partial step weighted by
its length; volumes without normals are shaded with gradients; point lights
light from their position; any volume shape renders.
"""

import functools
import glob
import os
import tempfile
import threading
import warnings
import weakref
from typing import Iterator, Optional, Tuple

import numpy as np

from . import _core
from ._numbers import check_count
from .camera import Camera, CameraPath
from .config import RenderConfig
from .lighting import Light
from .transferfunctions import ColorTransferFunction, OpacityTransferFunction
from .transferfunctions.base import BaseTransferFunction
from .transferfunctions.value_range import check_value_range, sample_map
from .volume import Volume


def _serialised(method):
    """One thread at a time in the engine: it renders with the GIL released,
    and a second call meanwhile would find it busy ("Already borrowed").
    Other threads wait their turn instead."""
    @functools.wraps(method)
    def call(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return call


def _vec(v):
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    return (float(a[0]), float(a[1]), float(a[2]))


def _colour(c):
    if isinstance(c, str):
        try:
            from matplotlib.colors import to_rgb
        except ImportError as e:
            raise ImportError("colour names need matplotlib: pip install 'pyvr[plot]', or give (r, g, b)") from e
        try:
            return to_rgb(c)
        except ValueError:
            raise ValueError(f"background {c!r} is not a colour name matplotlib knows") from None
    try:
        a = np.asarray(c, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"background must be an (r, g, b) colour, got {c!r}") from None
    if a.shape != (3,) or not np.all((a >= 0) & (a <= 1)):
        raise ValueError(f"background must be three numbers in [0, 1], got {c!r}")
    return tuple(a)


def _finite_vec(name, v):
    try:
        a = np.asarray(v, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be three numbers, got {v!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be three finite numbers, got {v!r}")
    return (float(a[0]), float(a[1]), float(a[2]))


def _runtime_dir() -> None:
    """Mesa's Vulkan loader probes for a display and prints "error:
    XDG_RUNTIME_DIR is invalid or not set" on the first device when that
    variable names no usable folder (scripts, notebooks, services). Give
    this process a private one before the device opens; a usable one the
    user set is left alone."""
    path = os.environ.get("XDG_RUNTIME_DIR")
    if path and os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK):
        return
    os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="pyvr-runtime-")


def _camera_tuple(camera: Camera):
    position, up = camera.get_camera_vectors()
    return (_vec(position), _vec(camera.target), _vec(up), float(camera.fov))


def _light_tuple(light: Light):
    return (_vec(light.position), _vec(light.target), float(light.ambient_intensity),
            float(light.diffuse_intensity), light.kind)


def _path_cameras(path, n_frames, endpoint):
    """(number of frames, the cameras): a CameraPath's are made as the frames
    are rendered, so a long path never holds all its cameras at once."""
    if isinstance(path, CameraPath):
        if n_frames is None:
            raise TypeError("render_path needs n_frames with a CameraPath: render_path(path, n_frames)")
        return int(n_frames), path.iter_cameras(n_frames, endpoint=endpoint)
    if isinstance(path, Camera) or not hasattr(path, "__iter__"):
        raise TypeError(f"path must be a CameraPath or a sequence of Camera, got {type(path).__name__}")
    cameras = list(path)
    if n_frames is not None:
        raise TypeError("n_frames is for a CameraPath; a sequence of cameras is rendered as given")
    for i, c in enumerate(cameras):
        if not isinstance(c, Camera):
            raise TypeError(f"path item {i} must be a Camera, got {type(c).__name__}")
    if not cameras:
        raise ValueError("path holds no cameras")
    return len(cameras), cameras


def output_format(dt: np.dtype, premultiplied: bool, bg, origin: str) -> tuple:
    """``render``'s output options as the engine's (codes, straight,
    background, top_down)."""
    return (dt == np.uint8, not premultiplied, bg, origin == "upper")


def output_image(img: np.ndarray, dt: np.dtype, premultiplied: bool, bg, origin: str) -> np.ndarray:
    """A frame's premultiplied float RGBA (row 0 at the bottom) as ``render``
    returns it: over ``bg`` if given, uint8 or float32, straight unless
    ``premultiplied``, rows from the bottom unless ``origin`` is "upper"
    (the rules by which the engine makes each pixel of a frame it returns)."""
    if dt == np.float32 and premultiplied and bg is None and origin == "lower":
        return img
    return _core.convert(img, output_format(dt, premultiplied, bg, origin))


def mean_image(total: np.ndarray, n: int) -> np.ndarray:
    """float32 ``total / n`` of float64 sums of frames, in one pass."""
    return np.divide(total, n, out=np.empty(total.shape, np.float32))


def check_frame_options(origin, background, dtype) -> None:
    """The output options of a path's frames, checked before any frame."""
    if origin not in ("lower", "upper"):
        raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
    if np.dtype(dtype) not in (np.dtype(np.uint8), np.dtype(np.float32)):
        raise ValueError(f"dtype must be uint8 or float32, got {np.dtype(dtype)}")
    if background is not None:
        _colour(background)


def _progress(progress, unit="frame", desc="render_path"):
    """A function making a progress bar of n units, or None for no bar."""
    if progress is False:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if progress:
            raise ImportError("progress bars need tqdm: pip install 'pyvr[progress]'") from None
        return None
    return lambda total: tqdm(total=total, unit=unit, desc=desc)


def _table_of(tf, n, shape, what):
    """``tf.to_lut(n)`` checked: real numbers of ``shape`` ((n, 1) is taken
    for (n,)), so a custom function's mistake is an error, not a picture."""
    table = np.asarray(tf.to_lut(n))
    if not (np.issubdtype(table.dtype, np.integer) or np.issubdtype(table.dtype, np.floating)):
        raise TypeError(f"{type(tf).__name__}.to_lut({n}) must return real {what}, got dtype {table.dtype}")
    if table.shape != shape and not (len(shape) == 1 and table.shape == shape + (1,)):
        raise ValueError(f"{type(tf).__name__}.to_lut({n}) must return {what} of shape {shape}, got {table.shape}")
    return table.reshape(shape)


def _check_size(size):
    if size is None:
        return None
    try:
        w, h = size
    except (TypeError, ValueError):
        raise TypeError(f"size must be (width, height), got {size!r}") from None
    for name, v in (("width", w), ("height", h)):
        check_count(f"size {name}", v, high=2**32 - 1)
    return (int(w), int(h))


def _straight(img: np.ndarray) -> np.ndarray:
    """Colour divided by alpha, clipped to [0, 1]; where alpha is 0 (nothing,
    or the emission model's additive glow) the colour is kept as it is."""
    a = img[..., 3:4]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.clip(np.where(a > 0, img[..., :3] / np.where(a > 0, a, 1), img[..., :3]), 0.0, 1.0)


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

# The last-level cache assumed where the system does not say (the 2-core
# machine the storages were measured on has 32 MiB).
DEFAULT_CPU_CACHE = 32 * 2**20

# At equal samples, fixed point's 8-byte texels were 3-8% slower than
# float32's 16 while the latter took up to 108 MiB (192^3), 5% faster at
# 256 MiB (256^3), on lavapipe with 32 MiB of L3 (benches/volume_size.py):
# decoding costs more than the misses it saves until the texels are several
# times the cache.
CACHE_FACTOR = 4

# The most cache the rule above counts on. A VM reports its host's last
# level cache, shared with every other guest: an Intel Xeon VM of 2 cores
# reported 480 MiB, and there fixed point still reached float32's speed per
# sample at 256^3 (0.99x, 5-10% slower up to 192^3), as on the AMD VM with
# 32 MiB, where the rule was measured.
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


#: Samples a frame may take before a warning says it will be slow: about a
#: minute on a software renderer, seconds on a GPU.
LONG_FRAME_SAMPLES = 5e9
#: The same for the float64 integrator (one CPU core does about 1e7 per second).
LONG_FLOAT64_SAMPLES = 5e8
#: Each optical model's abilities, as the core declares them.
MODEL_ABILITIES = _core.model_abilities()
#: Models with unbiased frames (RenderConfig.unbiased), which accumulate uses.
UNBIASED_MODELS = tuple(m for m, a in MODEL_ABILITIES.items() if a["unbiased"])
# Models whose samples are lit from the data's gradient when no normals are given.
GRADIENT_SHADED_MODELS = tuple(m for m, a in MODEL_ABILITIES.items() if a["lit_by_normals"])


def _value_map_for(value_range, dtype) -> tuple:
    """The (scale, offset) taking ``dtype``'s device samples to the transfer
    functions' [0, 1] over ``value_range``, or a ValueError when it is not
    finite (a range so wide that high - low overflows, or so narrow that
    its inverse does)."""
    scale, offset = sample_map(value_range, dtype)
    if not (np.isfinite(scale) and scale > 0 and np.isfinite(offset)):
        raise ValueError(f"value_range {value_range} cannot map {np.dtype(dtype).name} values onto the transfer "
                         "functions: its width must be a finite positive number whose inverse is finite too")
    return (scale, offset)


def _frame_samples(bounds, cfg: RenderConfig, width: int, height: int) -> float:
    """An upper bound on a frame's samples: every ray across the box's diagonal."""
    diag = float(np.linalg.norm(np.subtract(bounds[1], bounds[0])))
    per_ray = min(float(cfg.max_steps), diag / cfg.step_size + 2.0)
    if cfg.model == "single_scattering":
        shadow = cfg.shadow_step_size or cfg.step_size
        per_ray *= diag / shadow + 1.0
    return float(width) * float(height) * per_ray


def _warn_if_long(what: str, samples: float, limit: float, stacklevel: int) -> None:
    """``stacklevel`` counts from the caller of _warn_if_long (1: that caller)."""
    if samples > limit:
        warnings.warn(
            f"{what} may take up to {samples:.3g} samples (step_size, max_steps and image size decide this), "
            "which can take minutes; press Ctrl-C to stop it",
            UserWarning,
            stacklevel=stacklevel + 1,
        )


_RENDERERS: "weakref.WeakSet" = weakref.WeakSet()


def _after_fork_in_child() -> None:
    # A lock held by a parent thread at the fork would stay held for ever.
    for r in list(_RENDERERS):
        r._lock = threading.RLock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


class VolumeRenderer:
    """Renders a Volume with transfer functions, a camera and a light.

    >>> renderer = VolumeRenderer(512, 512, config=RenderConfig.balanced())
    >>> renderer.load_volume(volume); renderer.set_camera(camera)
    >>> renderer.set_transfer_functions(ctf, otf)
    >>> image = renderer.render()          # (512, 512, 4) uint8, row 0 = bottom

    The GPU device, shader variants and uploaded data stay alive between
    renders; changing the camera, light or config uploads no volume data.
    """

    def __init__(self, width: int = 512, height: int = 512, config: Optional[RenderConfig] = None, light: Optional[Light] = None,
                 *, brick_shape: Optional[tuple] = None, memory_budget: Optional[int] = None):
        """``brick_shape`` and ``memory_budget`` (bytes) decide how volumes
        that need bricks are cut and kept (pyvr.bricks): a volume is bricked
        when its data is not in memory (memmap, zarr, dask, xarray), when it
        exceeds the device's 3-D texture or buffer limit or the budget, or
        whenever ``brick_shape`` is given (cores of that many voxels).
        Bricks stay on the device while they fit in ``memory_budget``
        (default 4 GiB); beyond it each frame streams them from the source."""
        if memory_budget is not None:
            check_count("memory_budget", memory_budget)
        if brick_shape is not None:
            from .bricks import check_brick_shape

            brick_shape = check_brick_shape(brick_shape)
        for name, v in (("width", width), ("height", height)):
            check_count(name, v, high=2**32 - 1)
        if config is None:
            config = RenderConfig.balanced()
        elif not isinstance(config, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(config)}")
        if light is None:
            light = Light.default()
        elif not isinstance(light, Light):
            raise TypeError(f"Expected Light instance, got {type(light)}")
        self.width = int(width)
        self.height = int(height)
        self.volume: Optional[Volume] = None
        self.camera: Optional[Camera] = None
        _runtime_dir()
        self._lock = threading.RLock()
        self._engine_obj = _core.Renderer(self.width, self.height)
        self._engine_pid = os.getpid()
        self._precision = "float32"
        self._precision_request = "auto"
        self._fixed16_range = None
        self._lut = None
        _RENDERERS.add(self)
        self._camera_args = None
        self._warned = set()
        self.last_frame_stats: dict = {}
        self.last_float64_depth: Optional[np.ndarray] = None
        self._tf_value_range = None
        self._value_map = (1.0, 0.0)
        self._crop = None
        self._brick_shape = brick_shape
        self._memory_budget = memory_budget
        self._bricked = None
        self._gradients_tried = False
        self.set_config(config)
        self.set_light(light)
        self._has_tf = False

    @property
    def _engine(self):
        """The core renderer; in a child made by fork() a new one, made on
        first use and given this renderer's volume and tables, since the
        parent's GPU device does not work in the child."""
        if self._engine_pid != os.getpid():
            self._engine_for_this_process()
        return self._engine_obj

    def _engine_for_this_process(self) -> None:
        old = self._engine_obj
        engine = _core.Renderer(old.width, old.height)
        engine.skip_empty, engine.uniform_runs, engine.native_march = old.skip_empty, old.uniform_runs, old.native_march
        if self._bricked is not None:
            self._bricked.layout(engine)
        elif self.volume is not None:
            engine.set_volume(prepare_voxels(self.volume.data), prepare_normals(self.volume.normals),
                              *self._bounds, self._precision)
        if self._lut is not None:
            engine.set_lut(self._lut)
        engine.set_value_map(*self._value_map)
        engine.set_clip(self._crop)
        # The parent's engine is leaked by the core, never freed here.
        self._engine_obj, self._engine_pid = engine, os.getpid()
        self._gradients_tried = False

    # -- scene -----------------------------------------------------------
    @_serialised
    def load_volume(self, volume: Volume, *, precision: str = "auto") -> None:
        """Upload ``volume`` (data and normals are copied; later changes to
        the arrays need another load_volume).

        ``precision`` says how the data is stored on the device:

        - ``"auto"`` (default): ``"fixed16"`` for a volume with normals
          where it is faster and 16 bits resolve what the transfer
          functions see: integer data; on a CPU device (lavapipe), finite
          float data whose float32 texels take over four times the CPU's
          largest cache (counted as at most 32 MiB: a VM reports its
          host's) and whose range spans at most twice the transfer
          functions' value range (values then move by at most 1.5e-5 of
          that range). Else ``"float32"``. Decided again when the value
          range changes.
        - ``"fixed16"``: values as 16-bit fixed point over the data's own
          range: integer data exactly, float data rounded to a 131068th of
          its range (finite values only). 2 bytes per voxel, or 8 with
          normals, which then share the value's texel at 16 bits per
          component: the lit 256^3 benchmark scene renders 1.16-1.39x
          faster than at float32 on lavapipe (benches/precision_ab.py),
          mostly because its values within half a code of 0 read as 0 and
          their cells become empty; at equal samples 5% faster at 256^3 and
          3-8% slower at 192^3 and below (benches/volume_size.py). Needs a
          device with 16-bit normalized textures
          (``device_limits()["norm16_textures"]``); not for bricked volumes.
        - ``"float32"``: exact values, 4 bytes per voxel (integer data is
          stored exactly, in 1 or 2 bytes per voxel). With
          normals, 16: value and normal share one float texel, so that a lit
          sample fetches once (the lit benchmark scene renders 1.3x faster
          than with the normals in a texture of their own); where the device
          cannot filter float32 textures or the data holds NaN or infinities,
          4 plus 4 for the normals (directions to 1/127 per component).
          Models that read values only (MIP, MinIP, average, absorption,
          the isosurface's march, shadow rays) then fetch 16 bytes per
          sample instead of 4 and run 1.3-1.6x slower: load the volume
          without normals for them. Without normals, the first frame lit
          from the data's gradient stores each value with its gradient
          (16 bytes a voxel, where that fits a quarter of the memory
          budget), so that a lit sample fetches once instead of seven
          times; the images are the same within 0.003 level.
        - ``"float16"``: values rounded to float16 (relative error at most
          2**-11; values in [0, 1] move by at most 2**-12, a sixteenth of a
          256-entry table's spacing). 2 bytes per voxel, or 8 with normals
          in the value's texel: the lit benchmark scene renders 1.2x faster
          than at float32. Values must be finite and within +-65504. The
          rounding is the same in every voxel of a smooth region, so along
          long dense rays it can add up: measured up to 2.1 levels against
          the exact data's image (docs/numerics.md).

        ``counters()["volume_storage"]`` names the stored format, and
        ``precision`` the one chosen.
        """
        from . import bricks

        if not isinstance(volume, Volume) and bricks.is_lazy(volume):
            # An array not in memory (memmap, zarr, dask, xarray) is taken as
            # is; a plain ndarray still needs its Volume, as in pyvr.
            volume = bricks.as_volume(volume)
        if not isinstance(volume, Volume):
            raise TypeError(
                f"Expected Volume instance, got {type(volume)}. Create a Volume instance: "
                "from pyvr.volume import Volume; volume = Volume(data=your_array)"
            )
        volume.validate()
        # Checked before anything changes: a load that raises leaves the renderer as it was.
        _value_map_for(self._tf_value_range or volume.value_range, volume.data.dtype)
        if precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(map(repr, PRECISIONS))}, got {precision!r}")
        bounds = (_vec(volume.min_bounds), _vec(volume.max_bounds))
        request, fixed_range = precision, None
        # Arrays not in memory are bricked, never read whole here.
        lazy = bricks.is_lazy(volume.data) or bricks.is_lazy(volume.normals)
        if precision == "fixed16" and not lazy:
            fixed_range = _fixed16_range(volume.data)
            _check_fixed16(volume, fixed_range)
        elif precision == "auto" and volume.normals is not None and not lazy:
            fixed_range = _fixed16_range(volume.data)
        if precision == "auto":
            value_map = sample_map(self._tf_value_range or volume.value_range, volume.data.dtype)
            precision = _auto_precision(volume, fixed_range, value_map[0])
        bricked = self._needs_bricks(volume, precision)
        if bricked and precision == "fixed16":
            if request == "fixed16":
                raise ValueError("precision='fixed16' is for volumes in one texture, and this one is bricked: "
                                 "use 'auto', 'float32' or 'float16'")
            precision = "float32"
        if bricked:
            ghost = bricks.ghost_for(self._config_snapshot.step_size, bounds, volume.data.shape)
            brick = bricks.BrickedVolume(
                volume.data, volume.normals, volume.data.shape, bounds, precision, None, ghost,
                bricks.DEFAULT_MEMORY_BUDGET if self._memory_budget is None else self._memory_budget,
            )
            self._layout_bricks(brick)
        else:
            _check_volume_fits(volume, precision)
            data = prepare_voxels(volume.data)
            normals = prepare_normals(volume.normals)
            self._engine.set_volume(data, normals, *bounds, precision)
            self._bricked = None
        self._precision = precision
        self._precision_request = request
        self._fixed16_range = fixed_range
        self._gradients_tried = False
        self.volume = volume
        self._bounds = (_vec(volume.min_bounds), _vec(volume.max_bounds))
        # What pyvr.accuracy measures of the data (its gradient), once per load.
        self._data_features = None
        self._update_value_map()

    def _needs_bricks(self, volume: Volume, precision: str) -> bool:
        from . import bricks

        if self._brick_shape is not None or bricks.is_lazy(volume.data) or bricks.is_lazy(volume.normals):
            return True
        limits = device_limits()
        largest, total = device_texel_bytes(volume.data, volume.normals is not None, precision)
        voxels = int(np.prod(volume.data.shape, dtype=np.int64))
        budget = bricks.DEFAULT_MEMORY_BUDGET if self._memory_budget is None else self._memory_budget
        return (max(volume.data.shape) > limits["max_texture_dimension_3d"]
                or voxels * largest > limits["max_buffer_size"] or voxels * total > budget)

    def _layout_bricks(self, brick) -> None:
        """Cuts ``brick``'s volume for this device (nothing is read until a
        frame needs it)."""
        from .bricks import brick_shape_for

        limits = device_limits()
        brick.core = brick_shape_for(brick.shape, brick.ghost, limits["max_texture_dimension_3d"], self._brick_shape)
        self._bricked = None
        brick.layout(self._engine)
        self._bricked = brick

    @property
    def bricks(self) -> Optional[dict]:
        """How the loaded volume is bricked (None: one texture): core shape,
        ghost voxels, brick count, whether the bricks stay on the device, and
        the device bytes they take."""
        b = self._bricked
        if b is None:
            return None
        return {"brick_shape": b.core, "ghost": b.ghost, "count": len(b.ranges), "resident": b.resident,
                "device_bytes": b.device_bytes()}

    def set_camera(self, camera: Camera) -> None:
        """Use this camera; later changes to the object need another set_camera."""
        if not isinstance(camera, Camera):
            raise TypeError(f"Expected Camera instance, got {type(camera)}")
        self._camera_args = _camera_tuple(camera)
        self.camera = camera
        self._follow(camera)

    def _follow(self, camera: Optional[Camera]) -> None:
        """A camera-linked light moves with the camera the frame uses."""
        if camera is not None and self.light.is_linked:
            self.light.update_from_camera(camera)
            self._light_args = _light_tuple(self.light)

    def set_light(self, light: Light) -> None:
        if not isinstance(light, Light):
            raise TypeError(f"Expected Light instance, got {type(light)}")
        light.validate()
        self.light = light
        self._light_args = _light_tuple(light)
        self._follow(getattr(self, "camera", None))

    @_serialised
    def set_transfer_functions(self, color_transfer_function, opacity_transfer_function, size: Optional[int] = None,
                               *, value_range=None) -> None:
        """Tabulate both functions at ``size`` points (default: the larger
        lut_size) over [0, 1]; the renderer interpolates between entries.

        ``value_range=(low, high)`` says which data values the functions'
        [0, 1] spans (e.g. Hounsfield units, ``window_level(400, 40)``):
        value v is looked up at ``(v - low) / (high - low)``, on the GPU,
        without rescaling the volume. Default: the functions' own
        ``value_range`` (they must agree), else the volume's, else pyvr's
        rule ([0, 1] for float data, the type's range for uint8/uint16).
        """
        # Only pyvr's own functions carry a value range; any other object is
        # taken by pyvr 0.4.1's protocol (lut_size and to_lut) alone.
        ranges = {tf.value_range for tf in (color_transfer_function, opacity_transfer_function)
                  if isinstance(tf, BaseTransferFunction) and tf.value_range is not None}
        if value_range is not None:
            value_range = check_value_range(value_range)
        elif len(ranges) > 1:
            raise ValueError(
                f"the colour and opacity transfer functions have different value ranges {sorted(ranges)}: "
                "give both the same, or pass value_range= to set_transfer_functions"
            )
        elif ranges:
            value_range = ranges.pop()
        if self.volume is not None:  # a range the volume's values cannot be mapped with changes nothing
            _value_map_for(value_range or self.volume.value_range, self.volume.data.dtype)
        limit = device_limits()["max_texture_dimension_2d"]
        if size is None:
            n = max(check_count("color_transfer_function.lut_size", color_transfer_function.lut_size, high=limit),
                    check_count("opacity_transfer_function.lut_size", opacity_transfer_function.lut_size, high=limit))
        else:
            n = check_count("size", size, high=limit)
        lut = np.empty((n, 4), dtype=np.float32)
        lut[:, :3] = _table_of(color_transfer_function, n, (n, 3), "colours")
        lut[:, 3] = _table_of(opacity_transfer_function, n, (n,), "opacities")
        if not np.all(np.isfinite(lut)) or lut.min() < 0 or lut.max() > 1:
            raise ValueError("transfer functions must give colours and opacities in [0, 1]")
        self._engine.set_lut(lut)
        self._lut = lut
        self._has_tf = True
        self._tf_value_range = value_range
        self._update_value_map()

    @property
    def bounds(self) -> Optional[tuple]:
        """The loaded volume's box, ((x, y, z) min, (x, y, z) max), as it was
        uploaded; None before load_volume."""
        return getattr(self, "_bounds", None)

    @property
    def lut(self) -> Optional[np.ndarray]:
        """A copy of the (n, 4) RGBA table the transfer functions were
        tabulated to (entries at m / (n - 1)); None before they are set."""
        return None if getattr(self, "_lut", None) is None else self._lut.copy()

    @property
    def value_range(self) -> Optional[tuple]:
        """The (low, high) data values the transfer functions span now, or
        None for pyvr's rule (see set_transfer_functions)."""
        if self._tf_value_range is not None:
            return self._tf_value_range
        return None if self.volume is None else self.volume.value_range

    @_serialised
    def _update_value_map(self) -> None:
        if self.volume is None:
            return
        self._value_map = _value_map_for(self.value_range, self.volume.data.dtype)
        self._engine.set_value_map(*self._value_map)
        if self._precision_request == "auto" and self._bricked is None:
            self._rechoose_precision()

    def _rechoose_precision(self) -> None:
        """Stores the loaded volume again where the value range now asks for
        more bits than 16-bit fixed point gives (or allows fewer)."""
        chosen = _auto_precision(self.volume, self._fixed16_range, self._value_map[0])
        if chosen == self._precision:
            return
        # The same checks load_volume makes before it uploads: the device's
        # limits and budget (else bricks), and this machine's memory.
        why = "they would need bricks" if self._needs_bricks(self.volume, chosen) else None
        if why is None:
            try:
                _check_volume_fits(self.volume, chosen)
            except ValueError as e:
                why = str(e)
        if why is not None:
            key = ("fixed16 kept", self._value_map)
            if key in self._warned:
                return
            self._warned.add(key)
            warnings.warn("the transfer functions' value range is narrower than half the data's range, so 16-bit "
                          "fixed point moves values by more than 1.5e-5 of it; the volume stays in fixed point "
                          f"because float32 texels would not fit in one texture ({why}): load_volume(..., "
                          "precision='float32') bricks it", UserWarning, stacklevel=4)
            return
        self._engine.set_volume(prepare_voxels(self.volume.data), prepare_normals(self.volume.normals),
                                *self._bounds, chosen)
        self._precision = chosen

    @property
    def precision(self) -> str:
        """How the loaded volume is stored: 'float32', 'float16' or
        'fixed16' (what load_volume's ``precision="auto"`` chose)."""
        return self._precision

    @_serialised
    def set_crop_box(self, min_corner=None, max_corner=None) -> None:
        """Render only the part of the volume inside the box ``[min_corner,
        max_corner]`` (world coordinates; shadow rays stop at it too).
        Nothing is copied or uploaded. No arguments: the whole volume again."""
        if min_corner is None and max_corner is None:
            self._crop = None
        else:
            if min_corner is None or max_corner is None:
                raise ValueError("set_crop_box needs both corners, or neither to remove the crop")
            lo, hi = _finite_vec("min_corner", min_corner), _finite_vec("max_corner", max_corner)
            if not all(h > l for l, h in zip(lo, hi)):
                raise ValueError(f"max_corner must be greater than min_corner on every axis, got {lo} and {hi}")
            self._crop = (lo, hi)
        self._engine.set_clip(self._crop)

    @property
    def crop_box(self) -> Optional[tuple]:
        """((x, y, z), (x, y, z)) set by set_crop_box, or None."""
        return self._crop

    def set_config(self, config: RenderConfig) -> None:
        if not isinstance(config, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(config)}")
        config.validate()
        self._config_snapshot = config.copy()
        self.config = config

    def get_config(self) -> RenderConfig:
        return self.config

    def get_light(self) -> Light:
        return self.light

    def get_volume(self) -> Optional[Volume]:
        return self.volume

    def get_camera(self) -> Optional[Camera]:
        return self.camera

    @property
    def empty_space_skipping(self) -> bool:
        """Leap over 8x8x8-voxel cells the transfer function leaves fully
        transparent (default True). Only samples of opacity exactly 0 are
        skipped, so images do not change; turn off to measure the saving.
        Off, it turns ``uniform_runs`` off too. Maximum (minimum) intensity
        projections leap the cells whose values cannot pass a ray's maximum
        (minimum) so far: the same pixels, to 1e-6 of the value."""
        return self._engine.skip_empty

    @empty_space_skipping.setter
    def empty_space_skipping(self, on: bool) -> None:
        with self._lock:
            self._engine.skip_empty = bool(on)

    @property
    def uniform_runs(self) -> bool:
        """With ``empty_space_skipping``: composite a ray's run through
        uniform cells as one segment (default True; see
        ``uniform_fraction``). Images do not change (to f32 rounding: 0.002
        level measured); turn off to measure the saving."""
        return self._engine.uniform_runs

    @uniform_runs.setter
    def uniform_runs(self, on: bool) -> None:
        with self._lock:
            self._engine.uniform_runs = bool(on)

    @property
    def native_march(self) -> bool:
        """Where the only adapter is a CPU (wgpu on lavapipe) and it has
        AVX2, FMA and F16C, render the frames the native CPU march covers
        with it instead of the shader (default True; the environment
        variable ``PYVR_NATIVE_MARCH=0`` sets it off): emission-absorption
        (plain, pre-integrated, refined or unbiased), single scattering, absorption
        and emission, in either order and with either opacity correction,
        unlit or lit from the normals (or gradients) the volume's texels
        hold or from the values' central differences, from float32,
        float16, fixed16, uint8 or uint16 storage in one texture; the
        projections and the isosurface; and the same frames of bricked volumes,
        brick after brick; 1.25x (float32) and 1.7x (fixed16)
        the shader's speed per sample on the benchmark scene on a 2-core
        AMD EPYC (docs/speed.md).
        Images match the shader's within 0.25 level
        (measured: 0.0004 on most scenes); ``last_frame_stats["engine"]``
        says which ran ("native" or "gpu"). It keeps a volume's texels in
        memory itself (each brick's too), and the shader's texture is made
        from them only when a frame first runs on the shader (docs/speed.md,
        "The native march").

        Where no GPU adapter opens at all (no Vulkan driver, or
        ``PYVR_ENGINE=native``), the native engine is the only one: it
        renders every frame whatever this says
        (``pyvr.renderer.device_limits()["gpu_adapter"]`` is False;
        docs/ARCHITECTURE.md, "Engines at run time")."""
        return self._engine.native_march

    @native_march.setter
    def native_march(self, on: bool) -> None:
        with self._lock:
            self._engine.native_march = bool(on)

    @_serialised
    def empty_fraction(self) -> float:
        """Fraction of the volume's cells the current transfer function leaves empty."""
        return self._engine.empty_fraction()

    @_serialised
    def uniform_fraction(self) -> float:
        """Fraction of the visible cells that are uniform: every sample in
        them takes one colour and opacity (a constant region, or values where
        the transfer function is flat). With ``empty_space_skipping`` on,
        unlit frames of the Beer-Lambert models (emission-absorption,
        absorption, emission, single scattering) composite
        a ray's run through such cells as one segment, with the same image
        (pre-integrated frames too: their cells are then judged over the
        values of whole segments). 0 where the volume holds NaN."""
        return self._engine.uniform_fraction()

    @property
    def device(self) -> str:
        """The GPU adapter in use (e.g. 'llvmpipe (Vulkan, Cpu, ...)')."""
        return self._engine.device

    @_serialised
    def counters(self) -> dict:
        """Frames rendered, uploads made and bytes resident, for profiling.

        ``volume_texture`` is False while the native march's copy of the
        texels stands in for the GPU texture: where the adapter is a CPU,
        the texture is made at the first frame on the shader, not at load,
        and ``uploaded_bytes`` (like that frame's
        ``last_frame_stats["uploaded_bytes"]``) counts it then.
        """
        return self._engine.counters()

    # -- frames ----------------------------------------------------------
    def _pack_gradients_for(self, cfg: RenderConfig) -> None:
        """Gradient shading (a diffuse light, no normals) reads the data's
        gradient at every lit sample: seven fetches. At the first such frame
        after a load, the engine stores the float32 values with their
        gradients (16 bytes a voxel instead of 4, within a quarter of the
        memory budget) so that a lit sample fetches once, with the same
        result (the interpolated differences are the differences of the
        interpolated values; src/gradients.rs). Models that read values
        alone then fetch 16 bytes a sample too, as with supplied normals.
        Integer volumes (1 or 2 bytes a voxel) are packed so only where the
        native CPU march renders them, which reads no gradient otherwise
        (fuel.vti as uint8, lit: 617 -> 73 ms at 512x512, docs/speed.md).
        Elsewhere they keep their 1 or 2 bytes a voxel: 16 bytes a voxel
        was not measured against the neighbours' fetches on a GPU."""
        if (self._gradients_tried or self.volume is None or self.volume.normals is not None
                or self._light_args[3] <= 0 or cfg.model not in GRADIENT_SHADED_MODELS):
            return
        from . import bricks

        self._gradients_tried = True
        texels = int(np.prod([s + 2 for s in self.volume.data.shape], dtype=np.int64))
        budget = bricks.DEFAULT_MEMORY_BUDGET if self._memory_budget is None else self._memory_budget
        if self._precision != "float32" or 16 * texels > budget // 4:
            return
        data = prepare_voxels(self.volume.data)
        native = self.native_march and device_limits()["native_march"]
        if data.dtype == np.float32 or (native and data.dtype in (np.uint8, np.uint16)):
            self._engine.pack_gradients(data, *self._bounds)

    @_serialised
    def _render_frame(self, size=None, config: Optional[RenderConfig] = None, output=None,
                      sums: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
        """One frame. ``output``: (dtype, premultiplied, background, origin)
        as ``render`` takes them, for the frame as ``render`` returns it,
        each pixel made so as it is rendered (no pass over the image
        after); None: float32 premultiplied, row 0 at the bottom. With
        ``sums`` (float64, (H, W, 4), C-contiguous) the frame's
        premultiplied pixels are added to it instead, and None returned."""
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render()")
        self._ensure_tf()
        cfg = self._config_snapshot if config is None else config
        size = (self.width, self.height) if size is None else size
        # Caller chain: user -> render (or _accumulated -> render) -> _serialised -> here.
        _warn_if_long("this frame", _frame_samples(self._bounds, cfg, *size), LONG_FRAME_SAMPLES, stacklevel=4)
        if (self._engine.width, self._engine.height) != size:
            # Output buffers only; the volume, table and pipelines stay.
            self._engine.resize(*size)
        camera_args = self._frame_camera()
        if self._bricked is not None:
            from .bricks import ghost_for

            b = self._bricked
            need = ghost_for(cfg.step_size, b.bounds, b.shape)
            if need > b.ghost:
                # Longer steps reach further into the neighbours: re-cut.
                b.ghost = need
                self._layout_bricks(b)
            img, stats = b.render(self._engine, camera_args, self._light_args, cfg)
            if sums is not None:
                np.add(sums, img, out=sums)
                img = None
            elif output is not None:
                img = output_image(img, *output)
        elif sums is not None:
            self._pack_gradients_for(cfg)
            img, stats = None, self._engine.accumulate(camera_args, self._light_args, cfg, sums)
        else:
            self._pack_gradients_for(cfg)
            spec = None if output is None else output_format(*output)
            img, stats = self._engine.render(camera_args, self._light_args, cfg, spec)
        self.last_frame_stats = stats
        needed = stats["truncated_needed"]
        if needed:
            key = (cfg.step_size, cfg.max_steps, self._bounds)
            if key not in self._warned:
                self._warned.add(key)
                diag = float(np.linalg.norm(np.subtract(self._bounds[1], self._bounds[0])))
                hint = ""
                if diag > 10.0:
                    # pyvr's presets are sized for boxes about 2-3.5 units across.
                    hint = (
                        f" This volume's box is {diag:.4g} world units across (physical units?) while pyvr's presets "
                        "are made for boxes about 2 units wide: load files with pyvr.load(path), which maps the box "
                        "into [-1, 1] keeping its proportions, or scale step_size with the box "
                        f"(step_size={cfg.step_size * diag / 2 / np.sqrt(3):.3g} keeps this preset's samples per ray)."
                    )
                warnings.warn(
                    f"max_steps={cfg.max_steps} cannot cross the volume at step_size={cfg.step_size}: "
                    f"some rays were cut short; max_steps={needed} would cross it "
                    f"(config.with_max_steps({needed})).{hint}",
                    UserWarning,
                    stacklevel=3,
                )
        return img

    def _ensure_tf(self) -> None:
        if not self._has_tf:
            self.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction())

    def _frame_camera(self) -> tuple:
        """The camera a frame uses: the one set, or a default view of the box."""
        if self._camera_args is None:
            camera = self._default_camera()  # pyvr had no default camera
            self._follow(camera)
            return _camera_tuple(camera)
        return self._camera_args

    def render(self, *, dtype=np.uint8, premultiplied: bool = False, origin: str = "lower",
               background=None, size: Optional[tuple] = None, config: Optional[RenderConfig] = None,
               accumulate: int = 1) -> np.ndarray:
        """Render a frame as a C-contiguous (H, W, 4) array.

        dtype: np.uint8 (default) or np.float32. premultiplied: return colour
        multiplied by alpha (default: straight colour). origin: "lower"
        (default, row 0 = bottom, pyvr's order) or "upper" (row 0 = top).
        background: an RGB colour (three numbers in [0, 1], or a name such as
        "white" when matplotlib is installed) to composite the frame over;
        the result is opaque. Default None: transparent, straight RGBA.
        size: (width, height) to render this frame at instead of the
        renderer's own (the same view, e.g. a cheap preview while a user
        drags); config: a RenderConfig for this frame only. Neither changes
        the renderer's settings.
        accumulate: average this many frames (seeds jitter_seed,
        jitter_seed + 1, ...; premultiplied colour, before any background)
        for progressive refinement. For emission_absorption, absorption and
        emission they are unbiased frames (``config.replace(unbiased=True)``):
        their error falls as 1/sqrt(n) towards the exact integral, whatever
        the step. Pre-integrated configs and the other models average
        jittered frames, whose mean converges to the mean over sample
        offsets instead (docs/rendering.md). It costs n frames; Ctrl-C
        stops it.
        """
        bg = None if background is None else _colour(background)
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        dt = np.dtype(dtype)
        if dt not in (np.dtype(np.uint8), np.dtype(np.float32)):
            raise ValueError(f"dtype must be uint8 or float32, got {dt}")
        size = _check_size(size)
        if config is not None:
            if not isinstance(config, RenderConfig):
                raise TypeError(f"Expected RenderConfig instance, got {type(config)}")
            config.validate()
        n = check_count("accumulate", accumulate, high=1 << 16)
        if n == 1:
            return self._render_frame(size, config, (dt, premultiplied, bg, origin))
        return output_image(self._accumulated(size, config, n), dt, premultiplied, bg, origin)

    def _accumulated(self, size, config: Optional[RenderConfig], n: int) -> np.ndarray:
        """The mean of n premultiplied frames (float64 sums): unbiased ones
        where the model and config allow them, else jittered ones."""
        base = self._config_snapshot if config is None else config
        if base.model in UNBIASED_MODELS and not base.pre_integrated:
            base = base.replace(unbiased=True)
        else:
            base = base.replace(jitter=True)
        w, h = (self.width, self.height) if size is None else size
        # Each frame adds its pixels to the sums as it is made (no image of
        # its own: at 1024x1024 numpy's sums took longer than the frames).
        total = np.zeros((h, w, 4), np.float64)
        for k in range(n):
            self._render_frame(size, base.replace(jitter_seed=(base.jitter_seed + k) % 2**32), sums=total)
        return mean_image(total, n)

    def render_float64(self, *, config: Optional[RenderConfig] = None, premultiplied: bool = False,
                       origin: str = "lower", order: Optional[str] = None,
                       size: Optional[tuple] = None, adaptive_tolerance: float = 0.0, progress=None) -> np.ndarray:
        """The same frame from the float64 CPU integrator (the engine's oracle).

        Slow (CPU, one thread per core); meant for checking accuracy, e.g.
        against a converged image: ``render_float64(config=RenderConfig(
        step_size=1e-4, max_steps=100000, early_ray_termination=False))``.
        ``config`` defaults to the renderer's; ``order`` ("front_to_back" or
        "back_to_front", equal without early termination) overrides its order.
        Isosurface hit distances are left in ``last_float64_depth`` (row 0 at
        the bottom, inf where none).
        ``size=(width, height)`` renders the same view at another resolution
        (e.g. a coarse pilot of the rays). ``adaptive_tolerance`` > 0 splits
        segments in halves (down to 2^-24 of a step) while the transfer
        function varies across their values by more than it (optical depth
        or emitted colour per piece, at most 4096 pieces a step): steps and
        narrow peaks of the TF are located rather than sampled, for
        converged references.
        ``progress``: a tqdm bar of rows (True), none (False), or by default
        one for frames estimated at more than 2e8 samples when tqdm is
        installed. Ctrl-C stops the work (KeyboardInterrupt).
        """
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render_float64()")
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        cfg = self._config_snapshot if config is None else config
        if not isinstance(cfg, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(cfg)}")
        if cfg.unbiased:
            raise ValueError("render_float64 integrates on the step grid; unbiased frames have no float64 "
                             "counterpart: compare their mean with a converged frame of config.replace(unbiased=False)")
        if not self._has_tf:
            self.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction())
        if self._camera_args is None:
            cam = self._default_camera()
            self._follow(cam)
            camera = _camera_tuple(cam)
        else:
            camera = self._camera_args
        if not (isinstance(adaptive_tolerance, (int, float, np.floating, np.integer))
                and not isinstance(adaptive_tolerance, (bool, np.bool_))):
            raise TypeError(f"adaptive_tolerance must be a number, got {type(adaptive_tolerance).__name__}")
        width, height = (self.width, self.height) if size is None else _check_size(size)
        from ._memory import check_fits

        # The float64 image, depth and per-ray results (about 160 bytes a pixel), and the volume copy.
        check_fits(f"render_float64 at {width}x{height}", 160.0 * width * height + self.volume.data.size * 4.0,
                   "render a smaller size=(width, height)")
        samples = _frame_samples(self._bounds, cfg, width, height) * (8 if adaptive_tolerance > 0 else 1)
        _warn_if_long("render_float64", samples, LONG_FLOAT64_SAMPLES, stacklevel=2)
        make_bar = _progress(progress if progress is not None or samples > 2e8 else False, "row", "render_float64")
        bar = None if make_bar is None else make_bar(height)
        try:
            img, _, depth = _core.integrate_reference(
                prepare_voxels(self.volume.data), prepare_normals(self.volume.normals), *self._bounds, self._lut,
                camera, self._light_args, cfg, width, height, order, float(adaptive_tolerance),
                self._value_map, self._crop, None if bar is None else (lambda rows: bar.update(rows - bar.n)),
            )
            if bar is not None:
                bar.update(height - bar.n)
        finally:
            if bar is not None:
                bar.close()
        self.last_float64_depth = depth
        if not premultiplied:
            img[..., :3] = _straight(img)
        return np.ascontiguousarray(img[::-1]) if origin == "upper" else img

    def config_for_error(self, max_error_levels: float = 1.0, **options) -> RenderConfig:
        """The cheapest config predicted to keep this scene's frame within
        ``max_error_levels`` 8-bit levels of the exact image (see
        :func:`pyvr.accuracy.config_for_error`, which also returns what it
        predicted). Needs the volume, transfer functions and camera set."""
        from .accuracy import config_for_error

        if self.volume is None or not self._has_tf:
            raise RuntimeError("config_for_error needs load_volume() and set_transfer_functions() first")
        return config_for_error(self, max_error_levels, **options)[0]

    @_serialised
    def depth(self, *, origin: str = "lower") -> Optional[np.ndarray]:
        """Distance from the camera to the isosurface along each pixel's ray
        in the last frame (float32 (H, W), inf where the ray hit no surface),
        or None unless that frame used ``model="isosurface"``."""
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        d = self._engine.depth()
        if d is None:
            return None
        return np.ascontiguousarray(d[::-1]) if origin == "upper" else d

    def _default_camera(self) -> Camera:
        """With no camera set, a front view that frames the whole volume."""
        return Camera.fit(self.volume, aspect=self.width / self.height)

    def render_path(self, path, n_frames: Optional[int] = None, *, endpoint: bool = True, progress=None,
                    origin: str = "upper", background=None, dtype=np.uint8) -> Iterator[np.ndarray]:
        """Render a camera path frame by frame: a generator of (H, W, 4)
        arrays, so long animations stream (``pyvr.save_animation`` writes
        them to GIF or MP4 as they come).

        path: a ``CameraPath`` (``n_frames`` cameras evenly spaced along it;
        ``endpoint=False`` leaves out the last, for loops) or a sequence of
        ``Camera`` (rendered as given; ``n_frames`` must then be None).
        progress: show a tqdm progress bar; None (default) shows one when
        tqdm is installed. origin defaults to "upper" (row 0 at the top, as
        image and video files store frames); background and dtype are as in
        ``render``. A camera-linked light follows each frame's camera. The
        renderer's own camera (and linked light) is restored when the
        generator finishes, fails, is closed or is interrupted with Ctrl-C.
        """
        count, cameras = _path_cameras(path, n_frames, endpoint)
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render_path()")
        check_frame_options(origin, background, dtype)
        make_bar = _progress(progress)
        # The checks above run now; the frames when iterated.
        return self._frames(count, cameras, make_bar, dict(origin=origin, background=background, dtype=dtype))

    def _frames(self, count, cameras, make_bar, options):
        saved = (self.camera, self._camera_args, self.light.position, self.light.target, self._light_args)
        bar = None if make_bar is None else make_bar(count)
        try:
            for cam in cameras:
                self.set_camera(cam)
                yield self.render(**options)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
            self.camera, self._camera_args = saved[0], saved[1]
            self.light.position, self.light.target, self._light_args = saved[2], saved[3], saved[4]

    def _repr_png_(self) -> Optional[bytes]:
        """Jupyter shows a renderer as its current frame (PNG, top row first);
        None (text repr) until a volume is loaded."""
        if self.volume is None:
            return None
        try:
            from PIL import Image
        except ImportError:
            return None
        import io

        buf = io.BytesIO()
        Image.fromarray(self.render(origin="upper"), "RGBA").save(buf, format="PNG")
        return buf.getvalue()

    def __repr__(self) -> str:
        vol = "no volume" if self.volume is None else f"volume {self.volume.shape}"
        return f"VolumeRenderer({self.width}x{self.height}, {vol}, device={self.device!r})"

    @property
    def gl_manager(self):
        """pyvr 0.4.1's OpenGL manager; kept for compatibility only: a
        stand-in whose ``cleanup()`` is accepted (see
        ``pyvr.moderngl_renderer.gl_manager``)."""
        if self.__dict__.get("_gl_manager") is None:
            from .moderngl_renderer.gl_manager import GLManagerStandIn

            self._gl_manager = GLManagerStandIn(self.width, self.height)
        return self._gl_manager

    def render_to_pil(self, data=None):
        """The frame as a PIL RGBA image, top row at the top."""
        from PIL import Image

        if data is None:
            data = self.render()
        if isinstance(data, np.ndarray):
            data = data.tobytes()
        image = Image.frombytes("RGBA", (self.width, self.height), data)
        return image.transpose(Image.FLIP_TOP_BOTTOM)


ModernGLVolumeRenderer = VolumeRenderer

__all__ = ["VolumeRenderer", "prepare_voxels"]
