"""Sort-last rendering on a dask.distributed cluster (``pip install
'pyvr-rs[distributed]'``).

:func:`render` cuts a volume whose data is a dask array (or a zarr array, a
memmap, any array pyvr.bricks reads) into bricks and renders each brick on a
worker, next to its chunks, as a *partial image*: per pixel, the brick's
premultiplied colour and optical depth (a projection's running value, an
isosurface's nearest hit) over exactly the segments of the global ray grid
that fall inside it. Partial images combine with the ``over`` operator in
front-to-back brick order (the order is the same for every pixel, see
src/bricks.rs), and ``over`` is associative, so they are reduced pairwise in
a tree of tasks on the cluster: no process ever holds more than two partial
images and one brick. Dask schedules, moves data and retries the tasks of a
lost worker; pyvr adds no scheduler of its own.

The image equals the single-machine render (within float rounding) except
for early ray termination, which each brick applies on its own ray pieces:
a ray that would stop in a front brick still has its back bricks rendered,
so the composite holds slightly more of what lies behind (at most
``1 - opacity_threshold`` of the colour; with early_ray_termination=False
the two are the same).

:func:`render_path` farms the frames of a camera path out instead, one task
per frame, each on a whole in-memory volume scattered to the workers once.
"""

from __future__ import annotations

import os
from typing import Any, List, Optional

import numpy as np

from ._extras import require
from .transferfunctions.value_range import lut_at

#: One renderer per worker process and image size, kept between tasks.
_RENDERERS: dict = {}


def _client(client):
    distributed = require("distributed", "distributed", "pyvr.distributed")
    if client is not None:
        return client
    try:
        return distributed.get_client()
    except ValueError as e:
        raise ValueError(
            "no dask.distributed client: pass client=, or create one first "
            "(from dask.distributed import Client; client = Client())"
        ) from e


def _worker_renderer(width: int, height: int):
    from . import _core
    from ._scene import _runtime_dir

    key = (os.getpid(), width, height)
    if key not in _RENDERERS:
        _runtime_dir()
        _RENDERERS[key] = _core.Renderer(width, height)
    return _RENDERERS[key]


def _kind(cfg) -> str:
    from ._frames import MODEL_ABILITIES

    return MODEL_ABILITIES[cfg.model]["reduction"]


def _render_brick(spec: dict, index: int, block, normals) -> np.ndarray:
    """On a worker: brick ``index``'s partial image, (H, W, 5) float32: the
    rays' states (see pyvr._core.Renderer.end_bricks) and, for the
    isosurface, the hit distance."""
    from ._storage import prepare_normals, prepare_voxels

    r = _worker_renderer(spec["width"], spec["height"])
    r.skip_empty = spec["skip_empty"]
    # Arrays out of dask's buffers may be unaligned, which the core refuses.
    r.set_lut(np.require(spec["lut"], np.float32, ["C", "A"]))
    r.set_value_map(*spec["value_map"])
    r.set_clip(spec["clip"])
    r.set_clip_planes(list(spec["planes"]))
    r.set_brick_layout(spec["dims"], *spec["bounds"], spec["core"], spec["ghost"])
    r.set_brick(index, prepare_voxels(np.asarray(block)),
                None if normals is None else prepare_normals(np.asarray(normals)), spec["precision"])
    order = r.begin_bricks(spec["camera"], spec["light"], spec["config"], True)
    if index in order:
        r.render_brick(index)
    img, _ = r.end_bricks()
    out = np.zeros(img.shape[:2] + (5,), np.float32)
    out[..., :4] = img
    if _kind(spec["config"]) == "iso":
        depth = r.depth()
        out[..., 4] = np.inf if depth is None else depth
    r.evict_brick(index)
    return out


def combine(front: np.ndarray, back: np.ndarray, kind: str) -> np.ndarray:
    """Two partial images, ``front`` nearer the eye on every ray, as one."""
    out = np.empty_like(front)
    if kind == "integrate":
        tf, tb = front[..., 3:4], back[..., 3:4]
        out[..., :3] = front[..., :3] + np.exp(-tf) * back[..., :3]
        out[..., 3:4] = tf + tb
        out[..., 4] = 0
    elif kind in ("max", "min"):
        af, ab = front[..., 1] > 0, back[..., 1] > 0
        pick = np.maximum if kind == "max" else np.minimum
        best = np.where(af & ab, pick(front[..., 0], back[..., 0]), np.where(af, front[..., 0], back[..., 0]))
        out[...] = 0
        out[..., 0] = best
        out[..., 1] = (af | ab).astype(np.float32)
    elif kind == "average":
        out[...] = front + back
    else:
        hit = np.isfinite(front[..., 4:5])
        out[...] = np.where(hit, front, back)
    return out


def finish(partial: np.ndarray, kind: str, lut: np.ndarray, model: str) -> np.ndarray:
    """A whole ray's state as the shader finishes it: premultiplied RGBA."""
    out = np.zeros(partial.shape[:2] + (4,), np.float32)
    if kind == "integrate":
        out[..., :3] = partial[..., :3]
        if model != "emission":
            out[..., 3] = -np.expm1(-partial[..., 3].astype(np.float64))
    elif kind == "iso":
        out[...] = partial[..., :4]
    else:
        seen = partial[..., 1] > 0
        v = partial[..., 0] / np.where(seen, partial[..., 1], 1) if kind == "average" else partial[..., 0]
        c = lut_at(lut, v)
        out[..., :3] = c[..., :3] * c[..., 3:4]
        out[..., 3] = c[..., 3]
        out[~seen] = 0
    return out


def _scene(renderer, volume) -> dict:
    """What a worker needs of ``renderer`` and ``volume``."""
    from . import bricks
    from ._scene import _vec
    from ._storage import _value_map_for, device_limits

    renderer._ensure_tf()
    cfg = renderer._config_snapshot
    if cfg.model == "single_scattering":
        raise ValueError("the single_scattering model's shadow rays cross the whole volume, which no worker holds: "
                         "use another model")
    bounds = (_vec(volume.min_bounds), _vec(volume.max_bounds))
    shape = tuple(int(v) for v in volume.data.shape)
    ghost = bricks.ghost_for(cfg.step_size, bounds, shape)
    requested = renderer._brick_shape
    if requested is None:
        # Bricks on the array's own chunks when they are regular: each task
        # then reads its chunk and only the ghost slabs of its neighbours.
        requested = _regular_chunks(volume.data)
    core = bricks.brick_shape_for(shape, ghost, device_limits()["max_texture_dimension_3d"], requested)
    return {
        "width": renderer.width, "height": renderer.height, "lut": renderer._lut,
        # This volume's, whatever the renderer has loaded (often nothing): the
        # transfer functions' value range, else the volume's own.
        "value_map": _value_map_for(renderer._tf_value_range or volume.value_range, volume.data.dtype),
        "clip": renderer._crop, "planes": renderer.clip_planes, "skip_empty": renderer.empty_space_skipping, "dims": shape, "bounds": bounds,
        "core": core, "ghost": ghost, "precision": renderer._precision, "camera": renderer._frame_camera(),
        "light": renderer._light_args, "config": cfg,
    }


def _regular_chunks(data) -> Optional[tuple]:
    """A dask array's chunk shape when all its chunks but the last along each
    axis have it, and it is not tiny; None otherwise."""
    chunks = getattr(data, "chunks", None)
    if type(data).__module__.split(".")[0] == "xarray":
        chunks = getattr(data.data, "chunks", None)
    if not chunks or not isinstance(chunks[0], tuple) or len(chunks) != 3:
        return None
    shape = tuple(c[0] for c in chunks)
    if any(len(set(c[:-1])) > 1 or c[-1] > c[0] for c in chunks) or min(shape) < 32:
        return None
    return shape


def _padded_blocks(arr, core, ghost, extra_axis: bool):
    """The array cut on the brick cores, each block with ``ghost`` voxels of
    its neighbours (none past the volume's faces), as dask's overlap builds
    them: every chunk is read once and its edge slabs shared. Returns the
    blocks' delayed values in brick order (axis 2 fastest)."""
    da = require("dask.array", "distributed", "pyvr.distributed")
    chunks = tuple(core) + ((3,) if extra_axis else ())
    arr = arr.rechunk(chunks)
    depth = {0: ghost, 1: ghost, 2: ghost}
    if extra_axis:
        depth[3] = 0
    if ghost > 0 and min(min(c) for c in arr.chunks[:3]) >= ghost:
        arr = da.overlap.overlap(arr, depth=depth, boundary="none")
        return list(arr.to_delayed().reshape(-1))
    return None


def _as_dask(data, chunks):
    da = require("dask.array", "distributed", "pyvr.distributed")
    if type(data).__module__.split(".")[0] == "xarray":
        data = data.data
    if isinstance(data, da.Array):
        return data
    return da.from_array(data, chunks=chunks)


def _check_renderer(renderer) -> None:
    """The cluster path reads the renderer's tables and state, which only
    pyvr's own renderer has."""
    from .renderer import VolumeRenderer

    if not isinstance(renderer, VolumeRenderer):
        raise TypeError(f"Expected VolumeRenderer instance (pyvr.VolumeRenderer or a subclass), got {type(renderer)}")


def render(renderer, volume, client=None, *, dtype=np.uint8, premultiplied: bool = False) -> np.ndarray:
    """Renders ``volume`` with ``renderer``'s camera, light, transfer
    functions and config on a dask.distributed cluster (``client``, or the
    default one): one task per brick (cores of the renderer's brick_shape,
    default 256^3), partial images reduced in a tree of ``combine`` tasks.
    Returns the image as ``renderer.render(dtype=..., premultiplied=...)``
    does: (H, W, 4), row 0 at the bottom."""
    from . import bricks
    from .volume import Volume

    _check_renderer(renderer)
    client = _client(client)
    if not isinstance(volume, Volume):
        volume = bricks.as_volume(volume)
    if np.dtype(dtype) not in (np.dtype(np.uint8), np.dtype(np.float32)):
        raise ValueError(f"dtype must be uint8 or float32, got {np.dtype(dtype)}")
    img = client.compute(_graph(renderer, volume)).result()
    return _output(img, dtype, premultiplied)


def _graph(renderer, volume):
    """The delayed premultiplied image of ``volume`` through ``renderer``."""
    from . import _core

    dask = require("dask", "distributed", "pyvr.distributed")
    spec = _scene(renderer, volume)
    kind = _kind(spec["config"])
    data = _as_dask(volume.data, spec["core"])
    normals = None if volume.normals is None else _as_dask(volume.normals, spec["core"] + (3,))
    lo, hi = (np.asarray(b, np.float64) for b in spec["bounds"])
    eye = (np.asarray(spec["camera"][0]) - lo) / (hi - lo) * np.asarray(spec["dims"])
    ranges, order = _core.brick_layout(spec["dims"], spec["core"], spec["ghost"], tuple(float(v) for v in eye))
    delayed = dask.delayed
    spec_d = delayed(spec, pure=False)
    blocks = _padded_blocks(data, spec["core"], spec["ghost"], False)
    nblocks = None if normals is None else _padded_blocks(normals, spec["core"], spec["ghost"], True)
    parts: List[Any] = []
    for i in order:
        sl = tuple(slice(lo, hi) for lo, hi in ranges[i])
        # Dask's overlapped blocks where it could make them, slices otherwise
        # (a chunk thinner than the ghosts).
        block = data[sl] if blocks is None else blocks[i]
        nb = None if normals is None else (normals[sl] if nblocks is None else nblocks[i])
        parts.append(delayed(_render_brick, pure=False)(spec_d, i, block, nb))
    while len(parts) > 1:
        parts = [delayed(combine, pure=False)(parts[k], parts[k + 1], kind) if k + 1 < len(parts) else parts[k]
                 for k in range(0, len(parts), 2)]
    return delayed(finish, pure=False)(parts[0], kind, spec["lut"], spec["config"].model)


def _output(img: np.ndarray, dtype, premultiplied: bool) -> np.ndarray:
    from ._frames import output_image

    # What comes back from the cluster may be read-only or unaligned.
    img = np.require(img, np.float32, ["C", "A", "W"])
    return output_image(img, np.dtype(dtype), premultiplied, None, "lower")


def _render_frame(volume, state: dict, camera, options: dict) -> np.ndarray:
    """On a worker: one frame of a path, as ``render(**options)`` returns it."""
    from .renderer import VolumeRenderer

    key = (os.getpid(), "path", state["token"])
    r = _RENDERERS.get(key)
    if r is None:
        for k in [k for k in _RENDERERS if k[1] == "path"]:
            del _RENDERERS[k]
        r = VolumeRenderer(state["width"], state["height"], config=state["config"], light=state["light"])
        r.load_volume(volume, precision=state["precision"])
        _RENDERERS[key] = r
    # The volume is kept between paths; the rest is this path's, each time
    # (a later path may change the transfer functions, the config or the cuts).
    r.set_config(state["config"])
    r.set_light(state["light"])
    if r._lut is None or not np.array_equal(r._lut, state["lut"]):  # a new table rebuilds the empty cells
        r._lut, r._has_tf = state["lut"], True
        r._engine.set_lut(state["lut"])
    r._tf_value_range = state["tf_value_range"]
    r._update_value_map()
    r.set_crop_box(*(state["crop"] or (None, None)))
    r.set_clip_planes(state["planes"])
    r.set_camera(camera)  # a camera-linked light follows, as in render_path
    return r.render(**options)


def render_path(renderer, path, n_frames: Optional[int] = None, client=None, *, endpoint: bool = True,
                origin: str = "upper", background=None, dtype=np.uint8) -> List[np.ndarray]:
    """The frames of a CameraPath (or a list of Cameras) rendered one task
    per frame on the cluster, with ``renderer``'s volume (scattered to the
    workers once), transfer functions, light and config. Returns the frames
    in order, as ``renderer.render_path`` yields them (origin "upper" by
    default; origin, background and dtype as there)."""
    from ._frames import check_frame_options
    from ._scene import _path_cameras

    _check_renderer(renderer)
    client = _client(client)
    if renderer.volume is None:
        raise RuntimeError("no volume loaded: call load_volume() before render_path()")
    check_frame_options(origin, background, dtype)
    renderer._ensure_tf()
    _, cameras = _path_cameras(path, n_frames, endpoint)
    volume = client.scatter(renderer.volume, broadcast=True)
    state = {
        "token": id(renderer.volume), "width": renderer.width, "height": renderer.height,
        "config": renderer._config_snapshot, "light": renderer.get_light(), "precision": renderer._precision,
        "lut": renderer._lut, "tf_value_range": renderer._tf_value_range, "crop": renderer.crop_box,
        "planes": renderer.clip_planes,
    }
    options = {"origin": origin, "background": background, "dtype": dtype}
    futures = [client.submit(_render_frame, volume, state, c, options, pure=False) for c in cameras]
    return client.gather(futures)
