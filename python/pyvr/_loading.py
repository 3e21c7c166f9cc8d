"""``VolumeRenderer``'s volume: loading (one texture or bricks), the
precision it is stored at and chosen again when the value range changes,
and values packed with their gradients for gradient-shaded frames."""

import warnings
from typing import Optional

import numpy as np

from ._frames import GRADIENT_SHADED_MODELS
from ._scene import _vec
from ._storage import (
    PRECISIONS,
    _auto_precision,
    _check_fixed16,
    _check_volume_fits,
    _fixed16_range,
    _value_map_for,
    check_float32_storage,
    device_limits,
    device_texel_bytes,
    prepare_normals,
    prepare_voxels,
)
from ._threads import _serialised
from .config import RenderConfig
from .transferfunctions.value_range import sample_map
from .volume import Volume


class VolumeLoading:
    """Methods of VolumeRenderer (pyvr.renderer), which holds the state they use."""

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
        if not bricks.is_lazy(volume.data):
            check_float32_storage(volume.data)
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
        (docs/native-march.md).
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
