"""What a frame returns (output formats, backgrounds, means of frames) and
what it may cost (the warnings before long frames); the optical models'
abilities as the core declares them."""

import warnings

import numpy as np

from . import _core
from .config import RenderConfig


# What notebooks show frames over, the still (``_repr_png_``) and the live
# view alike: jupyter_rfb sends frames to the browser without alpha, so a
# transparent background would be black there and the page's colour in the
# still. White as RGB: colour names need matplotlib, which notebooks need not have.
NOTEBOOK_BACKGROUND = (1.0, 1.0, 1.0)


def output_format(dt: np.dtype, premultiplied: bool, bg, origin: str) -> tuple:
    """``render``'s output options as the engine's (codes, straight,
    background, top_down)."""
    return (dt == np.uint8, not premultiplied, bg, origin == "upper")


def output_image(img: np.ndarray, dt: np.dtype, premultiplied: bool, bg, origin: str) -> np.ndarray:
    """A frame's premultiplied float RGBA (row 0 at the bottom) as ``render``
    returns it: over ``bg`` if given, uint8 or float32, straight unless
    ``premultiplied``, rows from the bottom unless ``origin`` is "upper"
    (the rules by which the engine makes each pixel of a frame it returns)."""
    if dt == np.float32 and premultiplied and bg is None and origin == "lower":
        return img
    return _core.convert(img, output_format(dt, premultiplied, bg, origin))


def mean_image(total: np.ndarray, n: int) -> np.ndarray:
    """float32 ``total / n`` of float64 sums of frames, in one pass."""
    return np.divide(total, n, out=np.empty(total.shape, np.float32))


def _colour(c):
    """A background as (r, g, b), or None for none: matplotlib's "none"
    (and "transparent") is no background, not its colour (0, 0, 0) made
    opaque."""
    if isinstance(c, str) and c.strip().lower() in ("none", "transparent"):
        return None
    if isinstance(c, str):
        try:
            from matplotlib.colors import to_rgb
        except ImportError as e:
            raise ImportError("colour names need matplotlib: pip install 'pyvr-rs[plot]', or give (r, g, b)") from e
        try:
            return to_rgb(c)
        except ValueError:
            raise ValueError(f"background {c!r} is not a colour name matplotlib knows") from None
    try:
        a = np.asarray(c, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"background must be an (r, g, b) colour, got {c!r}") from None
    if a.shape != (3,) or not np.all((a >= 0) & (a <= 1)):
        raise ValueError(f"background must be three numbers in [0, 1], got {c!r}")
    return tuple(a)


def check_frame_options(origin, background, dtype) -> None:
    """The output options of a path's frames, checked before any frame."""
    if origin not in ("lower", "upper"):
        raise ValueError(f"origin must be 'lower' or 'upper', got {origin!r}")
    if np.dtype(dtype) not in (np.dtype(np.uint8), np.dtype(np.float32)):
        raise ValueError(f"dtype must be uint8 or float32, got {np.dtype(dtype)}")
    if background is not None:
        _colour(background)


def _progress(progress, unit="frame", desc="render_path"):
    """A function making a progress bar of n units, or None for no bar."""
    if progress is False:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if progress:
            raise ImportError("progress bars need tqdm: pip install 'pyvr-rs[progress]'") from None
        return None
    return lambda total: tqdm(total=total, unit=unit, desc=desc)


def _straight(img: np.ndarray) -> np.ndarray:
    """Colour divided by alpha, clipped to [0, 1]; where alpha is 0 (nothing,
    or the emission model's additive glow) the colour is kept as it is."""
    a = img[..., 3:4]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.clip(np.where(a > 0, img[..., :3] / np.where(a > 0, a, 1), img[..., :3]), 0.0, 1.0)


#: Samples a frame may take before a warning says it will be slow: about a
#: minute on a software renderer, seconds on a GPU.
LONG_FRAME_SAMPLES = 5e9


#: The same for the float64 integrator (one CPU core does about 1e7 per second).
LONG_FLOAT64_SAMPLES = 5e8


#: Each optical model's abilities, as the core declares them.
MODEL_ABILITIES = _core.model_abilities()


#: Models with unbiased frames (RenderConfig.unbiased), which accumulate uses.
UNBIASED_MODELS = tuple(m for m, a in MODEL_ABILITIES.items() if a["unbiased"])


# Models whose samples are lit from the data's gradient when no normals are given.
GRADIENT_SHADED_MODELS = tuple(m for m, a in MODEL_ABILITIES.items() if a["lit_by_normals"])


def _frame_samples(bounds, cfg: RenderConfig, width: int, height: int) -> float:
    """An upper bound on a frame's samples: every ray across the box's diagonal."""
    diag = float(np.linalg.norm(np.subtract(bounds[1], bounds[0])))
    per_ray = min(float(cfg.max_steps), diag / cfg.step_size + 2.0)
    if cfg.model == "single_scattering":
        shadow = cfg.shadow_step_size or cfg.step_size
        per_ray *= diag / shadow + 1.0
    return float(width) * float(height) * per_ray


def _warn_if_long(what: str, samples: float, limit: float, stacklevel: int) -> None:
    """``stacklevel`` counts from the caller of _warn_if_long (1: that caller)."""
    if samples > limit:
        warnings.warn(
            f"{what} may take up to {samples:.3g} samples (step_size, max_steps and image size decide this), "
            "which can take minutes; press Ctrl-C to stop it",
            UserWarning,
            stacklevel=stacklevel + 1,
        )
