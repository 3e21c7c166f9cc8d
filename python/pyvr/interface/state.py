"""InterfaceState: what the interactive interface is showing and doing."""

from dataclasses import dataclass, field
from typing import List, Optional, Tuple

PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]


@dataclass
class InterfaceState:
    """The opacity control points (scalar, opacity), the selection, the
    colormap and preset names, and the interaction flags.

    Control points stay sorted by scalar; the first is at scalar 0 and the
    last at 1, and neither can be removed.
    """

    control_points: List[Tuple[float, float]] = field(default_factory=lambda: [(0.0, 0.0), (1.0, 1.0)])
    selected_control_point: Optional[int] = None
    current_colormap: str = "viridis"
    is_dragging_camera: bool = False
    is_dragging_control_point: bool = False
    drag_start_pos: Optional[Tuple[float, float]] = None
    camera_control_mode: str = "trackball"
    needs_render: bool = True
    needs_tf_update: bool = False
    show_fps: bool = True
    show_histogram: bool = True
    current_preset_name: str = "fast"
    light_linked_to_camera: bool = False
    auto_quality_enabled: bool = True
    saved_preset_name: Optional[str] = None

    def __post_init__(self):
        if len(self.control_points) < 2:
            raise ValueError("Must have at least 2 control points")
        points = [(float(s), float(o)) for s, o in self.control_points]
        for s, o in points:
            if not 0.0 <= s <= 1.0:
                raise ValueError(f"Control point scalar {s} out of range [0, 1]")
            if not 0.0 <= o <= 1.0:
                raise ValueError(f"Control point opacity {o} out of range [0, 1]")
        self.control_points = sorted(points, key=lambda p: p[0])

    def add_control_point(self, scalar: float, opacity: float) -> int:
        """Insert a point in scalar order and return its index."""
        if not 0.0 <= scalar <= 1.0:
            raise ValueError(f"Scalar {scalar} out of range [0, 1]")
        if not 0.0 <= opacity <= 1.0:
            raise ValueError(f"Opacity {opacity} out of range [0, 1]")
        point = (float(scalar), float(opacity))
        self.control_points.append(point)
        self.control_points.sort(key=lambda p: p[0])
        self.needs_tf_update = True
        self.needs_render = True
        return self.control_points.index(point)

    def remove_control_point(self, index: int) -> None:
        """Remove the opacity control point at ``index`` (not the first or last)."""
        n = len(self.control_points)
        if index in (0, n - 1, -1, -n):
            raise ValueError("Cannot remove first or last control point")
        if not -n <= index < n:
            raise IndexError(f"Control point index {index} out of range for {n} points")
        del self.control_points[index]
        if self.selected_control_point is not None:
            if self.selected_control_point == index:
                self.selected_control_point = None
            elif self.selected_control_point > index:
                self.selected_control_point -= 1
        self.needs_tf_update = True
        self.needs_render = True

    def update_control_point(self, index: int, scalar: float, opacity: float) -> None:
        """Move a point; the end points keep scalar 0 and 1, the others are
        clamped to [0, 1] and re-sorted, the selection following the point."""
        n = len(self.control_points)
        if not -n <= index < n:
            raise IndexError(f"Control point index {index} out of range for {n} points")
        index %= n
        opacity = min(max(float(opacity), 0.0), 1.0)
        if index == 0:
            scalar = 0.0
        elif index == n - 1:
            scalar = 1.0
        else:
            scalar = min(max(float(scalar), 0.0), 1.0)
        point = (scalar, opacity)
        self.control_points[index] = point
        if 0 < index < n - 1:
            middle = sorted(self.control_points[1:-1], key=lambda p: p[0])
            self.control_points[1:-1] = middle
            if self.selected_control_point == index:
                self.selected_control_point = 1 + middle.index(point)
        self.needs_tf_update = True
        self.needs_render = True

    def select_control_point(self, index: Optional[int]) -> None:
        """Select the control point at ``index`` (None: none)."""
        if index is not None and not 0 <= index < len(self.control_points):
            raise IndexError(f"Control point index {index} out of range for {len(self.control_points)} points")
        self.selected_control_point = index

    def set_colormap(self, colormap_name: str) -> None:
        """Use the matplotlib colormap ``colormap_name``; the transfer functions and
        the frame update."""
        self.current_colormap = colormap_name
        self.needs_tf_update = True
        self.needs_render = True

    def set_preset(self, preset_name: str) -> None:
        """Use the RenderConfig preset ``preset_name`` (one of :data:`PRESETS`)."""
        if preset_name not in PRESETS:
            raise ValueError(f"Invalid preset '{preset_name}'. Choose from: {PRESETS}")
        self.current_preset_name = preset_name
        self.needs_render = True
