"""VolumeRenderer: pyvr 0.4.1's renderer API on the Rust/wgpu engine.

Differences from pyvr 0.4.1 (each a fix, see the README's migration notes):
``render()`` returns a (H, W, 4) uint8 array of straight RGBA (row 0 at the
bottom, as pyvr's bytes were ordered) instead of bytes with colour
multiplied by alpha twice; early termination and the opacity threshold are
honoured; rays stop at the box exit with the last partial step weighted by
its length; volumes without normals are shaded with gradients; point lights
light from their position; any volume shape renders.
"""

import os
import threading
from typing import Optional

import numpy as np

from . import _core
from ._loading import VolumeLoading
from ._picking import Picking, Picks  # noqa: F401
from ._slices import Slicing
from ._numbers import check_count
from ._rendering import FrameRendering
from ._scene import _camera_tuple, _clip_planes, _finite_vec, _light_tuple, _runtime_dir, _table_of
from ._storage import _value_map_for, device_limits, prepare_normals, prepare_voxels
from ._threads import _RENDERERS, _serialised
from .camera import Camera
from .config import RenderConfig
from .lighting import Light
from .transferfunctions.base import BaseTransferFunction
from .transferfunctions.value_range import check_value_range
from .volume import Volume

# The renderer's helpers live in modules named for their concern (storage,
# frames, scene inputs); the names code imported from here stay importable.
from ._frames import (  # noqa: E402, F401
    GRADIENT_SHADED_MODELS,
    LONG_FLOAT64_SAMPLES,
    LONG_FRAME_SAMPLES,
    MODEL_ABILITIES,
    UNBIASED_MODELS,
    check_frame_options,
    mean_image,
    output_format,
    output_image,
)
from ._storage import DEFAULT_CPU_CACHE, PRECISIONS, cpu_cache_bytes, device_texel_bytes  # noqa: E402, F401


class VolumeRenderer(VolumeLoading, FrameRendering, Picking, Slicing):
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
        self._planes = ()
        self._caps = False
        self._reference_voxels = None  # (volume, its voxels as the f64 integrator reads them), for picks
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
        engine.set_clip_planes(list(self._planes))
        # The parent's engine is leaked by the core, never freed here.
        self._engine_obj, self._engine_pid = engine, os.getpid()
        self._gradients_tried = False

    # -- scene -----------------------------------------------------------


    @_serialised
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

    @_serialised
    def set_light(self, light: Light) -> None:
        """Use ``light`` from the next frame; a camera-linked light is placed from the
        current camera at once."""
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

    @_serialised
    def set_clip_planes(self, planes=None, *, caps: bool = False) -> None:
        """Render only the part of the volume on the kept side of every plane.

        ``planes`` is a sequence of ``(point, normal)`` pairs (or an array of
        shape (N, 2, 3)) in world coordinates; a plane keeps the points ``x``
        with ``normal · (x - point) >= 0``: its normal points into the part
        that stays. Camera rays and shadow rays march only where every plane
        and the crop box (:meth:`set_crop_box`) keep, and the segment a plane
        cuts counts with its length, as at the box's faces. At most
        ``MAX_CLIP_PLANES`` (16) planes; None or ``[]`` removes them. Nothing
        is copied or uploaded.

        ``caps=True`` closes the cuts: :meth:`render` shows each plane's cut
        face, where it bounds what is kept, as an opaque surface coloured by
        the transfer function's colour of the volume there (a slice, see
        :meth:`render_slice`), which the volume is composited around.
        """
        if not isinstance(caps, (bool, np.bool_)):
            raise TypeError(f"caps must be True or False, got {caps!r}")
        self._planes = _clip_planes(planes)
        self._caps = bool(caps)
        self._engine.set_clip_planes(list(self._planes))

    @property
    def clip_planes(self) -> tuple:
        """The ``((point), (normal))`` pairs set by set_clip_planes (normals
        of unit length), or ``()``."""
        return self._planes

    @_serialised
    def set_config(self, config: RenderConfig) -> None:
        """Use ``config`` (a :class:`~pyvr.config.RenderConfig`) from the next frame;
        uploads no volume data."""
        if not isinstance(config, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(config)}")
        config.validate()
        self._config_snapshot = config.copy()
        self.config = config

    def get_config(self) -> RenderConfig:
        """The render config in use."""
        return self.config

    def get_light(self) -> Light:
        """The light in use."""
        return self.light

    def get_volume(self) -> Optional[Volume]:
        """The loaded volume, or None."""
        return self.volume

    def get_camera(self) -> Optional[Camera]:
        """The camera set, or None (then frames use :meth:`Camera.fit` of the volume)."""
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
        brick after brick, faster than the shader on lavapipe
        (docs/performance.md).
        Images match the shader's within 0.25 level
        (measured: 0.0004 on most scenes); ``last_frame_stats["engine"]``
        says which ran ("native" or "gpu"). It keeps a volume's texels in
        memory itself (each brick's too), and the shader's texture is made
        from them only when a frame first runs on the shader (docs/native-march.md).

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


ModernGLVolumeRenderer = VolumeRenderer

__all__ = ["VolumeRenderer", "prepare_voxels"]
