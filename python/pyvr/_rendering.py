"""``VolumeRenderer``'s frames: render (one frame, or the mean of
several), the float64 oracle's frame, depth, camera paths, and the
warnings a frame's result calls for."""

import warnings
from typing import Iterator, Optional

import numpy as np

from ._extras import require

from . import _core
from ._frames import (
    LONG_FLOAT64_SAMPLES,
    LONG_FRAME_SAMPLES,
    NOTEBOOK_BACKGROUND,
    UNBIASED_MODELS,
    _colour,
    _frame_samples,
    _progress,
    _straight,
    _warn_if_long,
    check_frame_options,
    mean_image,
    output_format,
    output_image,
)
from ._numbers import check_count
from ._opaque import nearer, opaque_scene
from ._scene import _camera_tuple, _check_size, _path_cameras
from ._storage import prepare_normals, prepare_voxels
from ._threads import _serialised
from .camera import Camera
from .config import RenderConfig
from .transferfunctions import ColorTransferFunction, OpacityTransferFunction


class FrameRendering:
    """Methods of VolumeRenderer (pyvr.renderer), which holds the state they use."""

    @_serialised
    def _render_frame(self, size=None, config: Optional[RenderConfig] = None, output=None,
                      sums: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
        """One frame. ``output``: (dtype, premultiplied, background, origin)
        as ``render`` takes them, for the frame as ``render`` returns it,
        each pixel made so as it is rendered (no pass over the image
        after); None: float32 premultiplied, row 0 at the bottom. With
        ``sums`` (float64, (H, W, 4), C-contiguous) the frame's
        premultiplied pixels are added to it instead, and None returned."""
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render()")
        self._ensure_tf()
        cfg = self._config_snapshot if config is None else config
        size = (self.width, self.height) if size is None else size
        # Caller chain: user -> render (or _accumulated -> render) -> _serialised -> here.
        _warn_if_long("this frame", _frame_samples(self._bounds, cfg, *size), LONG_FRAME_SAMPLES, stacklevel=4)
        if (self._engine.width, self._engine.height) != size:
            # Output buffers only; the volume, table and pipelines stay.
            self._engine.resize(*size)
        camera_args = self._frame_camera()
        if self._bricked is not None:
            from .bricks import ghost_for

            b = self._bricked
            need = ghost_for(cfg.step_size, b.bounds, b.shape)
            if need > b.ghost:
                # Longer steps reach further into the neighbours: re-cut.
                b.ghost = need
                self._layout_bricks(b)
            img, stats = b.render(self._engine, camera_args, self._light_args, cfg)
            if sums is not None:
                np.add(sums, img, out=sums)
                img = None
            elif output is not None:
                img = output_image(img, *output)
        elif sums is not None:
            self._pack_gradients_for(cfg)
            img, stats = None, self._engine.accumulate(camera_args, self._light_args, cfg, sums)
        else:
            self._pack_gradients_for(cfg)
            spec = None if output is None else output_format(*output)
            img, stats = self._engine.render(camera_args, self._light_args, cfg, spec)
        self.last_frame_stats = stats
        needed = stats["truncated_needed"]
        if needed:
            key = (cfg.step_size, cfg.max_steps, self._bounds)
            if key not in self._warned:
                self._warned.add(key)
                diag = float(np.linalg.norm(np.subtract(self._bounds[1], self._bounds[0])))
                hint = ""
                if diag > 10.0:
                    # pyvr's presets are sized for boxes about 2-3.5 units across.
                    hint = (
                        f" This volume's box is {diag:.4g} world units across (physical units?) while pyvr's presets "
                        "are made for boxes about 2 units wide: load files with pyvr.load(path), which maps the box "
                        "into [-1, 1] keeping its proportions, or scale step_size with the box "
                        f"(step_size={cfg.step_size * diag / 2 / np.sqrt(3):.3g} keeps this preset's samples per ray)."
                    )
                warnings.warn(
                    f"max_steps={cfg.max_steps} cannot cross the volume at step_size={cfg.step_size}: "
                    f"some rays were cut short; max_steps={needed} would cross it "
                    f"(config.with_max_steps({needed})).{hint}",
                    UserWarning,
                    stacklevel=3,
                )
        return img

    def _ensure_tf(self) -> None:
        if not self._has_tf:
            self.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction())

    def _frame_camera(self) -> tuple:
        """The camera a frame uses: the one set, or a default view of the box."""
        if self._camera_args is None:
            camera = self._default_camera()  # pyvr had no default camera
            self._follow(camera)
            return _camera_tuple(camera)
        return self._camera_args

    def render(self, *, dtype=np.uint8, premultiplied: bool = False, origin: str = "lower",
               background=None, size: Optional[tuple] = None, config: Optional[RenderConfig] = None,
               accumulate: int = 1, depth=None, color=None, slices=None) -> np.ndarray:
        """Render a frame as a C-contiguous (H, W, 4) array.

        dtype: np.uint8 (default) or np.float32. premultiplied: return colour
        multiplied by alpha (default: straight colour). origin: "lower"
        (default, row 0 = bottom, pyvr's order) or "upper" (row 0 = top).
        background: an RGB colour (three numbers in [0, 1], or a name such as
        "white" when matplotlib is installed) to composite the frame over;
        the result is opaque. Default None (or "none"): transparent,
        straight RGBA.
        size: (width, height) to render this frame at instead of the
        renderer's own (the same view, e.g. a cheap preview while a user
        drags); config: a RenderConfig for this frame only. Neither changes
        the renderer's settings.
        accumulate: average this many frames (seeds jitter_seed,
        jitter_seed + 1, ...; premultiplied colour, before any background)
        for progressive refinement. For emission_absorption, absorption and
        emission they are unbiased frames (``config.replace(unbiased=True)``):
        their error falls as 1/sqrt(n) towards the exact integral, whatever
        the step. Pre-integrated configs and the other models average
        jittered frames, whose mean converges to the mean over sample
        offsets instead (docs/rendering.md). It costs n frames; Ctrl-C
        stops it.
        depth, color: an opaque scene drawn by another renderer (meshes,
        slices) that the volume surrounds. ``depth`` (H, W) holds, for each
        pixel, the world distance along its ray (from the camera; for an
        orthographic camera from its plane) to the scene's surface, inf
        where there is none (``pyvr.scene_depth`` converts a rasteriser's
        depth buffer); rows in ``origin``'s order. Each ray stops there, the
        segment it cuts counted with its length. ``color`` (H, W, 3) in
        [0, 1] (or uint8) is the scene's colour: the volume in front is
        composited over it where the depth is finite (opaque there). Without
        ``color`` the frame is the volume in front of the scene alone.
        slices: ``(point, normal)`` planes shown as opaque slices of the
        volume (its colour through the transfer functions, as
        :meth:`render_slice` gives it) inside the box, which the volume is
        composited around; with ``depth``, the nearer surface shows.
        """
        bg = None if background is None else _colour(background)
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        dt = np.dtype(dtype)
        if dt not in (np.dtype(np.uint8), np.dtype(np.float32)):
            raise ValueError(f"dtype must be uint8 or float32, got {dt}")
        size = _check_size(size)
        if config is not None:
            if not isinstance(config, RenderConfig):
                raise TypeError(f"Expected RenderConfig instance, got {type(config)}")
            config.validate()
        n = check_count("accumulate", accumulate, high=1 << 16)
        caps = self._caps and bool(self._planes)
        if depth is not None or color is not None or slices is not None or caps:
            w, h = (self.width, self.height) if size is None else size
            scene = None if depth is None and color is None else opaque_scene(depth, color, w, h, origin)
            if slices is not None:
                scene = nearer(scene, *self._slice_scene(slices, w, h))
            if caps:
                scene = nearer(scene, *self._slice_scene(self._planes, w, h, within=self._planes))
            with self._lock:
                self._engine.set_depth_in(scene.depth32)
                try:
                    img = self._render_frame(size, config) if n == 1 else self._accumulated(size, config, n)
                finally:
                    self._engine.set_depth_in(None)
            return output_image(scene.under(img), dt, premultiplied, bg, origin)
        if n == 1:
            return self._render_frame(size, config, (dt, premultiplied, bg, origin))
        return output_image(self._accumulated(size, config, n), dt, premultiplied, bg, origin)

    def _accumulated(self, size, config: Optional[RenderConfig], n: int) -> np.ndarray:
        """The mean of n premultiplied frames (float64 sums): unbiased ones
        where the model and config allow them, else jittered ones."""
        base = self._config_snapshot if config is None else config
        if base.model in UNBIASED_MODELS and not base.pre_integrated:
            base = base.replace(unbiased=True)
        else:
            base = base.replace(jitter=True)
        w, h = (self.width, self.height) if size is None else size
        # Each frame adds its pixels to the sums as it is made (no image of
        # its own: at 1024x1024 numpy's sums took longer than the frames).
        total = np.zeros((h, w, 4), np.float64)
        # Every frame of the mean from one state: a camera, light, config or
        # transfer function set from another thread waits for the whole mean.
        with self._lock:
            for k in range(n):
                self._render_frame(size, base.replace(jitter_seed=(base.jitter_seed + k) % 2**32), sums=total)
        return mean_image(total, n)

    def render_float64(self, *, config: Optional[RenderConfig] = None, premultiplied: bool = False,
                       origin: str = "lower", order: Optional[str] = None,
                       size: Optional[tuple] = None, adaptive_tolerance: float = 0.0, progress=None,
                       depth=None, color=None) -> np.ndarray:
        """The same frame from the float64 CPU integrator (the engine's oracle).

        Slow (CPU, one thread per core); meant for checking accuracy, e.g.
        against a converged image: ``render_float64(config=RenderConfig(
        step_size=1e-4, max_steps=100000, early_ray_termination=False))``.
        ``config`` defaults to the renderer's; ``order`` ("front_to_back" or
        "back_to_front", equal without early termination) overrides its order.
        Isosurface hit distances are left in ``last_float64_depth`` (row 0 at
        the bottom, inf where none).
        ``size=(width, height)`` renders the same view at another resolution
        (e.g. a coarse pilot of the rays). ``adaptive_tolerance`` > 0 splits
        segments in halves (down to 2^-24 of a step) while the transfer
        function varies across their values by more than it (optical depth
        or emitted colour per piece, at most 4096 pieces a step): steps and
        narrow peaks of the TF are located rather than sampled, for
        converged references.
        ``progress``: a tqdm bar of rows (True), none (False), or by default
        one for frames estimated at more than 2e8 samples when tqdm is
        installed. Ctrl-C stops the work (KeyboardInterrupt).
        ``depth`` and ``color``: an opaque scene, as :meth:`render` takes it.
        """
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render_float64()")
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        cfg = self._config_snapshot if config is None else config
        if not isinstance(cfg, RenderConfig):
            raise TypeError(f"Expected RenderConfig instance, got {type(cfg)}")
        if cfg.unbiased:
            raise ValueError("render_float64 integrates on the step grid; unbiased frames have no float64 "
                             "counterpart: compare their mean with a converged frame of config.replace(unbiased=False)")
        if not self._has_tf:
            self.set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction())
        if self._camera_args is None:
            cam = self._default_camera()
            self._follow(cam)
            camera = _camera_tuple(cam)
        else:
            camera = self._camera_args
        if not (isinstance(adaptive_tolerance, (int, float, np.floating, np.integer))
                and not isinstance(adaptive_tolerance, (bool, np.bool_))):
            raise TypeError(f"adaptive_tolerance must be a number, got {type(adaptive_tolerance).__name__}")
        width, height = (self.width, self.height) if size is None else _check_size(size)
        from ._memory import check_fits

        # The float64 image, depth and per-ray results (about 160 bytes a pixel), and the volume copy.
        check_fits(f"render_float64 at {width}x{height}", 160.0 * width * height + self.volume.data.size * 4.0,
                   "render a smaller size=(width, height)")
        samples = _frame_samples(self._bounds, cfg, width, height) * (8 if adaptive_tolerance > 0 else 1)
        _warn_if_long("render_float64", samples, LONG_FLOAT64_SAMPLES, stacklevel=2)
        scene = None if depth is None and color is None else opaque_scene(depth, color, width, height, origin)
        make_bar = _progress(progress if progress is not None or samples > 2e8 else False, "row", "render_float64")
        bar = None if make_bar is None else make_bar(height)
        try:
            img, _, hits = _core.integrate_reference(
                prepare_voxels(self.volume.data), prepare_normals(self.volume.normals), *self._bounds, self._lut,
                camera, self._light_args, cfg, width, height, order, float(adaptive_tolerance),
                self._value_map, self._crop, list(self._planes), None if scene is None else scene.depth64,
                None if bar is None else (lambda rows: bar.update(rows - bar.n)),
            )
            if bar is not None:
                bar.update(height - bar.n)
        finally:
            if bar is not None:
                bar.close()
        self.last_float64_depth = hits
        if scene is not None:
            img = scene.under(img)
        if not premultiplied:
            img[..., :3] = _straight(img)
        return np.ascontiguousarray(img[::-1]) if origin == "upper" else img

    def config_for_error(self, max_error_levels: float = 1.0, **options) -> RenderConfig:
        """The cheapest config predicted to keep this scene's frame within
        ``max_error_levels`` 8-bit levels of the exact image (see
        :func:`pyvr.accuracy.config_for_error`, which also returns what it
        predicted). Needs the volume, transfer functions and camera set."""
        from .accuracy import config_for_error

        if self.volume is None or not self._has_tf:
            raise RuntimeError("config_for_error needs load_volume() and set_transfer_functions() first")
        return config_for_error(self, max_error_levels, **options)[0]

    @_serialised
    def depth(self, *, origin: str = "lower") -> Optional[np.ndarray]:
        """Distance from the camera to the isosurface along each pixel's ray
        in the last frame (float32 (H, W), inf where the ray hit no surface),
        or None unless that frame used ``model="isosurface"``."""
        if origin not in ("lower", "upper"):
            raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
        d = self._engine.depth()
        if d is None:
            return None
        return np.ascontiguousarray(d[::-1]) if origin == "upper" else d

    def _default_camera(self) -> Camera:
        """With no camera set, a front view that frames the whole volume."""
        return Camera.fit(self.volume, aspect=self.width / self.height)

    def render_path(self, path, n_frames: Optional[int] = None, *, endpoint: bool = True, progress=None,
                    origin: str = "upper", background=None, dtype=np.uint8) -> Iterator[np.ndarray]:
        """Render a camera path frame by frame: a generator of (H, W, 4)
        arrays, so long animations stream (``pyvr.save_animation`` writes
        them to GIF or MP4 as they come).

        path: a ``CameraPath`` (``n_frames`` cameras evenly spaced along it;
        ``endpoint=False`` leaves out the last, for loops) or a sequence of
        ``Camera`` (rendered as given; ``n_frames`` must then be None).
        progress: show a tqdm progress bar; None (default) shows one when
        tqdm is installed. origin defaults to "upper" (row 0 at the top, as
        image and video files store frames); background and dtype are as in
        ``render``. A camera-linked light follows each frame's camera. Each
        frame is rendered under the renderer's lock and its own camera (and
        linked light) restored before the frame is yielded: between frames,
        and to other threads or generators, the renderer is as it was.
        """
        count, cameras = _path_cameras(path, n_frames, endpoint)
        if self.volume is None:
            raise RuntimeError("no volume loaded: call load_volume() before render_path()")
        check_frame_options(origin, background, dtype)
        make_bar = _progress(progress)
        # The checks above run now; the frames when iterated.
        return self._frames(count, cameras, make_bar, dict(origin=origin, background=background, dtype=dtype))

    def _frames(self, count, cameras, make_bar, options):
        bar = None if make_bar is None else make_bar(count)
        try:
            for cam in cameras:
                # Each frame under the lock with the path's camera, the
                # renderer's own restored before the frame is handed out: between
                # frames (and to another generator or thread) the renderer is as
                # the user left it.
                with self._lock:
                    saved = (self.camera, self._camera_args, self.light.position.copy(), self.light.target.copy(),
                             self._light_args)
                    try:
                        self.set_camera(cam)
                        img = self.render(**options)
                    finally:
                        self.camera, self._camera_args = saved[0], saved[1]
                        self.light.position, self.light.target, self._light_args = saved[2], saved[3], saved[4]
                yield img
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()

    def _repr_png_(self) -> Optional[bytes]:
        """Jupyter shows a renderer as its current frame (PNG, top row first)
        over white, as the notebook view shows it; None (text repr) until a
        volume is loaded."""
        if self.volume is None:
            return None
        try:
            from PIL import Image
        except ImportError:
            return None
        import io

        buf = io.BytesIO()
        Image.fromarray(self.render(origin="upper", background=NOTEBOOK_BACKGROUND), "RGBA").save(buf, format="PNG")
        return buf.getvalue()

    def render_to_pil(self, data=None):
        """The frame as a PIL RGBA image, top row at the top (needs Pillow:
        ``pip install 'pyvr-rs[plot]'``)."""
        Image = require("PIL.Image", "plot", "render_to_pil")

        if data is None:
            data = self.render()
        if isinstance(data, np.ndarray):
            data = data.tobytes()
        image = Image.frombytes("RGBA", (self.width, self.height), data)
        return image.transpose(Image.FLIP_TOP_BOTTOM)
