"""Writing rendered frames to animated GIF or MP4 files.

>>> path = CameraPath.orbit(Camera.isometric_view(), turns=1)
>>> save_animation(renderer.render_path(path, 72, endpoint=False), "orbit.gif", fps=24)

Frames are written as they arrive from the iterable, so a long
``render_path`` streams to MP4 without holding the video in memory (GIF
files are assembled by Pillow when the last frame is in). Needs imageio:
``pip install 'pyvr-rs[animation]'`` (MP4 also needs its ffmpeg plugin,
``imageio-ffmpeg``, which that extra installs).
"""

import os
import tempfile
from pathlib import Path
from typing import Iterable, Union

import numpy as np

from ._extras import require
from ._numbers import check_count, is_number

FORMATS = (".gif", ".mp4")
# A GIF frame's delay is a 16-bit count of hundredths of a second.
MIN_FPS, MAX_FPS = 100.0 / 65535.0, 1000.0


def _opaque(frame: np.ndarray, background: np.ndarray, index: int) -> np.ndarray:
    a = np.asarray(frame)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] not in (3, 4):
        raise ValueError(f"frame {index} must be an (H, W, 3) or (H, W, 4) uint8 array, got {a.dtype} {a.shape}")
    if a.shape[2] == 3:
        return a
    # Straight RGBA over an opaque background: C*A + B*(1 - A).
    alpha = a[..., 3:4].astype(np.float32) / 255.0
    rgb = a[..., :3].astype(np.float32) * alpha + background * (1.0 - alpha)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _even(frame: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Pad to even width and height (H.264 in yuv420p needs both)."""
    h, w = frame.shape[:2]
    if h % 2 == 0 and w % 2 == 0:
        return frame
    out = np.empty((h + h % 2, w + w % 2, 3), np.uint8)
    out[...] = background.astype(np.uint8)
    out[:h, :w] = frame
    return out


def save_animation(frames: Iterable[np.ndarray], path: Union[str, os.PathLike], *, fps: float = 24.0,
                   loop: int = 0, background=(0, 0, 0), quality: int = 8) -> int:
    """Write ``frames`` (uint8 arrays, top row first, all one size: what
    ``VolumeRenderer.render_path`` yields) to ``path``, a ``.gif`` or
    ``.mp4`` file. Transparent pixels are composited over ``background``
    (RGB in [0, 1]). ``fps``: from about 0.0015 (a GIF frame lasts at
    most 655.35 s) to 1000. ``loop``: GIF repeat count (0 = forever, at
    most 65535). ``quality``: MP4 quality from 0 to 10. Returns the number of frames
    written. The file is written under a temporary name and renamed when
    complete, so an interrupted save (Ctrl-C) leaves no partial file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"save_animation writes {', '.join(FORMATS)} files, got {path.name!r}")
    if not is_number(fps):
        raise TypeError(f"fps must be a number, got {type(fps).__name__}")
    if not (np.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
        # A GIF stores each frame's delay in hundredths of a second, in 16 bits.
        raise ValueError(f"fps must be from {MIN_FPS:.4g} to {MAX_FPS:g} frames per second, got {fps!r}")
    check_count("loop", loop, low=0, high=65535)  # a GIF's repeat count is 16 bits
    if not (is_number(quality) and 0 <= quality <= 10):
        raise ValueError(f"quality must be a number from 0 to 10, got {quality!r}")
    bg = np.asarray(background, np.float64).reshape(-1)
    if bg.shape != (3,) or not np.all((bg >= 0) & (bg <= 1)):
        raise ValueError(f"background must be three numbers in [0, 1], got {background!r}")
    bg = (bg * 255.0).astype(np.float32)
    imageio = require("imageio", "animation", "save_animation")
    if suffix == ".mp4":
        require("imageio_ffmpeg", "animation", "MP4 output")
    # A name of its own for every save, so saves to one path from several
    # threads or processes never write into one another's file.
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".partial{suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    n = 0
    shape = None
    try:
        if suffix == ".gif":
            writer = imageio.v3.imopen(tmp, "w", plugin="pillow", extension=".gif")
            write = lambda rgb: writer.write(rgb, duration=1000.0 / fps, loop=loop, is_batch=False)  # noqa: E731
        else:
            writer = imageio.v2.get_writer(tmp, format="FFMPEG", mode="I", fps=float(fps), quality=quality,
                                           macro_block_size=1)
            write = lambda rgb: writer.append_data(_even(rgb, bg))  # noqa: E731
        with writer:
            for frame in frames:
                rgb = _opaque(frame, bg, n)
                if shape is None:
                    shape = rgb.shape
                elif rgb.shape != shape:
                    raise ValueError(f"frame {n} has shape {rgb.shape}, the first had {shape}: frames must match")
                write(rgb)
                n += 1
            if n == 0:
                raise ValueError("save_animation got no frames")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return n
