"""An opaque scene that a frame's volume surrounds: the depth where each
pixel's ray stops, and the scene's colour behind the volume."""

from typing import Optional

import numpy as np


class OpaqueScene:
    """A checked depth image and colour, row 0 at the bottom."""

    def __init__(self, depth: np.ndarray, color: Optional[np.ndarray]):
        self.depth64 = depth
        self.depth32 = depth.astype(np.float32)
        self.color = color

    def under(self, img: np.ndarray) -> np.ndarray:
        """Premultiplied ``img`` (H, W, 4) over the scene's colour where it
        has a surface and a colour (opaque there); elsewhere as it was."""
        if self.color is None:
            return img
        out = np.array(img, copy=True)
        surface = np.isfinite(self.depth64) & np.all(np.isfinite(self.color), axis=-1)
        behind = (1.0 - out[..., 3:4]) * self.color
        out[..., :3] = np.where(surface[..., None], out[..., :3] + behind, out[..., :3])
        out[..., 3] = np.where(surface, 1.0, out[..., 3])
        return out


def nearer(scene: Optional[OpaqueScene], depth: np.ndarray, color: np.ndarray) -> OpaqueScene:
    """``scene`` with another opaque surface (``depth``, ``color``, row 0 at
    the bottom) where that is nearer; pixels of a scene given without
    colour keep none (NaN)."""
    if scene is None:
        return OpaqueScene(depth, color)
    mine = scene.color if scene.color is not None else np.full(color.shape, np.nan)
    closer = depth < scene.depth64
    return OpaqueScene(np.where(closer, depth, scene.depth64), np.where(closer[..., None], color, mine))


def opaque_scene(depth, color, width: int, height: int, origin: str) -> OpaqueScene:
    """The scene ``render(depth=, color=)`` describes, checked: ``depth``
    (height, width) distances >= 0 or inf (None: a colour with no depth is
    refused), ``color`` (height, width, 3) in [0, 1] or uint8, rows in
    ``origin``'s order."""
    if depth is None:
        raise ValueError("color needs depth: the distance along each pixel's ray to the scene's surface")
    d = np.asarray(depth)
    if d.dtype == np.bool_ or not np.issubdtype(d.dtype, np.number) or np.iscomplexobj(d):
        raise TypeError(f"depth must be an array of distances, got dtype {d.dtype}")
    if d.shape != (height, width):
        raise ValueError(f"depth must have shape (height, width) = ({height}, {width}), got {d.shape}")
    d = d.astype(np.float64)
    if not np.all(d >= 0):  # NaN fails too
        raise ValueError("depth must hold distances >= 0, inf where the scene has no surface")
    c = None
    if color is not None:
        c = np.asarray(color)
        if c.shape != (height, width, 3):
            raise ValueError(f"color must have shape (height, width, 3) = ({height}, {width}, 3), got {c.shape}")
        if c.dtype == np.uint8:
            c = c / 255.0
        elif np.issubdtype(c.dtype, np.floating):
            c = c.astype(np.float64)
            if not np.all((c >= 0) & (c <= 1)):
                raise ValueError("color must hold values in [0, 1] (or be uint8)")
        else:
            raise TypeError(f"color must be float in [0, 1] or uint8, got dtype {c.dtype}")
    if origin == "upper":
        d = d[::-1]
        c = None if c is None else c[::-1]
    return OpaqueScene(np.ascontiguousarray(d), None if c is None else np.ascontiguousarray(c))
