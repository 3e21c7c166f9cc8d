"""A frame's inputs as the engine takes them: camera and light tuples,
vectors, camera paths, transfer-function tables, sizes."""

import os
import tempfile

import numpy as np

from ._numbers import check_count, is_number
from .camera import Camera, CameraPath
from .lighting import Light


def _vec(v):
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    return (float(a[0]), float(a[1]), float(a[2]))


def _finite_vec(name, v):
    try:
        a = np.asarray(v, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be three numbers, got {v!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be three finite numbers, got {v!r}")
    return (float(a[0]), float(a[1]), float(a[2]))


MAX_CLIP_PLANES = 16


def _clip_planes(planes) -> tuple:
    """Clip planes as ((point), (unit normal)) pairs of floats, checked: a
    sequence of (point, normal) pairs, an (N, 2, 3) array, or one pair."""
    if planes is None:
        return ()
    what = "planes must be (point, normal) pairs of three numbers each, or an (N, 2, 3) array"
    try:
        raw = np.asarray(planes, dtype=object)
    except (TypeError, ValueError):
        raise TypeError(f"{what}, got {planes!r}") from None
    if raw.size > 6 * 1024:  # before looking at each number
        raise ValueError(f"at most {MAX_CLIP_PLANES} clip planes, got an array of shape {raw.shape}")
    # Bools and complex numbers are not coordinates (numpy would take them).
    if any(isinstance(x, (bool, np.bool_, complex, np.complexfloating)) for x in raw.reshape(-1)):
        raise TypeError(f"{what}, got {planes!r}")
    try:
        a = raw.astype(np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{what}, got {planes!r}") from None
    if a.size == 0:
        return ()
    if a.shape == (2, 3):
        a = a[None]
    if a.ndim != 3 or a.shape[1:] != (2, 3):
        raise ValueError(f"{what}, got shape {a.shape}")
    if len(a) > MAX_CLIP_PLANES:
        raise ValueError(f"at most {MAX_CLIP_PLANES} clip planes, got {len(a)}")
    out = []
    for k, (point, normal) in enumerate(a):
        if not np.all(np.isfinite(a[k])):
            raise ValueError(f"clip plane {k}: point and normal must be finite, got {point.tolist()}, {normal.tolist()}")
        largest = np.abs(normal).max()
        if largest == 0:
            raise ValueError(f"clip plane {k}: the normal must not be zero")
        unit = normal / largest
        unit /= np.linalg.norm(unit)
        out.append((tuple(float(x) for x in point), tuple(float(x) for x in unit)))
    return tuple(out)


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
    """What the core takes: (position, target, up, fov), and for an
    orthographic camera its view height as a fifth number."""
    position, up = camera.get_camera_vectors()
    args = (_vec(position), _vec(camera.target), _vec(up), float(camera.fov))
    if camera.projection == "perspective":
        return args
    if camera.projection != "orthographic":
        raise ValueError(f"projection must be one of perspective, orthographic, got {camera.projection!r}")
    height = camera.orthographic_height
    if not (is_number(height) and 0 < height < np.inf):
        raise ValueError(f"view_height must be a finite number > 0 or None, got {camera.view_height!r}")
    return args + (float(height),)


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
