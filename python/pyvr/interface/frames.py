"""How the matplotlib window turns its state into frames: the cached
frame, the render throttle, cheap frames while the user interacts,
refinement of a still view, and blitting. A part of
InteractiveVolumeRenderer (pyvr.interface.matplotlib_interface)."""

import time
import warnings

import numpy as np


class FramePipeline:
    """Rendering and showing frames; mixed into InteractiveVolumeRenderer,
    whose attributes (renderer, state, widgets, fig) it uses."""

    @property
    def _cheap(self) -> bool:
        return self._native and self._interacting and self.state.auto_quality_enabled

    def _render_volume(self) -> np.ndarray:
        """The frame for the controller's camera, top row first (smaller
        while interacting); the cached frame while nothing changed. On a
        rendering error it warns and returns pyvr's placeholder, a black
        (height, width, 3) frame."""
        if not self.state.needs_render and self._cached_image is not None:
            return self._cached_image
        try:
            self.renderer.set_camera(self.camera_controller.params)
            if self._cheap:
                img = self.drag_quality.render_drag(origin="upper")
            elif self._native:
                img = self.drag_quality.render_full(origin="upper")
            else:
                img = np.array(self.renderer.render_to_pil())
        except Exception as e:  # the window must survive any one bad frame
            warnings.warn(f"Rendering error: {e}", RuntimeWarning, stacklevel=2)
            return np.zeros((self.height, self.width, 3), np.uint8)
        self._cached_image = img
        return img

    def _should_render(self) -> bool:
        """Whether the throttle lets a frame through now (and, if so, starts
        the next interval)."""
        now = time.time()
        if now - self._last_render_time > self._min_render_interval:
            self._last_render_time = now
            return True
        return False

    def _update_display(self, force_render: bool = False) -> None:
        """Bring everything shown up to date with the state: the transfer
        functions, a camera-linked light, the frame (throttled unless
        ``force_render``; a throttled frame is rendered a moment later
        unless another event comes first) and the opacity editor."""
        if self.opacity_editor is not None:
            self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)
        self._refresh_image(force_render)
        if not self._cheap and self._figure_changed():
            self._update_status_display()

    def _refresh_image(self, force_render: bool = False) -> None:
        if self.state.needs_tf_update:
            self._update_transfer_functions()
            self.state.needs_render = True
        self._follow_camera_with_light()
        if not self.state.needs_render:
            return
        if force_render or self._should_render():
            self._show_frame()
        else:
            self._later("pending", max(1, int(self._min_render_interval * 1000)), self._render_pending)

    def _follow_camera_with_light(self) -> None:
        """Move a camera-linked light with the controller's camera (pyvr's
        renderer does so itself in set_camera); a camera that cannot be
        read unlinks the light. A moved camera already asks for a frame."""
        light = self.renderer.get_light()
        if not light.is_linked:
            return
        try:
            camera = self.camera_controller.params
            if not self._native:
                light.update_from_camera(camera)
                self.renderer.set_light(light)
        except Exception as e:
            print(f"Warning: Failed to update linked light: {e}")
            light.unlink_from_camera()  # one failure, not one per frame
            self.state.light_linked_to_camera = False

    def _show_frame(self) -> None:
        cheap = self._cheap
        img = self._render_volume()
        self._last_render_time = time.time()
        self.state.needs_render = False
        if self.image_display is None:
            return
        self.image_display.redraw_on_update = False  # drawn below: blitted while cheap
        self.image_display.update_image(img)
        if not cheap and self._figure_changed():
            self._update_status_display()  # the editor or the info panel changed too
        else:
            self._blit(self.image_display)  # only the image changed
        if cheap:
            self.refinement.stop()
        else:
            if self.refinement is not None:
                self.refinement.restart()
                self._refine_later()
        if self._event_time is not None:
            latency = time.perf_counter() - self._event_time
            if cheap:
                self.drag_latencies.append(latency)
                self.drag_quality.record(latency)
            else:
                self.release_latencies.append(latency)
            self._event_time = None

    def _later(self, name: str, interval_ms: int, callback) -> None:
        """(Re)start the single-shot timer ``name`` (none before the figure)."""
        if self.fig is None:
            return
        timer = self._timers.get(name)
        if timer is None:
            timer = self._timers[name] = self.fig.canvas.new_timer(interval=interval_ms)
            timer.single_shot = True
            timer.add_callback(callback)
        timer.stop()
        timer.start()

    def _render_pending(self) -> None:
        if self.state.needs_render:
            self._update_display(force_render=True)

    def _refine_later(self) -> None:
        if self.refinement.pending:
            # Between frames the event loop runs: any event is handled first.
            self._later("refine", 1, self._refine_step)

    def _refine_step(self) -> None:
        """One more unbiased frame into the still view's running mean."""
        if self._interacting or self.refinement is None or not self.refinement.pending:
            return
        try:
            img = self.refinement.step()
        except Exception as e:  # the window must survive any one bad frame
            warnings.warn(f"Rendering error: {e}", RuntimeWarning, stacklevel=2)
            self.refinement.stop()
            return
        if img is not None and self.image_display is not None:
            self._cached_image = img
            self.image_display.update_image(img)
            self._blit(self.image_display)
        self._refine_later()

    def _figure_key(self) -> tuple:
        """What the figure shows besides the image: the info panel and the
        opacity editor's points."""
        return (self._get_full_info_text(), tuple(self.state.control_points), self.state.selected_control_point)

    def _figure_changed(self) -> bool:
        """Whether the figure around the image differs from its last full
        drawing (then it needs one; else blitting the image is enough)."""
        return self._figure_key() != self._drawn_key

    def _blit(self, widget) -> None:
        """Redraw only ``widget``'s axes (a full figure redraw costs more than
        a cheap frame); a full redraw before the first one."""
        if self.fig is None:
            return
        canvas = self.fig.canvas
        if not getattr(canvas, "supports_blit", False) or not self._drawn:
            canvas.draw_idle()
            return
        for artist in widget.artists():
            widget.ax.draw_artist(artist)
        canvas.blit(widget.ax.bbox)

    def _switch_to_interaction_quality(self) -> None:
        """An interaction begins: cheap frames until it ends."""
        if not self._interacting:
            self._interacting = True
            if self.drag_quality is not None:
                self.drag_quality.start()

    def _restore_quality_after_interaction(self) -> None:
        """The interaction ended: one frame at the renderer's own quality."""
        self._interacting = False
        self.state.needs_render = True
        self._update_display(force_render=True)
