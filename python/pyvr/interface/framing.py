"""The interface's presets and home view for the volume's box: pyvr's own
for boxes of its scale ([-1, 1]), scaled for boxes far from it."""

import warnings

import numpy as np

from ..camera import Camera
from ..config import RenderConfig
from ..lighting import Light
from ..volume import Volume

# pyvr's presets and home view are made for the [-1, 1] box. A box whose
# diagonal is beyond this factor of that box's, either way (physical units:
# metres of simulation, nanometres of a cell), gets them scaled to it.
_FOREIGN_SCALE = 1e3


def _box_scale(volume: Volume) -> float:
    """The box's diagonal over the [-1, 1] box's, or 1 where it is within
    _FOREIGN_SCALE of it (there pyvr's presets and view apply as they are)."""
    lo, hi = np.asarray(volume.min_bounds, np.float64), np.asarray(volume.max_bounds, np.float64)
    scale = float(np.linalg.norm(hi - lo)) / (2.0 * np.sqrt(3.0))
    return scale if not (1.0 / _FOREIGN_SCALE <= scale <= _FOREIGN_SCALE) else 1.0


def _home_camera(volume: Volume) -> Camera:
    """pyvr's home view (isometric, distance 3, at the origin); for a box
    far from pyvr's scale, the same view of that box: at its centre, the
    distance scaled with it."""
    scale = _box_scale(volume)
    if scale == 1.0:
        return Camera.isometric_view(distance=3.0)
    centre = (np.asarray(volume.min_bounds, np.float64) + np.asarray(volume.max_bounds, np.float64)) / 2
    # init_pos is absolute in pyvr's camera: it moves with the target, far
    # enough from it to stay distinct in float32, so the view keeps its direction.
    home = Camera.isometric_view(distance=3.0)
    offset = np.asarray(home.init_pos, np.float64) - np.asarray(home.target, np.float64)
    reach = max(scale, 1.0, 1e-3 * float(np.abs(centre).max()))
    return Camera(target=centre.astype(np.float32), azimuth=home.azimuth, elevation=home.elevation,
                  roll=home.roll, distance=3.0 * scale, init_pos=(centre + offset * reach).astype(np.float32),
                  init_up=home.init_up)


def _home_light(volume: Volume) -> Light:
    """The interface's light: pyvr's directional (1, -1, 0), placed 10 units
    out; for a box far from pyvr's scale, 10 of its scaled units out."""
    return Light.directional([1, -1, 0], distance=10.0 * _box_scale(volume))


def _crossing(cfg: RenderConfig, volume: Volume) -> RenderConfig:
    """The config with max_steps raised so rays cross the whole volume
    (pyvr's presets stop rays after a fixed length, shorter than the
    [-1, 1] box's diagonal for preview, fast and ultra_quality). For a box
    far from pyvr's scale, the step and the reference step scale with it:
    the same samples per ray, and the same look, as the [-1, 1] box."""
    scale = _box_scale(volume)
    with warnings.catch_warnings():
        # pyvr warns about steps above 0.1, meant for its own box.
        if scale != 1.0:
            warnings.filterwarnings("ignore", message="step_size .* is very large")
        cfg = cfg.replace(step_size=cfg.step_size * scale, reference_step_size=cfg.reference_step_size * scale)
        lo, hi = np.asarray(volume.min_bounds, np.float64), np.asarray(volume.max_bounds, np.float64)
        needed = int(np.ceil(np.linalg.norm(hi - lo) / cfg.step_size)) + 2
        return cfg.with_max_steps(needed) if needed > cfg.max_steps else cfg
