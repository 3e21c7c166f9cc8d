"""What pre-integration costs and what it buys, on the six scenes of
benches/accuracy.py (same volumes, transfer functions, lights, cameras and
image sizes).

Cost: a pre-integrated frame against a plain (midpoint) frame at the same
step, with the preset's early termination and empty-space skipping, for
each step in --steps. Both are rendered alternately (a warm-up each, then
--frames of each in turn) and compared by their medians, so drift on a
shared machine falls on both.

Gain: for each scene and for max errors of --targets levels, the cheapest
frame of each kind (plain, pre-integrated, pre-integrated with refined
segments) that stays within the target, over a sweep of steps without early
termination (as in benches/accuracy.py; on a GPU adapter with exact
filtering), scored against the float64 integrator's converged image. The last columns are how much less time each
pre-integrated kind needs than plain frames for the same error.

Table: what a new step (or a new transfer function) costs a pre-integrated
frame, which builds its table then, for lookup tables of 256 to 4096
entries: the first frame at each of several new steps against a warm frame
at the same step, and a frame back at a step whose table was kept.

Output: tables on stdout, out/preintegration_cost.json,
out/preintegration_gain.json and out/preintegration_table.json
(docs/performance.md).

Run: .venv/bin/python benches/preintegration.py [--frames N] [--quick] [--only NAME]
"""

import argparse
import copy
import os
import sys
import time
import warnings

import numpy as np

os.environ.setdefault("TQDM_DISABLE", "1")  # the float64 integrator's progress bars

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from accuracy import REFERENCE_HALVINGS, SWEEP, scenes  # noqa: E402
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer, accuracy  # noqa: E402
from pyvr.renderer import device_limits  # noqa: E402
from pyvr.camera import Camera  # noqa: E402

STEPS = [0.005, 0.01, 0.02, 0.04, 0.08]
# Lookup-table sizes for the table-build figures (the table's side stops at 512).
TABLE_SIZES = [256, 1024, 4096]
# The accuracy sweep, and smaller steps for midpoint frames of narrow peaks
# and for the helix (4 levels at 0.0003).
GAIN_SWEEP = SWEEP + [0.00125, 0.000625, 0.0003125]
TARGETS = [1.0, 4.0]
# Samples a refined pre-integrated segment takes (RenderConfig.refine): the
# number config_for_error tries.
REFINE = accuracy.REFINE
# The gain table's kinds: (pre_integrated, refine).
KINDS = {"plain": (False, 0), "pre-integrated": (True, 0), "refined": (True, REFINE)}


def renderer_for(scene):
    name, vol, ctf, otf, light, px = scene
    r = VolumeRenderer(px, px, light=light)
    r.load_volume(vol)
    r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ctf, otf)
    return r


def frame(r, cfg):
    r.set_config(cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        img = r.render(dtype=np.float32, premultiplied=True)
        return img, time.perf_counter() - t, r.last_frame_stats["samples"]


def alternate(r, configs, frames):
    """Median ms and samples of each config, rendered in turn after a warm-up each."""
    for cfg in configs:
        frame(r, cfg)
    times = [[] for _ in configs]
    samples = [0] * len(configs)
    for _ in range(frames):
        for k, cfg in enumerate(configs):
            _, dt, samples[k] = frame(r, cfg)
            times[k].append(dt)
    return [float(np.median(t) * 1e3) for t in times], samples


def cost(scene, steps, frames):
    r = renderer_for(scene)
    rows = []
    for h in steps:
        base = RenderConfig.balanced().replace(step_size=h, max_steps=int(3.5 / h) + 2)
        (plain, pre), (n_plain, n_pre) = alternate(r, [base, base.replace(pre_integrated=True)], frames)
        rows.append([scene[0], h, round(plain, 1), round(pre, 1), f"{pre / plain:.2f}x",
                     f"{n_plain / 1e6:.2f} / {n_pre / 1e6:.2f}"])
        print(f"  {scene[0]:<22} step {h:<6} plain {plain:8.1f} ms  pre-integrated {pre:8.1f} ms  "
              f"{pre / plain:5.2f}x  samples {n_plain / 1e6:.2f} / {n_pre / 1e6:.2f} M", flush=True)
    return rows


def gain(scene, targets, frames, sweep):
    r = renderer_for(scene)
    # On a GPU the texture units weigh texels in 8-bit fixed point, a floor
    # under the error of steep transfer functions that no step lowers:
    # frames there interpolate exactly, as config_for_error's do.
    exact = not device_limits()["cpu_device"]
    t = time.perf_counter()
    conv, info = accuracy.converged_image(r, tolerance=0.1, max_halvings=REFERENCE_HALVINGS)
    print(f"  {scene[0]}: converged at step {info['step']:.4g} in {time.perf_counter() - t:.0f} s "
          f"(estimated error {info['estimated_max_error']:.2f} levels)", flush=True)
    # From the largest step down, each kind until it meets the smallest target.
    points = {kind: [] for kind in KINDS}
    for h in sorted(sweep, reverse=True):
        cfg = RenderConfig(step_size=h, max_steps=int(3.5 / h) + 2, early_ray_termination=False,
                           exact_filtering=exact)
        for kind, (pre, refine) in KINDS.items():
            if any(p[2] <= min(targets) for p in points[kind]):
                continue
            c = cfg.replace(pre_integrated=pre, refine=refine)
            img, _, _ = frame(r, c)
            (ms,), _ = alternate(r, [c], frames)
            points[kind].append((h, ms, accuracy.error_metrics(img, conv)["max"]))
    rows = []
    for target in targets:
        best = {}
        for kind in KINDS:
            ok = [p for p in points[kind] if p[2] <= target]
            best[kind] = min(ok, key=lambda p: p[1]) if ok else None
        cell = {kind: (f"step {b[0]:g}: {b[1]:.1f} ms, max {b[2]:.2f}" if b else "not reached (smallest step)")
                for kind, b in best.items()}
        ratios = [f"{best['plain'][1] / best[k][1]:.1f}x" if best["plain"] and best[k] else ""
                  for k in ("pre-integrated", "refined")]
        rows.append([scene[0], f"{target:g}", *cell.values(), *ratios])
        print(f"  {scene[0]:<22} <= {target:g} levels: " + "; ".join(f"{k} {c}" for k, c in cell.items())
              + f"; {' / '.join(ratios)}", flush=True)
    return rows


def table_build(scene, sizes, frames):
    """Per lookup-table size: a warm pre-integrated frame, the first frame
    at a new step (medians over `frames` new steps), their difference (the
    table), and a frame back at the step before (its table kept)."""
    name, vol, ctf, otf, light, px = scene
    rows = []
    for n in sizes:
        r = renderer_for(scene)
        c, o = copy.deepcopy(ctf), copy.deepcopy(otf)
        c.lut_size = o.lut_size = n
        r.set_transfer_functions(c, o)
        base = RenderConfig.balanced().replace(pre_integrated=True)
        frame(r, base)
        first, warm, back = [], [], []
        for k in range(frames):
            cfg = base.replace(step_size=base.step_size * (1 + 0.01 * (k + 1)))
            first.append(frame(r, cfg)[1])
            warm.append(frame(r, cfg)[1])
            back.append(frame(r, base if k == 0 else base.replace(step_size=base.step_size * (1 + 0.01 * k)))[1])
        ms = [float(np.median(t) * 1e3) for t in (warm, first, back)]
        rows.append([name, n, round(ms[0], 2), round(ms[1], 2), round(ms[1] - ms[0], 2), round(ms[2], 2)])
        print(f"  {name:<22} {n:5d} entries: warm {ms[0]:6.2f} ms, first at a new step {ms[1]:7.2f} ms "
              f"(table {ms[1] - ms[0]:6.2f} ms), back to a kept step {ms[2]:6.2f} ms", flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="smaller volumes and images (a smoke run)")
    ap.add_argument("--only", help="run only scenes whose name contains this")
    ap.add_argument("--no-gain", action="store_true", help="only the cost and table-build tables")
    args = ap.parse_args()
    chosen = [sc for sc in scenes(args.quick) if not args.only or args.only in sc[0]]
    t0 = time.perf_counter()
    print("cost at equal step (balanced: early termination and skipping on)")
    cost_rows = [row for sc in chosen for row in cost(sc, STEPS, args.frames)]
    print("what a new step costs: the table")
    table_rows = [row for sc in chosen if sc[0].split()[0] in ("narrow", "shepp_logan")
                  for row in table_build(sc, TABLE_SIZES, max(5, args.frames))]
    gain_rows = []
    if not args.no_gain:
        print("time for a max error")
        gain_rows = [row for sc in chosen for row in gain(sc, TARGETS, max(3, args.frames // 2), GAIN_SWEEP)]
    if args.only:
        return
    command = f"benches/preintegration.py --frames {args.frames}" + (" --quick" if args.quick else "")
    device = VolumeRenderer(8, 8).device
    write_table("preintegration_cost", command,
                ["scene", "step", "plain ms", "pre-integrated ms", "pre-integrated / plain", "samples (M): plain / pre"],
                cost_rows, device=device,
                note=f"The scenes of benches/accuracy.py, balanced (early termination, empty-space skipping); plain "
                f"and pre-integrated frames rendered alternately, median of {args.frames} each after a warm-up.")
    if table_rows:
        write_table("preintegration_table", command,
                    ["scene", "LUT entries", "warm frame ms", "first frame at a new step ms", "table ms",
                     "back to a kept step ms"],
                    table_rows, device=device,
                    note="Pre-integrated frames, balanced, at steps 1-5% apart (medians over as many new steps): "
                    "the first frame at a new step builds and uploads its table; the renderer keeps the last three "
                    "other steps' tables.")
    if gain_rows:
        write_table("preintegration_gain", command,
                    ["scene", "max error (levels)", "plain: cheapest frame within it",
                     "pre-integrated: cheapest frame within it",
                     f"pre-integrated, refine={REFINE}: cheapest frame within it",
                     "plain / pre-integrated time", "plain / refined time"],
                    gain_rows, device=device,
                    note="Steps " + ", ".join(f"{h:g}" for h in sorted(GAIN_SWEEP, reverse=True)) + " (each kind "
                    "down to the first that meets the smaller target) without early termination, each scored "
                    "against the float64 integrator's converged image (max of premultiplied RGBA in 8-bit levels); "
                    f"times are medians of warm frames. Refined: pre-integrated with refine={REFINE} (segments whose "
                    "values may reach an opacity change their ramp misses are taken as that many midpoint samples)."
                    + ("" if device_limits()["cpu_device"] else " On this GPU every frame of the sweep interpolates "
                       "exactly (exact_filtering), as config_for_error's do: the texture units' 8-bit weights put a "
                       "floor under the error that no step lowers."))
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
