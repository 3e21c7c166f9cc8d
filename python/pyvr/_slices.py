"""Slices: the volume resampled on a plane through it (multi-planar
reformatting), as an image of its own or as opaque planes in the 3-D view."""

from typing import Optional

import numpy as np

from ._frames import _colour, output_image
from ._scene import _clip_planes, _check_size
from ._threads import _serialised
from .transferfunctions.value_range import lut_at, storage_unit


def trilinear(data, u: np.ndarray) -> np.ndarray:
    """``data`` interpolated at cell-centred voxel coordinates ``u`` (N, 3),
    clamped at the edges as the engines sample, reading 8 voxels each."""
    dims = np.array(data.shape[:3])
    u = np.clip(u, 0.0, dims - 1)
    lo = np.minimum(np.floor(u).astype(np.int64), dims - 2).clip(0)
    w = np.clip(u - lo, 0.0, 1.0)
    hi = np.minimum(lo + 1, dims - 1)
    out = np.zeros(len(u))
    for corner in range(8):
        at = [hi[:, a] if corner >> a & 1 else lo[:, a] for a in range(3)]
        weight = np.prod([w[:, a] if corner >> a & 1 else 1 - w[:, a] for a in range(3)], axis=0)
        out += weight * np.asarray(data[at[0], at[1], at[2]], np.float64)
    return out


def _plane_axes(normal: np.ndarray, up) -> tuple:
    """The slice image's right and up directions: ``up`` (default +z, or +y
    for a plane facing up) made perpendicular to the normal; right x up is
    the normal, so the slice is seen from the side the normal points to."""
    if up is None:
        up = (0.0, 0.0, 1.0) if abs(normal[2]) < 0.9 else (0.0, 1.0, 0.0)
    u = np.asarray(up, np.float64)
    if u.shape != (3,) or not np.all(np.isfinite(u)):
        raise ValueError(f"up must be three finite numbers, got {up!r}")
    u = u - (u @ normal) * normal
    if not np.linalg.norm(u) > 1e-9:
        raise ValueError(f"up {up!r} is parallel to the plane's normal: give another")
    u /= np.linalg.norm(u)
    return np.cross(u, normal), u


class Slicing:
    """VolumeRenderer's slice methods."""

    def _values_at(self, points: np.ndarray) -> np.ndarray:
        """The volume's values at world ``points`` (N, 3), NaN outside its box."""
        lo, hi = (np.asarray(b, np.float64) for b in self._bounds)
        dims = np.array(self.volume.data.shape[:3])
        inside = np.all((points >= lo) & (points <= hi), axis=1)
        out = np.full(len(points), np.nan)
        if inside.any():
            out[inside] = trilinear(self.volume.data, (points[inside] - lo) / (hi - lo) * dims - 0.5)
        return out

    def _colours_of(self, values: np.ndarray) -> np.ndarray:
        """Straight RGBA (N, 4) the transfer functions give data ``values``
        (linear between the table's entries, clamped; NaN transparent)."""
        self._ensure_tf()
        scale, offset = self._value_map
        tf = values / storage_unit(self.volume.data.dtype) * scale + offset
        rgba = lut_at(self._lut.astype(np.float64), np.nan_to_num(tf))
        rgba[np.isnan(values)] = 0.0
        return rgba

    @_serialised
    def render_slice(self, plane, size: Optional[tuple] = None, *, height: Optional[float] = None, up=None,
                     dtype=np.uint8, premultiplied: bool = False, origin: str = "lower", background=None,
                     values: bool = False) -> np.ndarray:
        """The volume resampled on ``plane`` (multi-planar reformatting).

        ``plane`` is ``(point, normal)`` in world coordinates; the image is
        centred on the point and seen from the side the normal points to,
        its up ``up`` made perpendicular to the normal (default +z, or +y
        for a plane facing up). ``size`` (width, height) in pixels (default
        the renderer's); ``height`` the world height it spans (default the
        box's diagonal, so every cut through the box fits). Each pixel is
        the volume interpolated trilinearly at its centre, as the engines
        sample it, through the transfer functions: colour, and the opacity
        as alpha; outside the box it is transparent. ``values=True``
        returns the interpolated data values instead, float64 (H, W), NaN
        outside. dtype, premultiplied, origin, background as :meth:`render`.
        """
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render_slice()")
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        planes = _clip_planes(plane)
        if len(planes) != 1:
            raise ValueError(f"plane must be one (point, normal) pair, got {len(planes)} planes")
        ((point, normal),) = planes
        w, h = (self.width, self.height) if size is None else _check_size(size)
        lo, hi = (np.asarray(b, np.float64) for b in self._bounds)
        span = float(np.linalg.norm(hi - lo)) if height is None else height
        if isinstance(span, (bool, np.bool_)) or not (np.isfinite(span) and span > 0):
            raise ValueError(f"height must be a finite number > 0, got {height!r}")
        n = np.asarray(normal)
        right, upward = _plane_axes(n, up)
        x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * 0.5 * span * w / h
        y = (2.0 * (np.arange(h) + 0.5) / h - 1.0) * 0.5 * span
        points = np.asarray(point) + x[None, :, None] * right + y[:, None, None] * upward
        v = self._values_at(points.reshape(-1, 3)).reshape(h, w)
        if values:
            return v[::-1].copy() if origin == "upper" else v
        rgba = self._colours_of(v.reshape(-1)).reshape(h, w, 4)
        rgba[..., :3] *= rgba[..., 3:]
        return output_image(rgba.astype(np.float32), np.dtype(dtype), premultiplied,
                            None if background is None else _colour(background), origin)

    def _slice_scene(self, planes, w: int, h: int, within=()) -> tuple:
        """Slice planes as an opaque scene of the current view: per pixel
        (row 0 at the bottom) the distance along its ray to the nearest
        plane's point inside the (cropped) box and on the kept side of every
        plane of ``within`` (a clip plane's cap: the face that bounds what
        is kept), and the transfer function's colour of the volume there
        (inf and black where no plane is met)."""
        origins, dirs = _pixel_rays(self._frame_camera(), w, h)
        lo, hi = (np.asarray(b, np.float64) for b in self._bounds)
        if self._crop is not None:
            lo, hi = np.maximum(lo, self._crop[0]), np.minimum(hi, self._crop[1])
        depth = np.full((h, w), np.inf)
        for point, normal in _clip_planes(planes):
            n = np.asarray(normal)
            slope = dirs @ n
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((np.asarray(point) - origins) @ n) / slope
            at = origins + dirs * t[..., None]
            inside = np.all((at >= lo) & (at <= hi), axis=-1) & (t > 0) & np.isfinite(t)
            # (A cap lies on its own plane: kept up to rounding of its size.)
            slack = 1e-9 * float(np.linalg.norm(hi - lo))
            for q, m in within:
                inside &= (at - np.asarray(q)) @ np.asarray(m) >= -slack
            depth = np.where(inside & (t < depth), t, depth)
        color = np.zeros((h, w, 3))
        seen = np.isfinite(depth)
        if seen.any():
            points = (origins + dirs * np.where(seen, depth, 0.0)[..., None])[seen]
            color[seen] = self._colours_of(self._values_at(points))[:, :3]
        return depth, color


def _pixel_rays(camera: tuple, w: int, h: int) -> tuple:
    """Each pixel's ray (row 0 at the bottom) as the engines make it from
    the core's camera tuple: origins and unit directions, (h, w, 3) each."""
    position, target, up, fov = (np.asarray(c, np.float64) for c in camera[:4])
    f = target - position
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    if not np.linalg.norm(r) > 1e-12 * max(np.linalg.norm(up), 1e-300):
        r = np.cross(f, np.eye(3)[np.argmin(np.abs(f))])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * w / h
    y = 2.0 * (np.arange(h) + 0.5) / h - 1.0
    across = x[None, :, None] * r + y[:, None, None] * u
    if len(camera) == 5:  # orthographic: parallel rays from the camera's plane
        origins = position + 0.5 * camera[4] * across
        return origins, np.broadcast_to(f, origins.shape)
    d = f + np.tan(0.5 * float(fov)) * across
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.broadcast_to(position, d.shape), d
