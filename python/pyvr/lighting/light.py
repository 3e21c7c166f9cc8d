"""Ambient + diffuse lights (pyvr 0.4.1), directional or point."""

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .._numbers import finite_vec3, is_number


class LightError(ValueError):
    """Kept for compatibility with pyvr 0.4.1 (never raised)."""


def _f32(v):
    return np.array(v, dtype=np.float32)


@dataclass
class Light:
    """A light: ``ambient + diffuse * max(n . L, 0)`` scales sample colours.

    ``L`` is the direction light travels: from ``position`` toward ``target``
    for a directional light, from ``position`` to each sample for a point
    light (``Light.point_light``; pyvr rendered those as directional too).
    """

    position: np.ndarray = field(default_factory=lambda: _f32([1.0, 1.0, 1.0]))
    target: np.ndarray = field(default_factory=lambda: _f32([0.0, 0.0, 0.0]))
    ambient_intensity: float = 0.2
    diffuse_intensity: float = 0.8
    _is_linked: bool = field(default=False, init=False, repr=False)
    _camera_offsets: Optional[dict] = field(default=None, init=False, repr=False)
    _kind: str = field(default="directional", init=False, repr=False)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check the fields (finite position and target; intensities in [0, 1]); raises
        ValueError naming the field."""
        finite_vec3("position", self.position)
        finite_vec3("target", self.target)
        if not is_number(self.ambient_intensity) or not (0.0 <= self.ambient_intensity <= 1.0):
            raise ValueError("ambient_intensity must be between 0.0 and 1.0")
        if not is_number(self.diffuse_intensity) or not (0.0 <= self.diffuse_intensity <= 1.0):
            raise ValueError("diffuse_intensity must be between 0.0 and 1.0")

    @property
    def kind(self) -> str:
        """"directional" or "point"."""
        return self._kind

    @classmethod
    def directional(cls, direction, ambient: float = 0.2, diffuse: float = 0.8, distance: float = 10.0) -> "Light":
        """A light shining along ``direction`` (any non-zero 3-vector): placed
        ``distance`` back along it from the origin, with the given ambient and
        diffuse intensities."""
        d = np.asarray(direction, dtype=np.float64).reshape(-1)
        m = np.max(np.abs(d)) if d.shape == (3,) else np.nan
        if not (np.isfinite(m) and m > 0):
            raise ValueError(f"direction must be a non-zero vector of three finite numbers, got {direction!r}")
        d = d / m  # scaled first: a tiny or huge vector keeps its direction
        d = _f32(d / np.linalg.norm(d))
        return cls(position=-d * np.float32(distance), target=_f32([0, 0, 0]), ambient_intensity=ambient, diffuse_intensity=diffuse)

    @classmethod
    def point_light(cls, position, target=None, ambient: float = 0.2, diffuse: float = 0.8) -> "Light":
        """A light at ``position`` shining at ``target`` (default the origin)."""
        light = cls(
            position=_f32(position),
            target=_f32([0, 0, 0]) if target is None else _f32(target),
            ambient_intensity=ambient,
            diffuse_intensity=diffuse,
        )
        light._kind = "point"
        return light

    @classmethod
    def default(cls) -> "Light":
        """pyvr's default light: at (1, 1, 1) shining at the origin, ambient 0.2,
        diffuse 0.8."""
        return cls()

    @classmethod
    def ambient_only(cls, intensity: float = 0.5) -> "Light":
        """Ambient light only (``intensity``), no diffuse term: unshaded colours."""
        return cls(position=_f32([0, 0, 0]), target=_f32([0, 0, 0]), ambient_intensity=intensity, diffuse_intensity=0.0)

    @classmethod
    def camera_linked(cls, azimuth_offset=0.0, elevation_offset=0.0, distance_offset=0.0, ambient=0.2, diffuse=0.8):
        """A light that follows the camera (a headlight), offset from it by the given
        azimuth, elevation (radians) and distance; the renderer moves it on every
        camera change."""
        light = cls(position=_f32([1, 1, 1]), target=_f32([0, 0, 0]), ambient_intensity=ambient, diffuse_intensity=diffuse)
        return light.link_to_camera(azimuth_offset, elevation_offset, distance_offset)

    def get_direction(self) -> np.ndarray:
        """The unit vector from the position to the target (float32; -z when they
        coincide)."""
        d = np.asarray(self.target, dtype=np.float64) - np.asarray(self.position, dtype=np.float64)
        n = np.linalg.norm(d)
        if not n >= 1e-9:
            return _f32([0.0, 0.0, -1.0])
        return (d / n).astype(np.float32)

    def copy(self) -> "Light":
        """An independent copy, camera link and offsets included."""
        light = Light(
            position=np.array(self.position, copy=True),
            target=np.array(self.target, copy=True),
            ambient_intensity=self.ambient_intensity,
            diffuse_intensity=self.diffuse_intensity,
        )
        light._is_linked = self._is_linked
        light._camera_offsets = None if self._camera_offsets is None else dict(self._camera_offsets)
        light._kind = self._kind
        return light

    @property
    def is_linked(self) -> bool:
        """Whether the light follows the camera (:meth:`camera_linked`,
        :meth:`link_to_camera`)."""
        return self._is_linked

    def link_to_camera(self, azimuth_offset=0.0, elevation_offset=0.0, distance_offset=0.0) -> "Light":
        """Follow the camera from now on, turned by these offsets (see
        update_from_camera). pyvr 0.4.1 stored the offsets and ignored them."""
        for name, v in (("azimuth_offset", azimuth_offset), ("elevation_offset", elevation_offset),
                        ("distance_offset", distance_offset)):
            if not is_number(v) or not np.isfinite(v):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        self._is_linked = True
        self._camera_offsets = {"azimuth": azimuth_offset, "elevation": elevation_offset, "distance": distance_offset}
        return self

    def unlink_from_camera(self) -> "Light":
        """Stop following the camera, keeping the current position; returns the light."""
        self._is_linked = False
        self._camera_offsets = None
        return self

    def update_from_camera(self, camera) -> None:
        """Put the light where the camera is, turned by the link's offsets
        (azimuth and elevation in radians, distance added to the camera's),
        aimed at the camera's target. With zero offsets it is a headlight.

        A renderer does this itself for a linked light whenever its camera
        changes (``set_camera``, ``render_path``, the interfaces)."""
        from ..camera import Camera

        if not self._is_linked:
            raise ValueError("Light is not linked to camera. Call link_to_camera() first.")
        if self._camera_offsets is None:
            raise ValueError("Camera offsets not set. Call link_to_camera() first.")
        if not isinstance(camera, Camera):
            raise ValueError("camera must be a Camera instance")
        o = self._camera_offsets
        if o["azimuth"] or o["elevation"] or o["distance"]:
            moved = camera.copy()
            moved.azimuth = float(camera.azimuth) + float(o["azimuth"])
            moved.elevation = float(camera.elevation) + float(o["elevation"])
            # A light closer than the target would flip; keep it in front.
            moved.distance = max(float(camera.distance) + float(o["distance"]), 1e-6 * float(camera.distance))
            camera = moved
        pos, _ = camera.get_camera_vectors()
        self.position = np.array(pos, dtype=np.float64)
        self.target = np.array(camera.target, copy=True)

    def get_offsets(self) -> Optional[dict]:
        """The camera-link offsets as a dict (``azimuth``, ``elevation``,
        ``distance``), or None when not linked."""
        return None if self._camera_offsets is None else dict(self._camera_offsets)

    def __repr__(self) -> str:
        return (
            f"Light(position={self.position}, target={self.target}, "
            f"ambient={self.ambient_intensity:.2f}, diffuse={self.diffuse_intensity:.2f})"
        )
