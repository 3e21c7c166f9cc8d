"""How far a frame is from the exact image, and configs chosen by accuracy.

Errors are measured on premultiplied RGBA in units of 8-bit levels (float,
not rounded): that is what a viewer sees once the image is composited over a
background, and it is well defined everywhere. (Straight colour is undefined
where alpha is 0 and its error grows as 1/alpha, so faint fringes would
dominate any straight-colour maximum.)

* :func:`error_metrics`: RMSE, maximum, and the fraction of pixels off by
  more than one level.
* :func:`converged_image`: the float64 integrator with steps halved until
  Richardson's estimate of its own error is below a tolerance.
* :func:`error_budget`: a frame's error split into its causes (step size,
  early termination, max_steps truncation, float32 arithmetic).
* :func:`config_for_error`: the largest step (and the termination
  threshold) whose predicted error is within a target.
"""

import itertools
import time
import warnings
from typing import Dict, Optional, Tuple

import numpy as np

from .config import RenderConfig
from ._storage import device_limits

LEVELS = 255.0
# A pre-integrated frame's time over a midpoint frame's at the same step
# (1.0-1.4x on the accuracy benchmark's scenes, at most 1.25x at steps up to
# 0.01: benches/preintegration.py).
PREINTEGRATED_COST = 1.3
# Midpoint samples of a refined pre-integrated segment (RenderConfig.refine)
# where config_for_error tries them, and the weight of each such sample on
# PREINTEGRATED_COST's scale: 1.7 times a pre-integrated segment's 1.3.
# Measured on lavapipe, a sub-sample takes 1.6-1.7x a pre-integrated
# sample's time on the narrow peaks (a third to a half of the samples
# refined), 0.9x on Shepp-Logan (nearly all), and 5-11x on the helix, where
# one lane in a group refines and the others wait, but there they are 2-4%
# of a frame's samples.
REFINE = 8
REFINED_COST = 1.7 * PREINTEGRATED_COST
# Where config_for_error starts searching refined segments: this many times
# the step of the choice so far, over its weight: a refined frame with few
# segments refined costs 1.3x a midpoint frame per segment (the helix), so a
# shorter step would not pay for the pilots.
REFINED_START = 1.5
# Where Bergner's TF-limited step is under this fraction of a voxel,
# config_for_error searches only the segment kinds (pre-integrated, refined),
# from steps of 1/SEGMENT_START of a voxel, against a reference at half that
# step (refined where the transfer function has a step, STEP_JUMP): on the
# accuracy benchmark the helix (a TF-limited step of 0.003 voxel) and the
# narrow peaks (0.09) are there, Shepp-Logan (0.21; the midpoint kind wins
# it) is not.
SEGMENTS_ONLY = 1 / 8
SEGMENT_START = 16
# A transfer function whose opacity changes by more than this between
# neighbouring entries of the pre-integration table (its side: the lookup
# table's length within 256-512) has a step there, which the table's
# bilinear lookups blur at any segment length: the segment search's
# reference is then refined (its refined segments sample the lookup table
# itself), elsewhere pre-integrated, at half the cost a sample. The helix's
# step changes by 0.6 at one entry, the narrow peaks by at most 0.12.
STEP_JUMP = 0.25
# A step commensurate with the voxels puts samples at the same places in
# every voxel along an axis-aligned stretch, where their errors add up
# instead of averaging out; the segment search's steps are offset from the
# voxel's binary fractions by this factor.
OFF_GRID = 1.09
# Between a step within the budget and its double, which was not, the error
# of the steps tried in between is predicted from the two (as h^p): a step
# predicted over this many times the budget fails on its own without a
# pilot. On the accuracy benchmark's scene at 4 levels both steps between
# were predicted at 1.25-1.6 times the budget and measured at 1.34-1.39.
PREDICTED_FAIL = 1.2
# A step that fails right after its half passed, with an error at most this
# many times the half's, ends the doubling: error growing as h^3 or slower
# is the integration's own and goes on growing. (Larger jumps may be a
# spike, a step whose samples fall against the data's features, so the
# next double is tried too.) On the accuracy benchmark's six scenes the
# failing doubles grew the error 2.3-3.3 times, and 8.3 times on fuel.vti at
# 1 level; no double after a failure passed.
SMOOTH_GROWTH = 8.0


def refined_cost(samples: float, segments: float) -> float:
    """A refined pre-integrated frame's cost in midpoint samples: its
    `segments` (the samples the same frame takes unrefined) at
    PREINTEGRATED_COST and the rest of its `samples`, the refined segments'
    sub-samples, at REFINED_COST."""
    return PREINTEGRATED_COST * segments + REFINED_COST * max(samples - segments, 0.0)


def error_metrics(image: np.ndarray, reference: np.ndarray) -> Dict[str, float]:
    """Premultiplied RGBA images in [0, 1] (H, W, 4) compared in 8-bit levels."""
    a = np.asarray(image, np.float64)
    b = np.asarray(reference, np.float64)
    if a.shape != b.shape or a.ndim != 3 or a.shape[2] != 4:
        raise ValueError(f"expected two (H, W, 4) images of one shape, got {a.shape} and {b.shape}")
    d = np.abs(np.clip(a, 0, 1) - np.clip(b, 0, 1)) * LEVELS
    return {
        "rmse": float(np.sqrt((d**2).mean())),
        "max": float(d.max()),
        "frac_over_1": float((d.max(axis=-1) > 1.0).mean()),
    }


def _exact(config: RenderConfig, step: float, longest: float) -> RenderConfig:
    """The same model at `step`, no early stop, max_steps that cross any chord."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "max_steps is very large"
        return config.replace(step_size=step, early_ray_termination=False, opacity_threshold=1.0,
                              max_steps=int(np.ceil(longest / step)) + 2, jitter=False, pre_integrated=False)


def longest_chord(renderer) -> float:
    """The diagonal of the renderer's volume box: the longest path a ray can take
    through it."""
    lo, hi = (np.asarray(b, np.float64) for b in renderer.bounds)
    return float(np.linalg.norm(hi - lo))


def converged_image(renderer, tolerance: float = 0.1, step: Optional[float] = None,
                    max_halvings: int = 3) -> Tuple[np.ndarray, Dict[str, float]]:
    """The renderer's frame from the float64 integrator, converged in the
    step: premultiplied RGBA and {"step", "estimated_max_error",
    "adaptive"} (levels).

    The midpoint rule's error falls as h^2 on smooth integrands, so
    `|I_h - I_2h| / 3` estimates the error left in `I_h` (Richardson). The
    step starts at `step` (default: a quarter of the smallest voxel spacing,
    at most reference_step / 4) and is halved until the estimate is below
    `tolerance`. Where a first halving does not get there (a TF with steps
    or narrow peaks makes the integrand jump, and the error fall only as h),
    segments are split adaptively where the TF varies
    (`render_float64(adaptive_tolerance=1e-4)`: a piece ends where the TF
    changes its optical depth or colour by at most 1e-4, so a jump costs
    under 0.01 level) and the halving goes on. When the splitting already
    resolves everything the two steps share their pieces and the estimate
    reads 0: the bound is then the splitting tolerance, not Richardson's.
    """
    lo, hi = (np.asarray(b, np.float64) for b in renderer.bounds)
    spacing = float(((hi - lo) / np.array(renderer.volume.data.shape[:3])).min())
    cfg = renderer.config
    h = step or min(spacing / 4, cfg.reference_step_size / 4)
    longest = longest_chord(renderer)
    adaptive = 0.0

    def image(step):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return renderer.render_float64(config=_exact(cfg, step, longest), premultiplied=True,
                                           adaptive_tolerance=adaptive)

    coarse = image(2 * h)
    for k in range(max_halvings + 1):
        fine = image(h)
        est = float(np.abs(fine - coarse).max() * LEVELS / 3)
        if est <= tolerance or k == max_halvings:
            break
        if k == 0 and not adaptive:
            adaptive = 1e-4
            coarse = image(2 * h)
            continue
        coarse, h = fine, h / 2
    return fine, {"step": h, "estimated_max_error": est, "adaptive": adaptive}


def error_budget(renderer, reference: np.ndarray, config: Optional[RenderConfig] = None) -> Dict[str, Dict[str, float]]:
    """A frame's error against `reference` (premultiplied RGBA), and how
    much each cause adds, each measured as the difference it makes alone:

    * ``step``: the float64 image at this step, without early termination
      or truncation, against the reference;
    * ``termination``: early termination on vs off (float64, same step);
    * ``truncation``: this max_steps vs enough steps (float64);
    * ``float32``: the GPU frame vs the float64 image of the same config.
    """
    cfg = config or renderer.config
    longest = longest_chord(renderer)
    saved = renderer.config
    renderer.set_config(cfg)
    try:
        gpu = renderer.render(dtype=np.float32, premultiplied=True)
    finally:
        renderer.set_config(saved)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        enough = cfg.replace(max_steps=max(cfg.max_steps, int(np.ceil(longest / cfg.step_size)) + 2))
        no_stop = enough.replace(early_ray_termination=False)
        f_exact = renderer.render_float64(config=no_stop, premultiplied=True)
        f_stop = renderer.render_float64(config=enough, premultiplied=True)
        f_cfg = renderer.render_float64(config=cfg, premultiplied=True)
    return {
        "total": error_metrics(gpu, reference),
        "step": error_metrics(f_exact, reference),
        "termination": error_metrics(f_stop, f_exact),
        "truncation": error_metrics(f_cfg, f_stop),
        "float32": error_metrics(gpu, f_cfg),
    }


def _data_features(renderer) -> Dict[str, float]:
    """The smallest voxel spacing and the largest gradient magnitude of the
    data (per world unit): a pass over every voxel, kept on the renderer
    until the next load_volume."""
    kept = getattr(renderer, "_data_features", None)
    if kept is not None:
        return kept
    raw = np.asarray(renderer.volume.data)
    scale = {np.dtype(np.uint8): 1 / 255.0, np.dtype(np.uint16): 1 / 65535.0}.get(raw.dtype, 1.0)
    data = np.nan_to_num(raw.astype(np.float32) * np.float32(scale), nan=0.0, posinf=1.0, neginf=0.0)
    lo, hi = (np.asarray(b, np.float64) for b in renderer.bounds)
    spacing = (hi - lo) / np.array(data.shape)
    # One axis at a time in float32: a 256^3 volume needs two extra copies, not six.
    sq = np.zeros(data.shape, np.float32)
    for axis, h in enumerate(spacing):
        if data.shape[axis] > 1:
            sq += np.gradient(data, h, axis=axis).astype(np.float32) ** 2
    kept = {"spacing": float(spacing.min()), "gradient": float(np.sqrt(sq.max()))}
    renderer._data_features = kept
    return kept


def scene_features(renderer) -> Dict[str, float]:
    """What the step has to resolve: the smallest voxel spacing, the largest
    gradient magnitude of the data (per world unit; measured once per loaded
    volume), and the transfer function's steepest change of optical depth
    per reference step and of emitted colour, per unit of value (its
    frequency content)."""
    lut = np.asarray(renderer.lut, np.float64)
    m = len(lut)
    emitted = lut[:, :3] * lut[:, 3:4]
    dv = 1.0 / max(m - 1, 1)
    slope_a = float(np.abs(np.diff(lut[:, 3])).max() / dv) if m > 1 else 0.0
    slope_c = float(np.abs(np.diff(emitted, axis=0)).max() / dv) if m > 1 else 0.0
    return {**_data_features(renderer), "tf_slope_alpha": slope_a, "tf_slope_color": slope_c,
            "longest_chord": longest_chord(renderer)}


def tf_has_step(lut: np.ndarray) -> bool:
    """Whether the transfer function's opacity changes by more than
    STEP_JUMP between neighbouring entries of its pre-integration table."""
    alpha = np.asarray(lut, np.float64)[:, 3]
    if len(alpha) < 2:
        return False
    side = int(np.clip(len(alpha), 256, 512))
    at = np.interp(np.linspace(0.0, 1.0, side), np.linspace(0.0, 1.0, len(alpha)), alpha)
    return bool(np.abs(np.diff(at)).max() > STEP_JUMP)


def tf_limited_step(features: Dict[str, float]) -> float:
    """The step the transfer function alone asks for (Bergner et al. 2006):
    the signal along a ray is the TF composed with the data, whose bandwidth
    is at most the data's gradient times the TF's slope; half a period of
    that. Infinite where the TF or the data is constant."""
    rate = features["gradient"] * max(features["tf_slope_alpha"], features["tf_slope_color"])
    return 0.5 / rate if rate > 0 else float("inf")


def initial_step(features: Dict[str, float], reference_step: float) -> float:
    """A first guess from sampling theory: resolve both the voxels and the
    TF-limited step (:func:`tf_limited_step`), never coarser than the
    reference step."""
    return max(min(features["spacing"], reference_step, tf_limited_step(features)), 1e-4)


def config_for_error(renderer, max_error_levels: float = 1.0, pilot: Optional[int] = None,
                     base: Optional[RenderConfig] = None) -> Tuple[RenderConfig, Dict[str, float]]:
    """The cheapest config predicted to keep the frame within
    `max_error_levels` (max premultiplied error, in levels) of the exact image.

    The anchor is :func:`initial_step` (Bergner et al.'s TF-aware rate: the
    data's gradient times the transfer function's slope, and the voxels);
    the step is then measured on a pilot: the same view at up to `pilot`
    pixels across (default: a quarter of the frame's side, at least 64, so
    a sixteenth of its rays), rendered by the engine (its f32 arithmetic is
    within 0.01 level of the float64 integrator). A fine pilot at a quarter
    of the anchor (at least a sixteenth of a voxel) is the reference; steps
    doubling from it are compared with it until two in a row exceed 0.4 of
    the target (0.75 when the pilot is the frame itself: the margin covers
    pixels a coarser pilot does not sample, and the maximum error jumps as
    samples shift against features, so one excess alone does not end the
    search, unless it grew the error by at most SMOOTH_GROWTH times); the
    anchor itself is tried first, since where it passes the steps between
    change nothing; the octave above the last step within the budget is
    searched at 2^(3/4), 2^(1/2) and 2^(1/4) times it, largest first,
    skipping a step that the errors at that step and its double predict
    (as h^p) over PREDICTED_FAIL times the budget, and stopping at the
    first that passes. A larger `pilot` buys a closer choice
    for a longer search (pilot=512 searches a 512x512 frame at full size:
    20-100 frames' time on the accuracy benchmark's scenes). If no step
    above the reference passes, the fine step is halved and the search
    repeated (refining only in the last attempt). Measuring
    instead of extrapolating keeps it right where the data has edges and the
    error stops falling as h^2.

    Pre-integrated segments (emission-absorption only) are tried where the
    transfer function limits the step: where Bergner et al.'s TF-aware step
    (:func:`tf_limited_step`) is under half the voxel spacing, so that the
    transfer function's features are narrow against the data's change over
    a voxel; elsewhere the data limits the step and pre-integration, which
    only resolves the transfer function, would cost a pipeline and a table
    for nothing. They are tried once at 1.5 times the midpoint step (above
    their cost per sample, PREINTEGRATED_COST) and searched further only if
    that passes. Refined pre-integrated segments (``refine=REFINE``: where
    a segment's values may reach an opacity change its ramp misses, as at a
    step transfer function's threshold) are then tried from REFINED_START
    times the step of the choice so far over its weight, unless a pilot
    there costs twice the choice so far, and taken where, at the largest
    step they keep within the budget, their pilot costs less than the
    choice so far's. Costs are sample counts of pilots with the chosen
    early termination, weighted per sample (:func:`refined_cost`): how many
    segments are refined depends on the scene, and their samples cost more
    than a segment's. Sample counts compare configs on the same rays, so
    they are taken on a pilot of a quarter of the pilot's side.

    Where the transfer function's features are far narrower than a voxel
    (emission-absorption, TF-limited step under SEGMENTS_ONLY of the
    spacing), the midpoint kind is not searched: its pilots would sample
    at a fraction of that step (the helix's step threshold: 0.003 voxel)
    and cost more than the choice they lose to. The pre-integrated and
    refined kinds are then searched as above from a step of 1/SEGMENT_START
    of a voxel (times OFF_GRID, so that samples do not fall at the same places
    in every voxel), against a pre-integrated reference at half that step,
    refined where the transfer function has a step (:func:`tf_has_step`);
    where neither passes there, the reference's step is halved once, and
    then the full search runs.

    Above one level the fine pilot (and the segment search's reference) is
    coarser by the target's square root: its own error, falling as h to
    h^2, then grows at most as fast as the budget, and takes no larger
    share of it than at one level.

    On a GPU the config interpolates exactly (``exact_filtering``): the
    texture units' 8-bit weights put a floor under the error of steep
    transfer functions that the pilots, sharing it, would not measure.

    Early termination: rays stop at opacity 1 - 0.2 * target / 255, which
    bounds what it drops to 0.2 of the target. Jitter stays off: it turns
    banding into noise of the same size, which does not lower the maximum
    error (``render(accumulate=n)`` averages it away where time allows).

    Returns the config and what was predicted, with the pilot's cost:
    ``pilot_renders`` and ``seconds`` (the volume's gradient is measured
    once per loaded volume and kept).
    """
    if not (max_error_levels > 0):
        raise ValueError(f"max_error_levels must be positive, got {max_error_levels}")
    if pilot is None:
        pilot = max(64, -(-max(renderer.width, renderer.height) // 4))
    if not (isinstance(pilot, (int, np.integer)) and pilot >= 8):
        raise ValueError(f"pilot must be an integer of at least 8 pixels, got {pilot!r}")
    started = time.perf_counter()
    cfg = base or renderer.config
    if not device_limits()["cpu_device"]:
        # GPUs' texture units weigh texels in 8-bit fixed point; pilots that
        # all share that rounding cannot see the floor it puts under the
        # error (their 8-bit weights put a floor under the error that no step lowers).
        cfg = cfg.replace(exact_filtering=True)
    feats = scene_features(renderer)
    w0, h0 = renderer.width, renderer.height
    scale = min(1.0, pilot / max(w0, h0))
    # Termination takes 0.2 of the target; the step gets the rest but a
    # margin for pixels a coarser pilot does not sample: a frame's maximum
    # was 0.8-2.3x a quarter-side pilot's on five of the accuracy scenes
    # (benches/pilot_margin.py); thin features the pilot's rays miss (the
    # anisotropic scene: 1.5-12.7x) are not bounded by it.
    budget = (0.75 if scale == 1.0 else 0.4) * max_error_levels
    size = (max(1, round(w0 * scale)), max(1, round(h0 * scale)))
    # Sample counts compare configs on the same rays, so a quarter of the
    # pilot's side (a sixteenth of its rays) counts them as well.
    count_size = tuple(min(s, max(16, -(-s // 4))) for s in size)
    longest = feats["longest_chord"]
    images: Dict[Tuple[float, bool, int], np.ndarray] = {}

    def pilot_image(h, pre=False, refine=0):
        if (h, pre, refine) not in images:
            # Early termination on at threshold 1 stops only rays whose
            # transmittance rounds to 0 in f32 (below 3e-8: under 1e-5
            # level behind them), so the pilots measure the step alone while
            # running the shader variant the chosen config runs: its first
            # frame then compiles nothing.
            pilot_cfg = _exact(cfg, h, longest).replace(pre_integrated=pre, refine=refine, early_ray_termination=True)
            images[h, pre, refine] = renderer.render(dtype=np.float32, premultiplied=True, size=size, config=pilot_cfg)
        return images[h, pre, refine]

    threshold = 1.0 - 0.2 * max_error_levels / LEVELS
    samples: Dict[Tuple[float, bool, int], int] = {}

    def samples_taken(h, pre, refine):
        # The samples a pilot takes with the chosen config's early
        # termination (the search's pilots march on until transmittance
        # underflows, which inflates kinds unequally).
        if (h, pre, refine) not in samples:
            pilot_cfg = _exact(cfg, h, longest).replace(pre_integrated=pre, refine=refine,
                                                        early_ray_termination=threshold < 1.0,
                                                        opacity_threshold=max(0.0, threshold))
            renderer.render(dtype=np.float32, premultiplied=True, size=count_size, config=pilot_cfg)
            samples[h, pre, refine] = renderer.last_frame_stats["samples"]
        return samples[h, pre, refine]

    # The pilot the others are measured against: (step, pre-integrated, refine).
    reference = None

    def error(h, pre, k=0):
        return float(np.abs(pilot_image(h, pre, k) - pilot_image(*reference)).max() * LEVELS)

    def largest_step(start, pre=False, between=(2**0.5, 2**0.25), leap=1, final=True, k=0):
        h, err = start, error(start, pre, k)
        cand, fails = start, 0
        # A step `leap` times the start first: where it passes, the steps
        # between would not change the outcome (a pass resets the failures),
        # and they are the costliest pilots after the reference.
        if leap > 1 and start * leap <= longest:
            e = error(start * leap, pre, k)
            if e <= budget:
                h, err, cand = start * leap, e, start * leap
        while cand * 2 <= longest and fails < 2:
            cand *= 2
            e = error(cand, pre, k)
            if e > budget:
                fails += 1
                # A failure right after a pass that grew the error by at
                # most SMOOTH_GROWTH ends the search: the error grows
                # with the step as it should, and larger steps fail too.
                if cand == 2 * h and 0 < err and e <= SMOOTH_GROWTH * err:
                    break
            else:
                h, err, fails = cand, e, 0
        # Between the last step within the budget and the next one up
        # (not when none above the start passed and a finer start follows).
        if h == start and not final:
            return h, err
        h0, e0 = h, err
        e2 = error(2 * h0, pre, k) if (2 * h0, pre, k) in images else None
        order = np.log2(e2 / e0) if e2 is not None and 0 < e0 < e2 else None
        if order is None:
            # No fit: bisect the octave, a factor of `between` at a time.
            for f in between:
                c = h * f
                e = error(c, pre, k) if c <= longest else np.inf
                if e <= budget:
                    h, err = c, e
            return h, err
        # The fit predicts each step of the octave (the products of
        # `between`'s factors): the largest predicted within the budget is
        # tried first and the next smaller ones only while they fail; one
        # predicted over PREDICTED_FAIL times the budget is not rendered.
        steps = sorted({h0 * float(np.prod(c)) for r in range(1, len(between) + 1)
                        for c in itertools.combinations(between, r)}, reverse=True)
        for c in steps:
            predicted = e0 * (c / h0) ** order
            if c > longest or predicted > PREDICTED_FAIL * budget:
                continue
            e = error(c, pre, k)
            if e <= budget:
                return c, e
        return h, err

    def segment_kinds(h, err, pre, first_pre):
        """Pre-integrated segments from `first_pre`, then refined ones, each
        taken where it beats the choice so far (h, err, pre; h None: none)."""
        k, h_pre, h_ref = 0, 0.0, 0.0
        if first_pre <= longest and error(first_pre, True) <= budget:
            h_pre, err_pre = largest_step(first_pre, True)
            if h is None or h_pre > PREINTEGRATED_COST * h:
                pre, h, err = True, h_pre, err_pre
        # Refined segments, where they are cheaper than both: searched from
        # REFINED_START times the step of the choice so far over its weight
        # (not where a pilot there already costs twice the choice so far:
        # refinement then fires on most segments, and its reach grows with
        # the step), and taken where the pilot at the largest step they
        # keep within the budget costs less.
        weight = PREINTEGRATED_COST if pre else 1.0
        first = first_pre if h is None else REFINED_START * h / weight

        def cost(h_k):
            return refined_cost(samples_taken(h_k, True, REFINE), samples_taken(h_k, True, 0))

        if first <= longest:
            so_far = np.inf if h is None else weight * samples_taken(h, pre, 0)
            # Where the choice so far is pre-integrated, the refined cost at
            # its step, times that step over `first`, bounds the cost at
            # `first` from below (segments fall as 1 / h; refined ones get
            # no rarer as segments lengthen and their values reach further)
            # without a table for `first`: on the accuracy benchmark's
            # scenes it lay 1-17% under the cost it bounds.
            bound = cost(h) * h / first if pre else 0.0
            if bound < 2 * so_far and cost(first) < 2 * so_far and error(first, True, REFINE) <= budget:
                h_ref, err_ref = largest_step(first, True, between=(2**0.5,), leap=2, k=REFINE)
                if cost(h_ref) < so_far:
                    pre, k, h, err = True, REFINE, h_ref, err_ref
        return h, err, pre, k, h_pre, h_ref

    ea = cfg.model == "emission_absorption"
    tf_step = tf_limited_step(feats)
    tf_limited = tf_step < 0.5 * feats["spacing"]
    h, err, pre, k, h_mid, h_pre, h_ref = None, 0.0, False, 0, 0.0, 0.0, 0.0
    if ea and tf_step < SEGMENTS_ONLY * feats["spacing"]:
        # The transfer function's features are so narrow against the voxels
        # that midpoint pilots would have to sample them finer still (the
        # helix's step threshold: 0.003 of a voxel), at many times a
        # segment kind's frame. The segment kinds are searched alone,
        # against a pre-integrated reference, whose segments integrate the
        # transfer function exactly along their ramp; where it has a step,
        # which the table blurs, a refined one, whose refined segments sample
        # the volume REFINE times as finely (where the midpoint reference
        # would resolve the same threshold).
        # Where neither passes at its start, the reference's step is halved
        # once; then the full search below decides.
        h_seg = feats["spacing"] / (2 * SEGMENT_START) * OFF_GRID * max(1.0, max_error_levels) ** 0.5
        ref_refine = REFINE if tf_has_step(renderer.lut) else 0
        for _attempt in range(2):
            reference = (h_seg, True, ref_refine)
            h, err, pre, k, h_pre, h_ref = segment_kinds(None, 0.0, False, 2 * h_seg)
            if h is not None:
                break
            h_seg /= 2
    if h is None:
        h_fine = max(initial_step(feats, cfg.reference_step_size) / 4, feats["spacing"] / 16)
        h_fine *= max(1.0, max_error_levels) ** 0.5
        for attempt in range(4):
            reference = (h_fine, False, 0)
            h, err = largest_step(h_fine, leap=4, final=attempt == 3)
            if h > h_fine or attempt == 3:
                break
            h_fine /= 2
        h_mid = h
        if ea and tf_limited and 1.5 * h <= longest:
            h, err, pre, k, h_pre, h_ref = segment_kinds(h, err, False, 1.5 * h)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        out = cfg.replace(step_size=h, max_steps=int(np.ceil(longest / h)) + 2, pre_integrated=pre, refine=k,
                          jitter=False, early_ray_termination=threshold < 1.0, opacity_threshold=max(0.0, threshold))
    return out, {"step": h, "pilot_step_error": err, "pilot_fine_step": reference[0],
                 "reference": "refined" if reference[2] else "pre-integrated" if reference[1] else "midpoint",
                 "threshold": threshold,
                 "tf_limited_step": tf_step,
                 "pre_integrated": pre, "refine": k, "midpoint_step": h_mid, "pre_integrated_step": h_pre,
                 "refined_step": h_ref,
                 "pilot_renders": len(images) + len(samples), "pilot_size": size,
                 "seconds": time.perf_counter() - started, **feats}
