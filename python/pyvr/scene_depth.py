"""Depth images for ``render(depth=, color=)`` from other renderers.

pyvr's depth is the world distance along each pixel's ray, from the camera
(perspective) or from the camera's plane (orthographic), infinity where the
opaque scene has no surface; rows in the order ``render``'s ``origin``
says. A rasteriser (OpenGL, moderngl, VTK, pygfx) stores instead a
non-linear value per pixel from its projection matrix: give it the same
camera (:meth:`pyvr.camera.Camera.get_view_matrix` and
:meth:`~pyvr.camera.Camera.get_projection_matrix` with its near and far
planes) and convert its depth buffer with :func:`from_depth_buffer`.
"""

import numpy as np

from .camera import Camera

CONVENTIONS = ("window", "ndc")


def _checked(name: str, image, camera, near, far, convention: str, origin: str) -> np.ndarray:
    """``image`` as float64 (H, W), the other arguments checked."""
    if convention not in CONVENTIONS:
        raise ValueError(f"convention must be one of {', '.join(CONVENTIONS)}, got {convention!r}")
    if origin not in ("lower", "upper"):
        raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
    if not isinstance(camera, Camera):
        raise TypeError(f"Expected Camera instance, got {type(camera)}")
    if not (0 < near < far < np.inf):
        raise ValueError(f"need 0 < near < far, finite; got near={near!r}, far={far!r}")
    a = np.asarray(image, np.float64)
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"{name} must be a 2-D image, got shape {a.shape}")
    return a


def from_depth_buffer(buffer, camera: Camera, near: float, far: float, *, convention: str = "window",
                      origin: str = "lower") -> np.ndarray:
    """Distances along pyvr's rays from a rasteriser's depth buffer.

    ``buffer`` (H, W): ``"window"`` depth in [0, 1] as OpenGL's default
    depth range stores it (``glReadPixels(..., GL_DEPTH_COMPONENT)``,
    moderngl's ``Framebuffer.read(attachment=-1)``), or ``"ndc"`` depth in
    [-1, 1]. ``near`` and ``far`` are the planes its projection matrix was
    made with; for ``camera``'s projection (perspective from ``fov``, or
    orthographic over ``orthographic_height``) and the buffer's aspect
    ratio. Pixels at the far plane or beyond (the cleared value) get inf.
    ``origin``: the buffer's row order, "lower" (row 0 at the bottom, as
    OpenGL reads it) or "upper"; the result has the same.
    """
    z = _checked("buffer", buffer, camera, near, far, convention, origin)
    ndc = 2.0 * z - 1.0 if convention == "window" else z
    n, f = float(near), float(far)
    h, w = z.shape
    if camera.projection == "orthographic":
        # Linear in depth: the distance from the camera's plane itself.
        distance = 0.5 * ((f - n) * ndc + (f + n))
    else:
        eye_z = 2.0 * n * f / ((f + n) - ndc * (f - n))
        # The pixel's ray leaves the view axis at its centre's angle.
        t = np.tan(0.5 * camera.fov)
        x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * (w / h) * t
        y = (2.0 * (np.arange(h) + 0.5) / h - 1.0) * t
        if origin == "upper":
            y = y[::-1]
        distance = eye_z * np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)
    return np.where(ndc >= 1.0, np.inf, distance)


def to_depth_buffer(distance, camera: Camera, near: float, far: float, *, convention: str = "window",
                    origin: str = "lower") -> np.ndarray:
    """The inverse of :func:`from_depth_buffer`: distances along pyvr's
    rays (e.g. :meth:`pyvr.renderer.VolumeRenderer.depth_image`) as a
    rasteriser's depth buffer for ``camera``'s projection with ``near`` and
    ``far``, so that meshes drawn afterwards are depth-tested against the
    volume. Distances past ``far`` (and inf) give the far plane's value."""
    s = _checked("distance", distance, camera, near, far, convention, origin)
    n, f = float(near), float(far)
    h, w = s.shape
    if camera.projection == "orthographic":
        eye_z = s
        ndc = (2.0 * eye_z - (f + n)) / (f - n)
    else:
        t = np.tan(0.5 * camera.fov)
        x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * (w / h) * t
        y = (2.0 * (np.arange(h) + 0.5) / h - 1.0) * t
        if origin == "upper":
            y = y[::-1]
        eye_z = s / np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)
        with np.errstate(divide="ignore"):
            ndc = ((f + n) - 2.0 * n * f / eye_z) / (f - n)
    ndc = np.clip(np.where(np.isfinite(ndc), ndc, 1.0), -1.0, 1.0)
    return (0.5 * (ndc + 1.0) if convention == "window" else ndc).astype(np.float32)
