"""VolumeRenderer.pick: which point of the volume a pixel shows."""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import _core
from ._slices import trilinear
from ._storage import prepare_normals, prepare_voxels
from ._threads import _serialised


@dataclass(frozen=True)
class Picks:
    """What pixels show, one entry per pixel asked for (arrays of the shape
    the pixel coordinates broadcast to, with a last axis of 3 for points).

    ``hit``: whether the pixel shows anything. ``position``: the world point
    (NaN where nothing). ``depth``: its distance along the pixel's ray from
    the camera (perspective) or from the camera's plane (orthographic).
    ``index``: the nearest voxel, (i, j, k) into ``volume.data`` (-1 where
    nothing). ``value``: the volume's value there, interpolated, in the
    data's own units."""

    hit: np.ndarray
    position: np.ndarray
    depth: np.ndarray
    index: np.ndarray
    value: np.ndarray


def _pixel_indices(name: str, v, size: int) -> np.ndarray:
    a = np.asarray(v)
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
        raise TypeError(f"{name} must be pixel coordinates (numbers), got {v!r}")
    a = np.rint(a.astype(np.float64))
    if not np.all((a >= 0) & (a < size)):
        raise ValueError(f"{name} must be pixel coordinates from 0 to {size - 1}, got {v!r}")
    return a.astype(np.uint32)


class Picking:
    """VolumeRenderer's pick method."""

    def _reference_voxels_of_volume(self) -> np.ndarray:
        """The loaded volume as the float64 integrator reads it
        (``prepare_voxels``), kept while that volume stays loaded: a view
        picks under the moving mouse, and a volume not stored as it is
        (float64, say) would otherwise be converted on every event."""
        kept = self._reference_voxels
        if kept is None or kept[0] is not self.volume:
            kept = (self.volume, prepare_voxels(self.volume.data))
            self._reference_voxels = kept
        return kept[1]

    @_serialised
    def pick(self, x, y, *, threshold: float = 0.5, origin: str = "lower",
             config: Optional[object] = None) -> Picks:
        """What the pixels (x, y) of the current frame show, as points.

        ``x`` (column) and ``y`` (row, counted from the bottom with
        ``origin="lower"`` as :meth:`render` returns it, from the top with
        ``"upper"``) are pixel indices, numbers or arrays that broadcast;
        many pixels at once are marched on every core. What a pixel shows
        is each model's own: for the integrating models the point where its
        ray's accumulated opacity first reaches ``threshold``; for maximum
        and minimum projections the sample that sets the pixel (the average
        projection's largest); for the isosurface the surface hit. Points
        come from the float64 integrator (:meth:`render_float64`'s rules,
        midpoint segments), so they are the oracle's own. A ray that meets
        nothing visible gives ``hit`` False.
        """
        from .config import RenderConfig

        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before pick()")
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        if isinstance(threshold, (bool, np.bool_)) or not isinstance(threshold, (int, float, np.number)):
            raise TypeError(f"threshold must be a number, got {threshold!r}")
        if not 0 < threshold <= 1:
            raise ValueError(f"threshold must be in (0, 1], got {threshold}")
        cfg = self._config_snapshot if config is None else config
        if not isinstance(cfg, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(cfg)}")
        cols = _pixel_indices("x", x, self.width)
        rows = _pixel_indices("y", y, self.height)
        cols, rows = np.broadcast_arrays(cols, rows)
        shape = cols.shape
        if origin == "upper":
            rows = self.height - 1 - rows
        self._ensure_tf()
        pixels = np.ascontiguousarray(np.stack([cols.reshape(-1), rows.reshape(-1)], axis=1), np.uint32)
        found = _core.pick_reference(
            self._reference_voxels_of_volume(), prepare_normals(self.volume.normals), *self._bounds, self._lut,
            self._frame_camera(), self._light_args, cfg.replace(unbiased=False), self.width, self.height, pixels,
            float(threshold), self._value_map, self._crop, list(self._planes),
        )
        hit = np.isfinite(found[:, 0])
        position = found[:, 1:]
        index = np.full((len(found), 3), -1, np.int64)
        value = np.full(len(found), np.nan)
        if hit.any():
            lo, hi = (np.asarray(b, np.float64) for b in self._bounds)
            dims = np.array(self.volume.data.shape[:3])
            u = (position[hit] - lo) / (hi - lo) * dims - 0.5  # cell-centred voxel coordinates
            index[hit] = np.clip(np.rint(u), 0, dims - 1).astype(np.int64)
            value[hit] = trilinear(self.volume.data, u)
        return Picks(hit=hit.reshape(shape), position=position.reshape(shape + (3,)),
                     depth=found[:, 0].reshape(shape), index=index.reshape(shape + (3,)),
                     value=value.reshape(shape))

    def depth_image(self, *, threshold: float = 0.5, origin: str = "lower") -> np.ndarray:
        """The depth of what every pixel shows, for any model: float32
        (H, W) distances along the pixels' rays (as :meth:`pick` defines
        the point: the opacity ``threshold``'s first crossing, the
        projection's extremum, the surface hit), inf where nothing is. For
        meshes drawn after the volume: :func:`pyvr.scene_depth.to_depth_buffer`
        turns it into a rasteriser's depth buffer. Computed by the float64
        integrator's rules on every core (a pick per pixel), not by the
        frame's engine."""
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        cols, rows = np.meshgrid(np.arange(self.width), np.arange(self.height))
        d = self.pick(cols, rows, threshold=threshold).depth
        d = np.where(np.isnan(d), np.inf, d).astype(np.float32)
        return np.ascontiguousarray(d[::-1]) if origin == "upper" else d
