"""Camera placement from spherical parameters, paths and interactive control."""

from typing import Iterator, List, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from .._numbers import check_count, is_number, is_vec3
# pyvr 0.4.1 defined these here (and exposed CameraError): they live with the Camera now.
from .camera import (  # noqa: F401
    Camera,
    CameraError,
    _unit,
    get_camera_pos,
    get_camera_pos_from_params,
    validate_camera_angles,
)


def _map_to_sphere(x: float, y: float, radius: float = 1.0) -> np.ndarray:
    """Project a 2-D point onto the virtual trackball (sphere + hyperbola)."""
    d2 = x * x + y * y
    r2 = radius * radius
    if d2 <= r2 / 2.0:
        z = np.sqrt(r2 - d2)
    else:
        z = (r2 / 2.0) / np.sqrt(d2)
    v = np.array([x, y, z], dtype=np.float32)
    return v / np.linalg.norm(v)


def _camera_to_quaternion(camera: Camera) -> Rotation:
    p, up = get_camera_pos_from_params(camera)
    f = np.asarray(camera.target, dtype=np.float64) - p
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    return Rotation.from_matrix(np.column_stack([r, u, -f]))


def _signed_angle(a, b, axis) -> float:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na < 1e-9 or nb < 1e-9:
        return 0.0
    ang = float(np.arccos(np.clip(np.dot(a, b) / (na * nb), -1.0, 1.0)))
    return ang if np.dot(np.cross(a, b), axis) >= 0 else -ang


def _quaternion_to_camera_angles(rotation: Rotation, target, distance, init_pos, init_up) -> Tuple[float, float, float]:
    m = rotation.as_matrix()
    forward = -m[:, 2]
    actual_up = m[:, 1]
    target = np.asarray(target, dtype=np.float64)
    position = target - forward * distance
    n = np.asarray(init_up, dtype=np.float64)
    n = n / np.linalg.norm(n)

    def proj(v, axis):
        return v - np.dot(v, axis) * axis

    a = proj(np.asarray(init_pos, dtype=np.float64) - target, n)
    b = proj(position - target, n)
    azimuth = _signed_angle(a, b, n)
    elevation = float(np.arcsin(np.clip(-np.dot(forward, n), -1.0, 1.0)))
    tmp = Camera(
        target=np.asarray(target, dtype=np.float32),
        azimuth=azimuth,
        elevation=elevation,
        roll=0.0,
        distance=float(distance),
        init_pos=np.asarray(init_pos, dtype=np.float32),
        init_up=np.asarray(init_up, dtype=np.float32),
    )
    expected_up = tmp.get_camera_vectors()[1]
    roll = _signed_angle(proj(expected_up, forward), proj(actual_up, forward), forward)
    return azimuth, elevation, roll


class CameraPath:
    """Keyframed camera animation: every parameter, angles included, is
    interpolated linearly between neighbouring keyframes.

    Angles are interpolated as the numbers given, not the shortest way
    round, so keyframes at azimuth 0 and 2*pi turn a full circle (pyvr
    0.4.1 wrapped both to the same angle and stood still); to go the short
    way from 0 to 3*pi/2, give -pi/2. ``CameraPath.orbit`` builds a turn.
    """

    def __init__(self, keyframes: List[Camera]):
        if len(keyframes) < 2:
            raise ValueError("At least 2 keyframes are required for a camera path")
        self.keyframes = keyframes
        self.validate_keyframes()

    def validate_keyframes(self) -> None:
        """Raise ValueError unless every keyframe is a valid :class:`Camera`."""
        for i, k in enumerate(self.keyframes):
            if not isinstance(k, Camera):
                raise ValueError(f"Keyframe {i} must be a Camera instance")
            k.validate()

    @staticmethod
    def _lerp_vector(v1, v2, t):
        return v1 + (v2 - v1) * t

    @staticmethod
    def _lerp_angle(a1, a2, t):
        return float(a1) + (float(a2) - float(a1)) * t

    @classmethod
    def orbit(cls, camera: Camera, turns: float = 1.0, keyframes: int = 2) -> "CameraPath":
        """A path that turns ``camera`` about its target by ``turns`` full
        circles of azimuth (negative: the other way), everything else fixed.
        The first and last cameras coincide for whole turns, so a looping
        animation should leave out the last frame."""
        if not is_number(turns) or not np.isfinite(turns) or turns == 0:
            raise ValueError(f"turns must be a finite non-zero number, got {turns!r}")
        if isinstance(keyframes, bool) or not isinstance(keyframes, (int, np.integer)) or keyframes < 2:
            raise ValueError(f"keyframes must be an integer of at least 2, got {keyframes!r}")
        frames = []
        for i in range(keyframes):
            c = camera.copy()
            c.azimuth = float(camera.azimuth) + 2 * np.pi * float(turns) * i / (keyframes - 1)
            frames.append(c)
        return cls(frames)

    def cameras(self, n_frames: int, *, endpoint: bool = True) -> List[Camera]:
        """``n_frames`` cameras evenly spaced in t; ``endpoint=False`` leaves
        out t = 1 (for loops whose last keyframe repeats the first)."""
        return list(self.iter_cameras(n_frames, endpoint=endpoint))

    def iter_cameras(self, n_frames: int, *, endpoint: bool = True) -> Iterator[Camera]:
        """The cameras of ``cameras()``, made one at a time (long paths)."""
        return self._iter(check_count("n_frames", n_frames), endpoint)

    def _iter(self, n_frames: int, endpoint: bool) -> Iterator[Camera]:
        if n_frames == 1:
            yield self.keyframes[0].copy()
            return
        d = (n_frames - 1) if endpoint else n_frames
        for i in range(n_frames):
            yield self.interpolate(i / d)

    def interpolate(self, t: float) -> Camera:
        """The camera at ``t`` in [0, 1] along the path: keyframes evenly spaced in
        ``t``, each field interpolated linearly between its neighbours, angles as
        given (0 to 2*pi is a full turn)."""
        if not (0.0 <= t <= 1.0):
            raise ValueError("t must be between 0.0 and 1.0")
        if t == 0.0:
            return self.keyframes[0].copy()
        if t == 1.0:
            return self.keyframes[-1].copy()
        n = len(self.keyframes) - 1
        seg = min(int(t * n), n - 1)
        lt = t * n - seg
        a, b = self.keyframes[seg], self.keyframes[seg + 1]
        lerp = self._lerp_vector
        return Camera(
            target=lerp(a.target, b.target, lt),
            azimuth=self._lerp_angle(a.azimuth, b.azimuth, lt),
            elevation=self._lerp_angle(a.elevation, b.elevation, lt),
            roll=self._lerp_angle(a.roll, b.roll, lt),
            distance=lerp(a.distance, b.distance, lt),
            init_pos=lerp(a.init_pos, b.init_pos, lt),
            init_up=lerp(a.init_up, b.init_up, lt),
            fov=lerp(a.fov, b.fov, lt),
            near_plane=lerp(a.near_plane, b.near_plane, lt),
            far_plane=lerp(a.far_plane, b.far_plane, lt),
            # A change of projection happens halfway; heights interpolate.
            projection=a.projection if lt < 0.5 else b.projection,
            view_height=None if a.view_height is None and b.view_height is None
            else lerp(a.orthographic_height, b.orthographic_height, lt),
        )

    def generate_frames(self, n_frames: int) -> List[Camera]:
        """``n_frames`` cameras evenly spaced along the path, both ends included
        (:meth:`cameras`)."""
        if is_number(n_frames) and not isinstance(n_frames, bool) and n_frames < 1:
            raise ValueError("n_frames must be at least 1")  # pyvr 0.4.1's message
        return self.cameras(n_frames)


class CameraController:
    """Orbit, zoom, pan, roll and trackball control of a Camera (its own copy)."""

    def __init__(self, initial_params: Optional[Camera] = None):
        if initial_params is None:
            initial_params = Camera.front_view()
        self.params = initial_params.copy()

    def orbit(self, delta_azimuth: float, delta_elevation: float) -> None:
        """Turn about the target: add ``delta_azimuth`` and ``delta_elevation``
        (radians; elevation kept within +-pi/2)."""
        self.params.azimuth += delta_azimuth
        self.params.elevation = np.clip(self.params.elevation + delta_elevation, -np.pi / 2, np.pi / 2)

    def zoom(self, factor: float) -> None:
        """Multiply the distance by ``factor`` (> 0; below 1 comes closer), kept within
        [0.01, 1000]."""
        if factor <= 0:
            raise ValueError("Zoom factor must be positive")
        before = self.params.distance
        self.params.distance = np.clip(self.params.distance * factor, 0.01, 1000.0)
        if self.params.view_height is not None:
            # An orthographic view's height follows, as a perspective view's does.
            self.params.view_height = float(self.params.view_height * self.params.distance / before)

    def trackball(self, dx, dy, viewport_width, viewport_height, sensitivity: float = 1.0) -> None:
        """Rotate as if dragging a ball under the mouse: a drag of (``dx``, ``dy``)
        pixels, over the viewport's smaller side and times ``sensitivity``, is
        mapped onto a virtual ball, and the view turns by the arc from its
        centre to that point, about the axis perpendicular to the drag."""
        if viewport_width <= 0 or viewport_height <= 0:
            raise ValueError(
                f"Viewport dimensions must be positive, got width={viewport_width}, height={viewport_height}"
            )
        if dx == 0 and dy == 0:
            return
        s = min(viewport_width, viewport_height)
        dxn = -(dx / s) * sensitivity
        dyn = -(dy / s) * sensitivity
        if abs(dxn) < 0.001 and abs(dyn) < 0.001:
            return
        a = _map_to_sphere(0.0, 0.0)
        b = _map_to_sphere(dxn, dyn)
        axis = np.cross(a, b)
        if np.linalg.norm(axis) < 1e-8:
            return
        angle = np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))
        t = Rotation.from_rotvec(angle * axis / np.linalg.norm(axis))
        new = _camera_to_quaternion(self.params) * t
        p = self.params
        az, el, roll = _quaternion_to_camera_angles(new, p.target, p.distance, p.init_pos, p.init_up)
        p.azimuth, p.elevation, p.roll = az, el, roll

    def pan(self, delta_target) -> None:
        """Move the target (and so the camera) by ``delta_target``, a 3-vector in world
        units."""
        if not is_vec3(delta_target):
            raise ValueError("delta_target must be a 3D numpy array")
        self.params.target += delta_target

    def roll_camera(self, delta_roll: float) -> None:
        """Turn the camera about its view direction by ``delta_roll`` radians."""
        self.params.roll += delta_roll

    def set_distance(self, distance: float) -> None:
        """Set the distance from the target (> 0)."""
        if distance <= 0:
            raise ValueError("Distance must be positive")
        self.params.distance = distance

    def look_at(self, target) -> None:
        """Look at ``target`` (a 3-vector), keeping angles and distance."""
        if not is_vec3(target):
            raise ValueError("target must be a 3D numpy array")
        self.params.target = target.astype(np.float32)

    def reset_to_preset(self, preset: str, distance: Optional[float] = None) -> None:
        """Replace the camera by a preset view, ``'front'``, ``'side'``, ``'top'`` or
        ``'isometric'``, keeping the target and (unless given) the distance."""
        presets = {
            "front": Camera.front_view,
            "side": Camera.side_view,
            "top": Camera.top_view,
            "isometric": Camera.isometric_view,
        }
        if preset not in presets:
            raise ValueError(f"Unknown preset: {preset}. Available: {list(presets)}")
        d = self.params.distance if distance is None else distance
        kept = (self.params.projection, self.params.view_height)
        self.params = presets[preset](target=np.array(self.params.target, copy=True), distance=d)
        self.params.projection, self.params.view_height = kept

    def get_position_and_up(self):
        """``(position, up)`` of the current camera, as float32 3-vectors."""
        return get_camera_pos_from_params(self.params)

    def animate_to(self, target_params: Camera, n_frames: int = 30) -> List[Camera]:
        """``n_frames`` cameras from the current one to ``target_params`` (a
        :class:`CameraPath` of the two)."""
        return CameraPath([self.params.copy(), target_params.copy()]).generate_frames(n_frames)
