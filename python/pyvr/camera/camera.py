"""The Camera: a target, spherical angles and a distance (pyvr 0.4.1)."""

import json
import warnings
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from .._numbers import is_number, is_vec3


class CameraError(ValueError):
    """Invalid camera angles (raised by ``validate_camera_angles``)."""


def validate_camera_angles(azimuth, elevation, roll) -> None:
    """Raise :class:`CameraError` unless ``azimuth``, ``elevation`` and ``roll``
    are finite numbers."""
    for name, v in (("azimuth", azimuth), ("elevation", elevation), ("roll", roll)):
        if not is_number(v):
            raise CameraError(f"{name} must be numeric, got {type(v)}")
        if not np.isfinite(v):
            raise CameraError(f"{name} must be finite, got {v}")


def degrees_to_radians(**kwargs) -> Dict[str, float]:
    """Each keyword's value converted from degrees to radians, as a dict:
    ``degrees_to_radians(azimuth=45)``."""
    return {k: np.radians(v) for k, v in kwargs.items()}


def radians_to_degrees(**kwargs) -> Dict[str, float]:
    """Each keyword's value converted from radians to degrees, as a dict."""
    return {k: np.degrees(v) for k, v in kwargs.items()}


PROJECTIONS = ("perspective", "orthographic")


def _f32(v):
    return np.array(v, dtype=np.float32)


@dataclass
class Camera:
    """A perspective camera orbiting ``target``.

    ``init_pos`` is the absolute position at zero angles (as pyvr: not
    relative to target), ``init_up`` the world up (+Z), ``fov`` the vertical
    field of view in radians. Angles are radians.
    """

    target: np.ndarray = field(default_factory=lambda: _f32([0.0, 0.0, 0.0]))
    azimuth: float = 0.0
    elevation: float = 0.0
    roll: float = 0.0
    distance: float = 3.0
    init_pos: np.ndarray = field(default_factory=lambda: _f32([1.0, 0.0, 0.0]))
    init_up: np.ndarray = field(default_factory=lambda: _f32([0.0, 0.0, 1.0]))
    fov: float = np.pi / 4
    near_plane: float = 0.1
    far_plane: float = 100.0
    projection: str = "perspective"
    view_height: Optional[float] = None

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check the fields (target, init_pos and init_up 3-vectors; angles
        numeric; distance positive, ...); raises ValueError naming the field,
        and warns for angles past 4*pi."""
        if not is_vec3(self.target):
            raise ValueError("target must be a 3D numpy array")
        for name in ("azimuth", "elevation", "roll"):
            v = getattr(self, name)
            if not is_number(v):
                raise ValueError(f"{name} must be numeric")
            if abs(v) > 4 * np.pi:
                # A warning, not pyvr's print: it can be filtered, and long
                # turntable paths pass such angles on purpose.
                warnings.warn(f"{name} = {v:.3f} rad ({np.degrees(v):.1f}°) is unusually large", UserWarning,
                              stacklevel=3)
        if not is_number(self.distance) or not self.distance > 0:
            raise ValueError("distance must be positive")
        if not is_vec3(self.init_pos):
            raise ValueError("init_pos must be a 3D numpy array")
        if not is_vec3(self.init_up):
            raise ValueError("init_up must be a 3D numpy array")
        # In float64: float32 squares overflow for boxes past 1e19 across.
        if np.linalg.norm(np.asarray(self.init_pos, np.float64) - np.asarray(self.target, np.float64)) < 1e-9:
            raise ValueError("init_pos must not be at the same location as target")
        if np.linalg.norm(self.init_up) < 1e-9:
            raise ValueError("init_up must not be the zero vector")
        if not is_number(self.fov) or not (0 < self.fov < np.pi):
            raise ValueError("fov must be between 0 and π radians")
        if not is_number(self.near_plane) or not self.near_plane > 0:
            raise ValueError("near_plane must be positive")
        if not is_number(self.far_plane) or not self.far_plane > self.near_plane:
            raise ValueError("far_plane must be greater than near_plane")
        if self.projection not in PROJECTIONS:
            raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}, got {self.projection!r}")
        if self.view_height is not None and not (
                is_number(self.view_height) and 0 < self.view_height < np.inf):
            raise ValueError(f"view_height must be a finite number > 0 or None, got {self.view_height!r}")

    @property
    def orthographic_height(self) -> float:
        """The world height an orthographic view of this camera shows:
        ``view_height``, or by default the height the perspective view shows
        at the target (``2 distance tan(fov / 2)``), so that switching the
        projection keeps what is at the target the same size."""
        if self.view_height is not None:
            return float(self.view_height)
        return float(2.0 * self.distance * np.tan(0.5 * self.fov))

    @classmethod
    def from_spherical(cls, target, azimuth, elevation, roll, distance, **kwargs) -> "Camera":
        """A camera looking at ``target`` from ``azimuth``, ``elevation`` (radians) and
        ``distance``, turned by ``roll`` about its view direction; other fields as
        keywords."""
        return cls(target=target, azimuth=azimuth, elevation=elevation, roll=roll, distance=distance, **kwargs)

    @classmethod
    def front_view(cls, target=None, distance: float = 3.0) -> "Camera":
        """Looking along -z at ``target`` (default the origin) from ``distance``:
        azimuth 0, elevation 0."""
        return cls(target=_f32([0, 0, 0]) if target is None else target, distance=distance)

    @classmethod
    def side_view(cls, target=None, distance: float = 3.0) -> "Camera":
        """Looking at ``target`` from the side: azimuth pi/2, elevation 0, at
        ``distance``."""
        return cls(target=_f32([0, 0, 0]) if target is None else target, azimuth=np.pi / 2, distance=distance)

    @classmethod
    def top_view(cls, target=None, distance: float = 3.0) -> "Camera":
        """Looking down at ``target``: elevation pi/2, at ``distance``."""
        return cls(target=_f32([0, 0, 0]) if target is None else target, elevation=np.pi / 2, distance=distance)

    @classmethod
    def isometric_view(cls, target=None, distance: float = 3.0) -> "Camera":
        """A three-quarter view of ``target``: azimuth pi/4, elevation pi/6, at
        ``distance``."""
        return cls(
            target=_f32([0, 0, 0]) if target is None else target,
            azimuth=np.pi / 4,
            elevation=np.pi / 6,
            distance=distance,
        )

    @classmethod
    def fit(cls, volume, *, azimuth: float = 0.0, elevation: float = 0.0, roll: float = 0.0,
            fov: float = np.pi / 4, aspect: float = 1.0, margin: float = 1.05,
            projection: str = "perspective") -> "Camera":
        """A camera aimed at the centre of ``volume`` (a Volume, or a
        ``(min_bounds, max_bounds)`` pair) from the given angles, far enough
        that the box's bounding sphere fits the view with ``margin`` to spare,
        in an image ``aspect`` = width / height. Works at any scale: a CT in
        millimetres is framed as well as pyvr's [-1, 1] box. With
        ``projection="orthographic"`` the view's height is chosen so that
        the sphere fits (the camera stands as far off as for perspective,
        outside the sphere)."""
        if hasattr(volume, "min_bounds") and hasattr(volume, "max_bounds"):
            lo, hi = volume.min_bounds, volume.max_bounds
        else:
            try:
                lo, hi = volume
            except (TypeError, ValueError):
                raise TypeError(f"fit needs a Volume or a (min_bounds, max_bounds) pair, got {type(volume)}") from None
        lo = np.asarray(lo, np.float64).reshape(-1)
        hi = np.asarray(hi, np.float64).reshape(-1)
        if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(lo)) or not np.all(hi > lo):
            raise ValueError(f"fit needs finite bounds with max > min, got {lo} and {hi}")
        if not (is_number(aspect) and aspect > 0 and is_number(margin) and margin > 0):
            raise ValueError(f"aspect and margin must be positive numbers, got {aspect!r} and {margin!r}")
        if not (is_number(fov) and 0 < fov < np.pi):
            raise ValueError("fov must be between 0 and π radians")
        if projection not in PROJECTIONS:
            raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}, got {projection!r}")
        centre = 0.5 * (lo + hi)
        radius = 0.5 * float(np.linalg.norm(hi - lo))
        half = min(0.5 * fov, np.arctan(aspect * np.tan(0.5 * fov)))
        distance = margin * radius / np.sin(half)
        # The sphere's diameter fits the height and the width (aspect times it).
        height = 2.0 * margin * radius * max(1.0, 1.0 / aspect) if projection == "orthographic" else None
        return cls(
            target=centre.astype(np.float32),
            azimuth=azimuth,
            elevation=elevation,
            roll=roll,
            distance=float(distance),
            init_pos=(centre + np.array([radius, 0.0, 0.0])).astype(np.float32),
            fov=fov,
            near_plane=float(min(0.1, 0.01 * distance)),
            far_plane=float(max(100.0, 2.0 * (distance + radius))),
            projection=projection,
            view_height=height,
        )

    def to_dict(self) -> dict:
        """The camera as a JSON-ready dict (target as a list; angles, distance, fov and
        planes as floats)."""
        return {
            "target": np.asarray(self.target).tolist(),
            "azimuth": float(self.azimuth),
            "elevation": float(self.elevation),
            "roll": float(self.roll),
            "distance": float(self.distance),
            "init_pos": np.asarray(self.init_pos).tolist(),
            "init_up": np.asarray(self.init_up).tolist(),
            "fov": float(self.fov),
            "near_plane": float(self.near_plane),
            "far_plane": float(self.far_plane),
            "projection": self.projection,
            "view_height": None if self.view_height is None else float(self.view_height),
        }

    @classmethod
    def from_dict(cls, data: dict) -> "Camera":
        """The camera a :meth:`to_dict` dict describes."""
        return cls(
            target=_f32(data["target"]),
            azimuth=data["azimuth"],
            elevation=data["elevation"],
            roll=data["roll"],
            distance=data["distance"],
            init_pos=_f32(data["init_pos"]),
            init_up=_f32(data["init_up"]),
            fov=data.get("fov", np.pi / 4),
            near_plane=data.get("near_plane", 0.1),
            far_plane=data.get("far_plane", 100.0),
            projection=data.get("projection", "perspective"),
            view_height=data.get("view_height"),
        )

    def save_to_file(self, filepath) -> None:
        """Write :meth:`to_dict` as JSON to ``filepath``."""
        with open(filepath, "w") as f:
            json.dump(self.to_dict(), f, indent=2)

    @classmethod
    def load_from_file(cls, filepath) -> "Camera":
        """The camera saved by :meth:`save_to_file` in ``filepath``."""
        with open(filepath) as f:
            return cls.from_dict(json.load(f))

    def copy(self) -> "Camera":
        """An independent copy (the target array is not shared)."""
        return Camera.from_dict(self.to_dict())

    def get_camera_vectors(self) -> Tuple[np.ndarray, np.ndarray]:
        """(position, up) as float64 arrays."""
        return get_camera_pos_from_params(self)

    def _basis(self):
        p, up = self.get_camera_vectors()
        f = np.asarray(self.target, dtype=np.float64) - p
        f /= np.linalg.norm(f)
        r = np.cross(f, up)
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        return p, f, r, u

    def get_view_matrix(self) -> np.ndarray:
        """Look-at matrix, stored transposed (column-major) as in pyvr."""
        p, f, r, u = self._basis()
        m = np.zeros((4, 4), dtype=np.float64)
        m[0:3, 0] = r
        m[0:3, 1] = u
        m[0:3, 2] = -f
        m[3, 0] = -np.dot(r, p)
        m[3, 1] = -np.dot(u, p)
        m[3, 2] = np.dot(f, p)
        m[3, 3] = 1.0
        return m.astype(np.float32)

    def get_projection_matrix(self, aspect_ratio: float) -> np.ndarray:
        """The 4x4 OpenGL-style projection matrix for ``aspect_ratio`` (width /
        height): perspective from ``fov``, or orthographic over
        :attr:`orthographic_height`, with the near and far planes."""
        n, fa = self.near_plane, self.far_plane
        if self.projection == "orthographic":
            top = 0.5 * self.orthographic_height
            return np.array(
                [
                    [1 / (aspect_ratio * top), 0, 0, 0],
                    [0, 1 / top, 0, 0],
                    [0, 0, 2 / (n - fa), (fa + n) / (n - fa)],
                    [0, 0, 0, 1],
                ],
                dtype=np.float32,
            )
        f = 1.0 / np.tan(self.fov / 2.0)
        return np.array(
            [
                [f / aspect_ratio, 0, 0, 0],
                [0, f, 0, 0],
                [0, 0, (fa + n) / (n - fa), 2 * fa * n / (n - fa)],
                [0, 0, -1, 0],
            ],
            dtype=np.float32,
        )

    def __repr__(self) -> str:
        return (
            f"Camera(target={self.target}, "
            f"azimuth={self.azimuth:.3f} rad ({np.degrees(self.azimuth):.1f}°), "
            f"elevation={self.elevation:.3f} rad ({np.degrees(self.elevation):.1f}°), "
            f"roll={self.roll:.3f} rad ({np.degrees(self.roll):.1f}°), "
            f"distance={self.distance:.2f}"
            + ("" if self.projection == "perspective" else f", orthographic, height {self.orthographic_height:.3g}")
            + ")"
        )


def _unit(v: np.ndarray):
    """v / |v| without overflow or underflow in the norm; None for zero."""
    m = np.max(np.abs(v))
    if not m > 0:
        return None
    u = v / m
    return u / np.linalg.norm(u)


def get_camera_pos(target, azimuth, elevation, roll, distance, init_pos=None, init_up=None):
    """Camera position and up vector from spherical parameters (float64 arrays).

    Rotations compose as in pyvr: roll about the view direction first, then
    elevation, then azimuth about ``init_up``.
    """
    validate_camera_angles(azimuth, elevation, roll)
    if not is_vec3(target):
        raise ValueError("target must be a 3D numpy array")
    if not is_number(distance) or not distance > 0:
        raise ValueError("distance must be positive")
    if init_pos is None:
        init_pos = np.array([0.0, 0.0, distance], dtype=np.float32)
    if init_up is None:
        init_up = np.array([0.0, 1.0, 0.0], dtype=np.float32)
    if not is_vec3(init_pos):
        raise ValueError("init_pos must be a 3D numpy array")
    if not is_vec3(init_up):
        raise ValueError("init_up must be a 3D numpy array")
    # pyvr's float32 inputs, then float64 unit vectors: the distance only
    # scales the result, so a scene 1e-30 or 1e30 across neither underflows
    # nor overflows the norms (which flipped or broke the rotation).
    target = target.astype(np.float32).astype(np.float64)
    init_pos = init_pos.astype(np.float32).astype(np.float64)
    init_up = init_up.astype(np.float32).astype(np.float64)
    if not (np.all(np.isfinite(target)) and np.all(np.isfinite(init_pos)) and np.all(np.isfinite(init_up))
            and np.isfinite(distance)):
        raise ValueError("target, init_pos, init_up and distance must be finite")

    unit = _unit(init_pos - target)
    if unit is None:
        raise ValueError("init_pos must not be the zero vector (relative to target)")
    r_az = Rotation.from_rotvec(azimuth * init_up)
    view_dir = -unit
    axis_el = np.cross(init_up, view_dir)
    if np.linalg.norm(axis_el) < 1e-6:
        fallback = np.array([1.0, 0.0, 0.0]) if abs(init_up[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
        axis_el = np.cross(init_up, fallback)
    axis_el = axis_el / np.linalg.norm(axis_el)
    r_el = Rotation.from_rotvec(elevation * axis_el)
    r_roll = Rotation.from_rotvec(roll * view_dir)
    r = r_az * r_el * r_roll
    position = r.apply(unit) * float(distance) + target
    up = r.apply(init_up)
    return np.asarray(position, dtype=np.float64), np.asarray(up, dtype=np.float64)


def get_camera_pos_from_params(params: Camera):
    """``(position, up)`` of a :class:`Camera`: :func:`get_camera_pos` of its
    target, angles and distance."""
    return get_camera_pos(
        params.target,
        params.azimuth,
        params.elevation,
        params.roll,
        params.distance,
        params.init_pos,
        params.init_up,
    )
