"""What the matplotlib window does on each mouse, scroll and key event.
A part of InteractiveVolumeRenderer (pyvr.interface.matplotlib_interface);
the handler names are pyvr 0.4.1's."""

import time
from typing import Optional

import numpy as np
from matplotlib.backend_tools import Cursors

from .framing import _home_camera


class EventHandlers:
    """Event handlers; mixed into InteractiveVolumeRenderer, whose state,
    widgets and frame pipeline they drive."""

    def _in(self, widget, event) -> bool:
        return widget is not None and event.inaxes is not None and event.inaxes == widget.ax

    def _picked_under(self, event):
        """What the image shows under the mouse (``VolumeRenderer.pick``),
        or None off the image, where nothing is shown, or for volumes not
        held in memory (a pick there would read the whole volume)."""
        if not self._in(self.image_display, event) or event.xdata is None or event.ydata is None:
            return None
        if getattr(self.renderer, "_bricked", None) is not None or not hasattr(self.renderer, "pick"):
            return None
        col = min(max(int(event.xdata), 0), self.width - 1)
        row = min(max(int(event.ydata), 0), self.height - 1)  # the image's y grows upward, as rows from the bottom
        picked = self.renderer.pick(col, row)
        return picked if bool(picked.hit) else None

    def _show_value_under(self, event) -> None:
        """The value and voxel under the mouse, below the image."""
        picked = self._picked_under(event)
        text = "" if picked is None else (f"value {float(picked.value):.4g} at voxel {tuple(int(i) for i in picked.index)}")
        if self.image_display is not None and self.image_display.ax.get_xlabel() != text:
            self.image_display.ax.set_xlabel(text, fontsize=9)
            self.fig.canvas.draw_idle()

    def _centre_on(self, event) -> None:
        """Turn about the point under a double-click from now on."""
        picked = self._picked_under(event)
        if picked is None:
            return
        # The view moves with its centre (init_pos is absolute): the same
        # direction, the point in the middle.
        cam = self.camera_controller.params
        shift = np.asarray(picked.position, np.float64) - np.asarray(cam.target, np.float64)
        cam.init_pos = (np.asarray(cam.init_pos, np.float64) + shift).astype(np.float32)
        self.camera_controller.look_at(np.asarray(picked.position, np.float32))
        print(f"Rotating about {tuple(round(float(v), 4) for v in picked.position)}")
        self.state.needs_render = True
        self._update_display(force_render=True)

    def _on_mouse_press(self, event) -> None:
        self._event_time = time.perf_counter()
        if self._in(self.image_display, event) and getattr(event, "dblclick", False) and event.button == 1:
            self._centre_on(event)
            return
        if self._in(self.image_display, event):
            if event.button == 1:
                self.state.is_dragging_camera = True
                self.state.drag_start_pos = (event.xdata, event.ydata)
                if self.state.auto_quality_enabled:
                    self._switch_to_interaction_quality()
        elif self._in(self.opacity_editor, event):
            if event.button == 1:
                self._handle_opacity_left_click(event)
            elif event.button == 3:
                self._handle_opacity_right_click(event)

    def _find_control_point_near(self, x: float, y: float, threshold: float = 0.05) -> Optional[int]:
        """Index of the control point nearest (x, y) if closer than ``threshold``."""
        pts = np.asarray(self.state.control_points, np.float64)
        d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
        i = int(np.argmin(d))
        return i if d[i] < threshold else None

    def _handle_opacity_left_click(self, event) -> None:
        """Select the point under the click, else add one there; either way
        it can then be dragged."""
        x, y = event.xdata, event.ydata
        if x is None or y is None:
            return
        i = self._find_control_point_near(x, y)
        if i is None:
            i = self.state.add_control_point(float(np.clip(x, 0.0, 1.0)), float(np.clip(y, 0.0, 1.0)))
        self.state.select_control_point(i)
        self.state.is_dragging_control_point = True
        self.state.drag_start_pos = (x, y)
        if self.state.auto_quality_enabled:
            self._switch_to_interaction_quality()
        self._update_display(force_render=True)

    def _handle_opacity_right_click(self, event) -> None:
        """Remove the point under the click (not the end points)."""
        if event.xdata is None or event.ydata is None:
            return
        self._remove_point(self._find_control_point_near(event.xdata, event.ydata))

    def _remove_point(self, i: Optional[int]) -> None:
        """Remove control point ``i`` and show the result; nothing for None
        or an end point."""
        if i is None:
            return
        try:
            self.state.remove_control_point(i)
        except ValueError:
            return  # an end point
        self._update_display(force_render=True)

    def _on_mouse_move(self, event) -> None:
        if self.state.is_dragging_camera:
            if not self._in(self.image_display, event) or event.xdata is None or self.state.drag_start_pos is None:
                return
            self._event_time = time.perf_counter()
            x0, y0 = self.state.drag_start_pos
            dx, dy = event.xdata - x0, event.ydata - y0
            if self.state.camera_control_mode == "trackball":
                # The image's y grows upward, the trackball's downward.
                self.camera_controller.trackball(dx=dx, dy=-dy, viewport_width=self.width,
                                                 viewport_height=self.height, sensitivity=1.0)
            else:
                self.camera_controller.orbit(delta_azimuth=-0.005 * dx, delta_elevation=0.005 * dy)
            self.state.drag_start_pos = (event.xdata, event.ydata)
            self.state.needs_render = True
            self._update_display()
        elif not self.state.is_dragging_control_point:
            self._show_value_under(event)
        elif self.state.is_dragging_control_point:
            i = self.state.selected_control_point
            if i is None or not self._in(self.opacity_editor, event) or event.xdata is None:
                return
            self._event_time = time.perf_counter()
            try:
                self.state.update_control_point(i, np.clip(event.xdata, 0.0, 1.0), np.clip(event.ydata, 0.0, 1.0))
            except (ValueError, IndexError):
                return
            self.opacity_editor.update_plot(self.state.control_points, self.state.selected_control_point)
            if self._native:  # other renderers show the new function on release
                self._refresh_image()
                if self._cheap:
                    self._blit(self.opacity_editor)
                elif self._figure_changed():
                    self._update_status_display()

    def _on_mouse_release(self, event) -> None:
        self._event_time = time.perf_counter()
        if self.state.is_dragging_camera or self.state.is_dragging_control_point:
            self.state.is_dragging_camera = False
            self.state.is_dragging_control_point = False
            self.state.drag_start_pos = None
            self._restore_quality_after_interaction()

    def _on_scroll(self, event) -> None:
        if not self._in(self.image_display, event):
            return
        self._event_time = time.perf_counter()
        if self.state.auto_quality_enabled:
            self._switch_to_interaction_quality()
        self.camera_controller.zoom(factor=0.9 if event.step > 0 else 1.1)
        self.state.needs_render = True
        self._update_display()
        self._later("scroll", 500, self._on_scroll_end)

    def _on_scroll_end(self) -> None:
        if self._interacting and not (self.state.is_dragging_camera or self.state.is_dragging_control_point):
            self._event_time = time.perf_counter()
            self._restore_quality_after_interaction()

    def _update_cursor(self, event) -> None:
        """A hand over the image, a crosshair over the opacity editor."""
        if self.fig is None:
            return
        if self._in(self.image_display, event):
            cursor = Cursors.HAND
        elif self._in(self.opacity_editor, event):
            cursor = Cursors.SELECT_REGION
        else:
            cursor = Cursors.POINTER
        try:
            self.fig.canvas.set_cursor(cursor)
        except (SystemError, RuntimeError):
            pass  # some backends cannot change the cursor; it is only a hint

    def _on_colormap_change(self, colormap_name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_colormap(colormap_name)
        self._update_display()

    def _on_preset_change(self, preset_name: str) -> None:
        self._event_time = time.perf_counter()
        self.state.set_preset(preset_name)
        config = self._preset(preset_name)
        self.renderer.set_config(config)
        self.state.needs_render = True
        self._update_display(force_render=True)
        print(f"Switched to '{preset_name}' preset (~{config.estimate_samples_per_ray()} samples/ray)")
        self._update_status_display()

    def _on_key_press(self, event) -> None:
        self._event_time = time.perf_counter()
        action = {
            "r": self._reset_view, "s": self._save_image, "f": self._toggle_fps, "h": self._toggle_histogram,
            "l": self._toggle_light_link, "q": self._toggle_auto_quality, "t": self._toggle_control_mode,
            "o": self._toggle_projection,
            "escape": self._deselect, "delete": self._delete_selected, "backspace": self._delete_selected,
        }.get(event.key)
        if action is not None:
            action()

    def _reset_view(self) -> None:
        projection = self.camera_controller.params.projection
        self.camera_controller.params = _home_camera(self.volume)
        self.camera_controller.params.projection = projection
        self.state.needs_render = True
        self._update_display(force_render=True)

    def _toggle_projection(self) -> None:
        # The orthographic view's height follows the distance (view_height
        # None): the target keeps its size, and the wheel zooms either view.
        cam = self.camera_controller.params
        cam.projection = "perspective" if cam.projection == "orthographic" else "orthographic"
        cam.view_height = None
        print(f"{cam.projection.capitalize()} projection")
        self.state.needs_render = True
        self._update_display(force_render=True)
        self._update_status_display()

    def _toggle_fps(self) -> None:
        self.state.show_fps = not self.state.show_fps
        if self.image_display is not None:
            self.image_display.set_fps_visible(self.state.show_fps)
        self._update_status_display()

    def _toggle_histogram(self) -> None:
        self.state.show_histogram = not self.state.show_histogram
        if self.opacity_editor is not None:
            self.opacity_editor.set_histogram_visible(self.state.show_histogram)
        print(f"Histogram {'visible' if self.state.show_histogram else 'hidden'}")
        self._update_status_display()

    def _toggle_light_link(self) -> None:
        try:
            self._switch_light_link()
        except Exception as e:  # the window must survive a bad light or camera
            print(f"Error toggling light linking: {e}")

    def _switch_light_link(self) -> None:
        light = self.renderer.get_light()
        if light.is_linked:
            light.unlink_from_camera()
            self.renderer.set_light(light)
            self.state.light_linked_to_camera = False
            print("Light unlinked from camera (fixed position)")
            self.state.needs_render = True
            self._update_display(force_render=True)
            self._update_status_display()
        else:
            self.set_camera_linked_lighting(quiet=True)
            print("Light linked to camera (will follow movement)")

    def _toggle_auto_quality(self) -> None:
        self.state.auto_quality_enabled = not self.state.auto_quality_enabled
        print(f"Automatic quality adjustment {'enabled' if self.state.auto_quality_enabled else 'disabled'}")
        self._update_status_display()

    def _toggle_control_mode(self) -> None:
        if self.state.camera_control_mode == "trackball":
            self.state.camera_control_mode = "orbit"
            print("Switched to orbit control (azimuth/elevation)")
        else:
            self.state.camera_control_mode = "trackball"
            print("Switched to trackball control (arcball)")
        self._update_status_display()

    def _deselect(self) -> None:
        if self.state.selected_control_point is not None:
            self.state.select_control_point(None)
            self._update_display()

    def _delete_selected(self) -> None:
        self._remove_point(self.state.selected_control_point)

    def _on_draw(self, event) -> None:
        # Blitting draws over the last full drawing, so there must be one.
        self._drawn = True

    def _on_close(self, event) -> None:
        for timer in self._timers.values():
            timer.stop()
        self._restore_matplotlib_keymaps()
