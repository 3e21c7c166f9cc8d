"""An interactive view of a VolumeRenderer in Jupyter.

>>> from pyvr.notebook import VolumeView
>>> VolumeView(renderer)          # last expression of a cell: shows the view

Drag with the left button to rotate (trackball), scroll to zoom, press
``o`` to switch to parallel rays and back: the wheel and the keys work
once the view has the keyboard focus (click it first); until then
the browser scrolls the page, as it does over any picture. While the
mouse drags or the wheel turns, frames are rendered cheaper (see
``pyvr.interaction.DragQuality``) and full quality returns on release, or
0.5 s after the last scroll. The view is a ``jupyter_rfb.RemoteFrameBuffer``
(an ipywidgets widget): ``pip install 'pyvr-rs[notebook]'``.

With ``refine_frames=n`` the view refines itself while it stands still:
after the full frame it renders unbiased frames (``RenderConfig.unbiased``)
one per draw and, from the fourth on, shows their running mean, which
converges to the exact integral (the same image as
``renderer.render(accumulate=k)``), until n frames; any interaction or
change of the scene starts over. Off by default: it keeps the machine busy
for n more frames after every interaction, and on smooth scenes the first
means are noisier than the midpoint frame they replace (docs/rendering.md).

Frames are shown over ``background`` (white by default, as the renderer's
still image): jupyter_rfb sends frames to the browser without their alpha.

Without a live notebook frontend (nbconvert, a script) nothing is drawn by
itself; ``view.draw()`` renders a frame now and ``view.snapshot()`` shows it.
A plain renderer also shows itself as a still image (``_repr_png_``).
"""

import time
from collections import deque
from typing import Optional

import numpy as np

from ._extras import require

require("jupyter_rfb", "notebook", "pyvr.notebook")

from jupyter_rfb import RemoteFrameBuffer  # noqa: E402

from ._frames import NOTEBOOK_BACKGROUND, _colour  # noqa: E402
from .camera import Camera, CameraController  # noqa: E402
from .interaction import DragQuality  # noqa: E402
from .refinement import Refinement  # noqa: E402
from .renderer import VolumeRenderer  # noqa: E402

SCROLL_SETTLE_SECONDS = 0.5


class VolumeView(RemoteFrameBuffer):
    """A notebook widget showing ``renderer``'s frames, turned and zoomed
    with the mouse. The renderer's volume, transfer functions, config and
    light are used as they are; the view keeps its own camera
    (``view.camera``), starting from the renderer's (or a framing one).
    ``background``: the colour frames are composited over (a name or RGB in
    [0, 1]), the same as the renderer's still image by default.
    """

    # Set once jupyter_rfb's __init__ has run (`close`).
    _built = False

    def __new__(cls, renderer=None, camera=None, **kwargs):
        # Checked before the widget exists.
        if not isinstance(renderer, VolumeRenderer):
            raise TypeError(f"Expected VolumeRenderer instance, got {type(renderer)}")
        if renderer.get_volume() is None:
            raise RuntimeError("no volume loaded: call renderer.load_volume() before making a view")
        if camera is not None and not isinstance(camera, Camera):
            raise TypeError(f"Expected Camera instance, got {type(camera)}")
        return super().__new__(cls)

    def __init__(self, renderer: VolumeRenderer, camera: Optional[Camera] = None, *, target_fps: float = 10.0,
                 refine_frames: int = 0, background=NOTEBOOK_BACKGROUND, **kwargs):
        # Checked before the widget opens its channel to the notebook.
        if background is None or _colour(background) is None:
            raise ValueError(f"background={background!r}: the view's frames reach the browser without alpha; "
                             "give a colour (a name or (r, g, b) in [0, 1])")
        refinement = Refinement(renderer, refine_frames, background=background)
        drag_quality = DragQuality(renderer, target_fps=target_fps)
        kwargs.setdefault("css_width", f"{renderer.width}px")
        kwargs.setdefault("css_height", f"{renderer.height}px")
        super().__init__(**kwargs)
        self._built = True
        start = camera or renderer.get_camera() or Camera.fit(renderer.get_volume(),
                                                              aspect=renderer.width / renderer.height)
        self.renderer = renderer
        self.controller = CameraController(start)
        self.drag_quality = drag_quality
        self._dragging = False
        self._last_pos = None
        self._interacting = False
        self._event_time: Optional[float] = None
        self._settle = None
        self._view_size = (float(renderer.width), float(renderer.height))
        # Event-to-pixels seconds of the latest frames while interacting and after.
        self.drag_latencies: deque = deque(maxlen=200)
        self.release_latencies: deque = deque(maxlen=200)
        self.refinement = refinement
        self.background = background
        self._last_frame: Optional[np.ndarray] = None

    def close(self, *args, **kwargs) -> None:
        """Close the widget (also one whose construction failed part-way)."""
        if self._built:
            super().close(*args, **kwargs)
        else:
            # A widget whose __init__ stopped early (a bad argument) is closed
            # when collected: jupyter_rfb's close would then send a close
            # event through state its __init__ never made, and raise after
            # the error the user was shown. The widget's own close is enough.
            super(RemoteFrameBuffer, self).close(*args, **kwargs)

    @property
    def camera(self) -> Camera:
        """The view's camera (the controller's; changes show on the next frame)."""
        return self.controller.params

    # -- events ------------------------------------------------------------
    def handle_event(self, event: dict) -> None:
        """jupyter_rfb's event callback: pointer drags turn the camera, the wheel
        zooms, the ``o`` key switches between perspective and orthographic
        projection, a double-click turns the view about the point under it,
        resizes rescale the drag."""
        kind = event.get("type", event.get("event_type"))
        if kind == "pointer_down" and event.get("button", 1) == 1:
            self._event_time = time.perf_counter()
            self._dragging = True
            self._last_pos = (float(event["x"]), float(event["y"]))
            self._begin()
        elif kind == "pointer_move" and self._dragging:
            self._event_time = time.perf_counter()
            x, y = float(event["x"]), float(event["y"])
            x0, y0 = self._last_pos
            # Browser y grows downward, as the trackball expects; positions
            # are in the view's logical pixels, whatever size it is shown at.
            self.controller.trackball(x - x0, y - y0, *self._view_size)
            self._last_pos = (x, y)
            self.request_draw()
        elif kind == "pointer_up" and self._dragging:
            self._event_time = time.perf_counter()
            self._dragging = False
            self._end()
        elif kind == "wheel":
            self._event_time = time.perf_counter()
            dy = float(event.get("dy", 0.0))
            if dy:
                self.controller.zoom(1.1 if dy > 0 else 0.9)
                self._begin()
                self.request_draw()
                self._settle_later()
        elif kind == "double_click" and event.get("button", 1) == 1:
            self._centre_on(float(event["x"]), float(event["y"]))
        elif kind == "key_down" and event.get("key") == "o":
            # Orthographic / perspective, as the window's o key; the view's
            # height follows the distance, so the target keeps its size.
            self._event_time = time.perf_counter()
            cam = self.controller.params
            cam.projection = "perspective" if cam.projection == "orthographic" else "orthographic"
            cam.view_height = None
            self.request_draw()
        elif kind == "resize":
            if event.get("width", 0) > 0 and event.get("height", 0) > 0:
                self._view_size = (float(event["width"]), float(event["height"]))
            self.request_draw()

    def _centre_on(self, x: float, y: float) -> None:
        """Turn about the point the view shows at (x, y) (logical pixels,
        y down, as the browser gives them) from now on: the view moves so
        that it is in the middle, looking the same way."""
        w, h = self._view_size
        col = min(max(int(x / w * self.renderer.width), 0), self.renderer.width - 1)
        row = min(max(int((1.0 - y / h) * self.renderer.height), 0), self.renderer.height - 1)
        if self.renderer._bricked is not None:  # a pick would read the whole volume
            return
        self.renderer.set_camera(self.controller.params)  # the view's camera, drawn or not yet
        picked = self.renderer.pick(col, row)
        if not bool(picked.hit):
            return
        cam = self.controller.params
        shift = np.asarray(picked.position, np.float64) - np.asarray(cam.target, np.float64)
        cam.init_pos = (np.asarray(cam.init_pos, np.float64) + shift).astype(np.float32)
        cam.target = np.asarray(picked.position, np.float32)
        self.request_draw()

    def _begin(self) -> None:
        if not self._interacting:
            self._interacting = True
            self.drag_quality.start()

    def _end(self) -> None:
        self._interacting = False
        self.request_draw()

    def _settle_later(self) -> None:
        import asyncio

        if self._settle is not None:
            self._settle.cancel()
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return
        self._settle = loop.call_later(SCROLL_SETTLE_SECONDS, self._scroll_settled)

    def _scroll_settled(self) -> None:
        self._settle = None
        if not self._dragging:
            self._event_time = time.perf_counter()
            self._end()

    # -- frames ------------------------------------------------------------
    def get_frame(self) -> Optional[np.ndarray]:
        """The frame for the view's camera: (H, W, 4) uint8, top row first,
        smaller while the user interacts (the browser stretches it); while
        refining, the running mean, or None when there is nothing new."""
        self.renderer.set_camera(self.controller.params)
        cheap = self._interacting
        if cheap:
            self.refinement.stop()
            img = self.drag_quality.render_drag(origin="upper", background=self.background)
        elif self.refinement.pending:
            img = self.refinement.step()
            if self.refinement.pending:
                self.request_draw()
            return img
        elif self.refinement.finished:
            return None  # refined as far as asked: nothing new to show
        else:
            img = self.drag_quality.render_full(origin="upper", background=self.background)
            self.refinement.restart()
            if self.refinement.pending:
                self.request_draw()
        if self._event_time is not None:
            latency = time.perf_counter() - self._event_time
            (self.drag_latencies if cheap else self.release_latencies).append(latency)
            if cheap:
                self.drag_quality.record(latency)
            self._event_time = None
        return img

    def draw(self) -> np.ndarray:
        """Render a frame now and send it to the view; returns what the view
        shows (the last frame when refinement has nothing new)."""
        img = self.get_frame()
        if img is None:
            return self._last_frame
        self.send_frame(img)
        self._last_frame = img
        return img
