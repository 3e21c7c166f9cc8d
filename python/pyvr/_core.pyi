"""Type stubs for the Rust extension module pyvr._core."""

from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

Vec3 = Tuple[float, float, float]
# (position, target, up, vertical fov in radians)
CameraArgs = Tuple[Vec3, Vec3, Vec3, float]
# (position, target, ambient, diffuse, "directional" | "point")
LightArgs = Tuple[Vec3, Vec3, float, float, str]

__version__: str

class RenderConfig:
    step_size: float
    max_steps: int
    early_ray_termination: bool
    opacity_threshold: float
    reference_step_size: float
    opacity_correction: str
    model: str
    iso_value: float
    anisotropy: float
    shadow_step_size: float
    jitter: bool
    jitter_seed: int
    pre_integrated: bool
    refine: int
    unbiased: bool
    exact_filtering: bool
    order: str
    def __init__(
        self,
        step_size: float = 0.01,
        max_steps: int = 500,
        early_ray_termination: bool = True,
        opacity_threshold: float = 0.95,
        reference_step_size: float = 0.01,
        opacity_correction: str = "exponential",
        *,
        model: str = "emission_absorption",
        iso_value: float = 0.5,
        anisotropy: float = 0.0,
        shadow_step_size: float = 0.0,
        jitter: bool = False,
        jitter_seed: int = 0,
        pre_integrated: bool = False,
        refine: int = 0,
        unbiased: bool = False,
        exact_filtering: bool = False,
        order: str = "front_to_back",
    ) -> None: ...
    def replace(self, **changes: Any) -> "RenderConfig": ...
    def validate(self) -> None: ...
    @classmethod
    def preview(cls) -> "RenderConfig": ...
    @classmethod
    def fast(cls) -> "RenderConfig": ...
    @classmethod
    def balanced(cls) -> "RenderConfig": ...
    @classmethod
    def high_quality(cls) -> "RenderConfig": ...
    @classmethod
    def ultra_quality(cls) -> "RenderConfig": ...
    @classmethod
    def custom(
        cls, step_size: float, max_steps: int, early_ray_termination: bool = True, opacity_threshold: float = 0.95
    ) -> "RenderConfig": ...
    def copy(self) -> "RenderConfig": ...
    def with_step_size(self, step_size: float) -> "RenderConfig": ...
    def with_max_steps(self, max_steps: int) -> "RenderConfig": ...
    def estimate_samples_per_ray(self) -> int: ...
    def estimate_render_time_relative(self) -> float: ...
    def __eq__(self, other: object) -> bool: ...

class Renderer:
    width: int
    height: int
    device: str
    def __init__(self, width: int, height: int) -> None: ...
    def resize(self, width: int, height: int) -> None: ...
    def set_volume(
        self,
        data: npt.NDArray[Any],
        normals: Optional[npt.NDArray[np.float32]],
        min_bounds: Vec3,
        max_bounds: Vec3,
        precision: str = "float32",
    ) -> None: ...
    def pack_gradients(self, data: npt.NDArray[np.float32], min_bounds: Vec3, max_bounds: Vec3) -> bool: ...
    def set_lut(self, lut: npt.NDArray[np.float32]) -> None: ...
    def set_value_map(self, scale: float, offset: float) -> None: ...
    def set_clip(self, clip: Optional[Tuple[Vec3, Vec3]]) -> None: ...
    def render(
        self, camera: CameraArgs, light: LightArgs, config: RenderConfig,
        output: Optional[Tuple[bool, bool, Optional[Vec3], bool]] = None,
    ) -> Tuple[npt.NDArray[Any], Dict[str, int]]: ...
    def accumulate(
        self, camera: CameraArgs, light: LightArgs, config: RenderConfig, sums: npt.NDArray[np.float64]
    ) -> Dict[str, int]: ...
    def counters(self) -> Dict[str, int]: ...
    skip_empty: bool
    uniform_runs: bool
    native_march: bool
    def empty_fraction(self) -> float: ...
    def uniform_fraction(self) -> float: ...
    def depth(self) -> Optional[npt.NDArray[np.float32]]: ...
    # Bricked volumes (pyvr.bricks): layout, uploads, and a frame's steps.
    def set_brick_layout(
        self, dims: Tuple[int, int, int], min_bounds: Vec3, max_bounds: Vec3, core: Tuple[int, int, int], ghost: int
    ) -> None: ...
    def brick_ranges(self) -> List[Tuple[Tuple[int, int], Tuple[int, int], Tuple[int, int]]]: ...
    def set_brick(
        self, index: int, data: npt.NDArray[Any], normals: Optional[npt.NDArray[np.float32]], precision: str = "float32"
    ) -> None: ...
    def evict_brick(self, index: int) -> None: ...
    def brick_resident(self, index: int) -> bool: ...
    def wait_idle(self) -> None: ...
    def begin_bricks(
        self, camera: CameraArgs, light: LightArgs, config: RenderConfig, keep_state: bool = False
    ) -> List[int]: ...
    def render_brick(self, index: int) -> None: ...
    def end_bricks(self) -> Tuple[npt.NDArray[np.float32], Dict[str, int]]: ...

def convert(
    rgba: npt.NDArray[np.float32], output: Tuple[bool, bool, Optional[Vec3], bool]
) -> npt.NDArray[Any]: ...
def integrate_reference(
    data: npt.NDArray[Any],
    normals: Optional[npt.NDArray[np.float32]],
    min_bounds: Vec3,
    max_bounds: Vec3,
    lut: npt.NDArray[np.float32],
    camera: CameraArgs,
    light: LightArgs,
    config: RenderConfig,
    width: int,
    height: int,
    order: Optional[str] = None,
    adaptive_tolerance: float = 0.0,
    value_map: Tuple[float, float] = (1.0, 0.0),
    clip: Optional[Tuple[Vec3, Vec3]] = None,
    progress: Optional[Callable[[int], Any]] = None,
) -> Tuple[npt.NDArray[np.float64], int, npt.NDArray[np.float64]]: ...
def colormap_table(name: str) -> Optional[npt.NDArray[np.float64]]: ...
def colormap_names() -> List[str]: ...
def device_info() -> str: ...
def device_limits() -> Dict[str, int]: ...
def model_abilities() -> Dict[str, Dict[str, object]]: ...
def brick_ghost(step: float, spacing: Vec3) -> int: ...
def brick_layout(
    dims: Tuple[int, int, int], core: Tuple[int, int, int], ghost: int, eye: Vec3
) -> Tuple[List[Tuple[Tuple[int, int], Tuple[int, int], Tuple[int, int]]], List[int]]: ...
