"""The speed/accuracy trade, measured: error against a converged image and
frame time, for our engine and its peers, on the same scenes in one run.

Scenes: pyvr's benchmark scene (256^3 double_sphere with normals, [-1,1]^3,
512x512, isometric camera at distance 3), the 3-D Shepp-Logan phantom
(256^3, dense, CT-like), a helix (sparse), ../shared/data/fuel.vti when
present, a torus under a TF of narrow peaks (high frequency), and an
anisotropic non-cubic volume; all but the first at 256x256.

Engines: ours at each preset, at a sweep of steps (no early termination),
the same sweep pre-integrated (pyvr-preint) and at error-targeted configs
(targets 1 and 4 levels), and for volumes with normals the presets and
sweep again with float16 storage (pyvr-f16); the moderngl/GLSL
reference (pyvr's semantics) at each preset; VTK's CPU
(vtkFixedPointVolumeRayCastMapper) and GPU (vtkGPUVolumeRayCastMapper) ray
casters from the `vtk` wheel, headless through EGL, at a sweep of sample
distances. Ours and the reference are scored against the float64
integrator's converged image (steps halved until Richardson's estimate of
its error is under 0.1 level); each VTK mapper against its own finest image.

Errors: premultiplied RGBA (VTK: RGB over black) in 8-bit levels, max and
RMSE (pyvr.accuracy); where ours are matched with VTK's frames, by their
RGB error. Times: for every engine and config alike, one warm-up frame
(pipeline compilation, VTK's gradient encoding, first uploads) and then the
median of --frames (3) frames, readback included.

Output: a table per scene on stdout, JSON (--json) and a log-log plot of
max error against time (--plot), one curve per engine.

Run: .venv/bin/python benches/accuracy.py [--frames N] [--quick] [--no-vtk]
"""

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "examples"))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
os.environ.setdefault("PYVR_BACKEND", "vulkan")  # keep wgpu off the EGL context moderngl and VTK use
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from _common import out_path  # noqa: E402
from peers import VtkPeer  # noqa: E402

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer, accuracy  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume, load_vti, shepp_logan_3d  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

FUEL = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "fuel.vti")
BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]
SWEEP = [0.0025, 0.005, 0.007, 0.01, 0.014, 0.02, 0.028, 0.04, 0.057, 0.08, 0.113, 0.16]
VTK_SWEEP = [0.01, 0.02, 0.04, 0.08]
TARGETS = [1.0, 4.0]
# Searches timed per target (the median is reported): a single search
# varied by up to 15% between runs on the 2-core VM.
CHOICES = 3
# Halvings of the float64 reference's step before it gives up converging:
# the helix needs five (Richardson's estimate 1.4 levels after three, 0.08
# after five), the other scenes stop earlier.
REFERENCE_HALVINGS = 5


def scenes(quick):
    n = 96 if quick else 256
    px = 128 if quick else 256
    out = []
    ds = create_sample_volume(n, "double_sphere")
    out.append(("benchmark", Volume(ds, compute_normal_volume(ds), *BOX), ColorTransferFunction.from_colormap("plasma"),
                OpacityTransferFunction.linear(0.0, 0.1), Light.default(), 2 * px))
    out.append(("shepp_logan", Volume(shepp_logan_3d(n), None, *BOX), ColorTransferFunction.from_colormap("bone"),
                OpacityTransferFunction([(0.0, 0.0), (0.15, 0.0), (0.25, 0.02), (0.35, 0.3), (1.0, 0.05)]),
                Light.ambient_only(1.0), px))
    out.append(("helix (sparse)", Volume(create_sample_volume(n // 2, "helix"), None, *BOX),
                ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.one_step(0.5, 0.0, 0.6),
                Light.default(), px))
    if os.path.exists(FUEL):
        fuel = (load_vti(FUEL).data / np.float32(255.0)).astype(np.float32)
        out.append(("fuel.vti", Volume(fuel, None, *BOX), ColorTransferFunction.from_colormap("inferno"),
                    OpacityTransferFunction.linear(0.0, 0.5), Light.ambient_only(1.0), px))
    out.append(("narrow peaks (torus)", Volume(create_sample_volume(n // 2, "torus"), None, *BOX),
                ColorTransferFunction.from_colormap("viridis"),
                OpacityTransferFunction.peaks([0.25, 0.5, 0.75], opacity=0.6, eps=0.02), Light.ambient_only(1.0), px))
    aniso = create_sample_volume(n // 2, "random_blob")[:, : n // 4, : n // 8]
    out.append(("anisotropic", Volume(np.ascontiguousarray(aniso), None, np.array([-1.2, -0.5, -0.3], np.float32),
                                      np.array([1.2, 0.5, 0.3], np.float32)),
                ColorTransferFunction.from_colormap("magma"), OpacityTransferFunction.linear(0.0, 0.3),
                Light.default(), px))
    return out


def timed(fn, frames):
    """The median time of `frames` frames after one warm-up frame, and the
    last image."""
    first = fn()
    times = []
    for _ in range(frames):
        t = time.perf_counter()
        first = fn()
        times.append(time.perf_counter() - t)
    return first, float(np.median(times) * 1e3)


def run_scene(scene, frames, use_reference):
    """Ours and the moderngl reference; returns the result and the LUT."""
    name, vol, ctf, otf, light, px = scene
    cam = Camera.isometric_view(distance=3.0)
    r = VolumeRenderer(px, px, light=light)
    r.load_volume(vol)
    r.set_camera(cam)
    r.set_transfer_functions(ctf, otf)
    t = time.perf_counter()
    conv, info = accuracy.converged_image(r, tolerance=0.1, max_halvings=REFERENCE_HALVINGS)
    res = {"scene": name, "pixels": px, "converged": {**info, "seconds": time.perf_counter() - t}, "points": []}
    conv_rgb = colour_only(conv)
    res["peak_rgb"] = peak_level(conv_rgb)

    def ours(label, cfg, kind, engine="pyvr"):
        r.set_config(cfg)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            img, ms = timed(lambda: r.render(dtype=np.float32, premultiplied=True), frames)
        samples = r.last_frame_stats["samples"]
        res["points"].append({"engine": engine, "kind": kind, "label": label, "step": cfg.step_size, "ms": ms,
                              "samples_per_s": samples / ms * 1e3, **accuracy.error_metrics(img, conv),
                              "max_rgb": accuracy.error_metrics(colour_only(img), conv_rgb)["max"]})

    def sweep(engine="pyvr", **fields):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for h in SWEEP:
                cfg = RenderConfig(step_size=h, max_steps=int(3.5 / h) + 2, early_ray_termination=False)
                ours(f"step {h}", cfg.replace(**fields), "sweep", engine)

    for p in PRESETS:
        ours(p, getattr(RenderConfig, p)(), "preset")
    sweep()
    sweep("pyvr-preint", pre_integrated=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r.set_config(RenderConfig.balanced())
        # The data's gradient is measured once per loaded volume; the
        # choices below reuse it.
        t = time.perf_counter()
        accuracy.scene_features(r)
        res["data_features_s"] = time.perf_counter() - t
        for target in TARGETS:
            picks = []
            for _ in range(CHOICES):
                # Each search starts cold, as after a user's new transfer
                # function: the tables kept from earlier pilots are dropped,
                # and one frame of each kind rebuilds what frames share
                # (the occupancy grids).
                r.set_transfer_functions(ctf, otf)
                for pre in (False, True):
                    r.render(dtype=np.float32, premultiplied=True,
                             config=RenderConfig.balanced().replace(pre_integrated=pre))
                t = time.perf_counter()
                cfg, info = accuracy.config_for_error(r, target)
                picks.append(time.perf_counter() - t)
            pick = float(np.median(picks))
            ours(f"target {target:g}", cfg, "target")
            chosen = res["points"][-1]
            chosen.update({"target": target, "choose_s": pick, "pilot_renders": info["pilot_renders"],
                           "pre_integrated": cfg.pre_integrated})
            # Larger steps than the chosen one: the cheapest step that meets
            # the target (and all smaller ones) bounds what the choice costs.
            cheapest = cfg.step_size
            for f in (2**0.5, 2.0, 2**1.5):
                ours(f"target {target:g} x{f:.2g}", cfg.replace(step_size=cfg.step_size * f), "probe")
                if res["points"][-1]["max"] > target:
                    break
                cheapest = cfg.step_size * f
            chosen["cheapest_step_found"] = cheapest
            chosen["cost_vs_cheapest"] = cheapest / cfg.step_size
            chosen["cost_vs_cheapest_bound"] = min(2**1.5, 2**0.5 * cheapest / cfg.step_size)
            # The fastest frame of this run (sweeps of both kinds, probes)
            # that meets the target.
            ok = [p for p in res["points"] if p["engine"] in ("pyvr", "pyvr-preint") and p["max"] <= target]
            fastest = min(ok, key=lambda p: p["ms"], default=None)
            chosen["fastest_meeting"] = short(fastest) if fastest else "none"
            chosen["time_vs_fastest"] = chosen["ms"] / fastest["ms"] if fastest else float("nan")

    if vol.normals is not None and vol.data.dtype == np.float32:
        # The same sweep with the values (and normals) in one float16 texel.
        r.load_volume(vol, precision="float16")
        for p in PRESETS:
            ours(p, getattr(RenderConfig, p)(), "preset", "pyvr-f16")
        sweep("pyvr-f16")
        r.load_volume(vol)

    if use_reference:
        from reference.moderngl_reference import ReferenceRenderer

        ref = ReferenceRenderer(vol, ctf, otf, px, px)
        try:
            for p in PRESETS:
                cfg = getattr(RenderConfig, p)()
                img, ms = timed(lambda: ref.render(cam, light, cfg), frames)  # noqa: B023 (called at once)
                res["points"].append({"engine": "moderngl", "kind": "preset", "label": p, "step": cfg.step_size,
                                      "ms": ms, **accuracy.error_metrics(img, conv)})
        finally:
            ref.release()

    return res, r.lut


def run_vtk(scene, lut, res, frames):
    """VTK's mappers, after every moderngl frame: VTK's EGL windows leave
    their own context current, which moderngl's would not survive."""
    name, vol, ctf, otf, light, px = scene
    cam = Camera.isometric_view(distance=3.0)
    for kind in ("cpu", "gpu"):
        peer = VtkPeer(kind, vol, lut, cam, light, (px, px), RenderConfig().reference_step_size)
        try:
            finest = peer.render(VTK_SWEEP[0] / 2)
            # How far the finest image itself is from one at half its
            # distance: the scale below which errors against it say little.
            settled = accuracy.error_metrics(finest, peer.render(VTK_SWEEP[0] / 4))["max"]
            for h in VTK_SWEEP:
                img, ms = timed(lambda: peer.render(h), frames)  # noqa: B023 (called at once)
                m = accuracy.error_metrics(img, finest)
                res["points"].append({"engine": f"vtk-{kind}", "kind": "sweep", "label": f"step {h}", "step": h,
                                      "ms": ms, "finest_vs_half": settled, "peak": peak_level(finest), **m})
        finally:
            peer.release()


def colour_only(img):
    """A premultiplied RGBA image with its alpha set to 0: what VTK's frames
    (RGB over black, read from the window) can be compared on."""
    out = np.array(img, np.float64)
    out[..., 3] = 0.0
    return out


def peak_level(img):
    """The brightest colour channel of a premultiplied image, in 8-bit levels:
    the largest error a frame scored against it can have there."""
    return float(np.clip(np.asarray(img, np.float64)[..., :3], 0, 1).max() * accuracy.LEVELS)


def cheapest_relative(res, p):
    """Our fastest frame whose colour error, as a fraction of the brightest
    level of the image it is scored against, is at most the peer point p's.
    VTK lights a scene its own way: its helix peaks at 101 levels where ours
    peaks at 149, so a pixel it misses whole costs it 101 levels and us 149."""
    if not p.get("peak") or not res.get("peak_rgb"):
        return None
    bound = p["max"] / p["peak"] * res["peak_rgb"]
    return cheapest_at(res["points"], bound, "max_rgb")


def cheapest_at(points, max_error, key="max"):
    """Our fastest frame whose error `key` ("max": RGBA; "max_rgb": colour
    only, as VTK's frames are scored) is at most max_error."""
    ok = [p for p in points if p["engine"].startswith("pyvr") and p[key] <= max_error]
    return min(ok, key=lambda p: p["ms"]) if ok else None


def peer_key(p):
    """The error of ours a peer's point is matched on: VTK's frames hold no
    alpha, so ours are matched on their colour channels."""
    return "max_rgb" if p["engine"].startswith("vtk") else "max"


def report(res):
    print(f"\n== {res['scene']} ({res['pixels']}x{res['pixels']}); converged: step {res['converged']['step']:.4g}, "
          f"estimated error {res['converged']['estimated_max_error']:.3f} levels, {res['converged']['seconds']:.0f} s")
    print(f"{'engine':<9} {'config':<15} {'step':>7} {'ms':>8} {'max err':>8} {'rmse':>7} {'>1 lvl':>7} "
          f"{'ours at <= err':>15}")
    for p in res["points"]:
        if p["kind"] == "probe":
            continue
        best = cheapest_at(res["points"], p["max"], peer_key(p))
        vs = (f"{p['ms'] / best['ms']:6.1f}x ({best['engine']} {best['label']})"
              if best and not p["engine"].startswith("pyvr") else "")
        rel = cheapest_relative(res, p) if p["engine"].startswith("vtk") else None
        if rel:
            vs += f"; relative to peak ({p['peak']:.0f} / {res['peak_rgb']:.0f}): {p['ms'] / rel['ms']:.1f}x " \
                  f"({rel['engine']} {rel['label']})"
        if "target" in p:
            ok = "met" if p["max"] <= p["target"] else "MISSED"
            vs = (f"{ok}; costs {p['cost_vs_cheapest']:.2f}-{p['cost_vs_cheapest_bound']:.2f}x the cheapest step "
                  f"meeting it; chosen in {p['choose_s']:.1f} s")
        print(f"{p['engine']:<9} {p['label']:<15} {p['step']:7.4g} {p['ms']:8.1f} {p['max']:8.2f} {p['rmse']:7.3f} "
              f"{p['frac_over_1'] * 100:6.2f}% {vs}")


def short(p):
    """A point's config and time: 'step 0.08, 258' (float16 storage and
    pre-integration marked)."""
    mark = {"pyvr-f16": " (float16)", "pyvr-preint": " (pre-integrated)"}.get(p["engine"], "")
    return f"{p['label']}{mark}, {p['ms']:.0f}"


def write_tables(results, command, device):
    """The tables docs/performance.md shows, from this run's results."""
    presets, f16, targets, peers = [], [], [], []
    for res in results:
        pts = [p for p in res["points"] if p["kind"] != "probe"]
        ref = {p["label"]: p for p in pts if p["engine"] == "moderngl"}
        for p in pts:
            if p["engine"] == "pyvr" and p["kind"] == "preset":
                r = ref.get(p["label"])
                best = cheapest_at(pts, r["max"]) if r else None
                presets.append([res["scene"], p["label"], f"{p['ms']:.0f}", f"{p['max']:.1f}",
                                f"{r['ms']:.0f}" if r else "", f"{short(best)}, {r['ms'] / best['ms']:.1f}x" if best else ""])
            if "target" in p:
                kind = " (pre-integrated)" if p.get("pre_integrated") else ""
                targets.append([res["scene"], f"{p['target']:g}", f"{p['step']:.4g}{kind}", f"{p['ms']:.0f}",
                                f"{p['max']:.2f}", f"{res['converged']['estimated_max_error']:.2f}",
                                f"{p['cost_vs_cheapest']:.2f}-{p['cost_vs_cheapest_bound']:.2f}x",
                                f"{p['fastest_meeting']}: {p['time_vs_fastest']:.2f}x",
                                f"{p['choose_s'] * 1e3:.0f} ms, {p['choose_s'] * 1e3 / p['ms']:.1f} frames, "
                                f"{p['pilot_renders']} pilots"])
            if p["engine"].startswith("vtk"):
                best = cheapest_at(pts, p["max"], peer_key(p))
                rel = cheapest_relative({**res, "points": pts}, p)
                peers.append([res["scene"], p["engine"], f"{p['step']:g}", f"{p['ms']:.0f}", f"{p['max']:.0f}",
                              f"{p['finest_vs_half']:.0f}",
                              f"{short(best)}, {p['ms'] / best['ms']:.1f}x" if best else "",
                              f"{p['peak']:.0f} / {res['peak_rgb']:.0f}",
                              f"{short(rel)}, {p['ms'] / rel['ms']:.1f}x" if rel else ""])
        if any(p["engine"] == "pyvr-f16" for p in pts):
            for label, r in ref.items():
                row = [res["scene"], label, f"{r['ms']:.0f}", f"{r['max']:.1f}"]
                for engine in ("pyvr", "pyvr-f16"):
                    ok = [p for p in pts if p["engine"] == engine and p["max"] <= r["max"]]
                    best = min(ok, key=lambda p: p["ms"]) if ok else None
                    row.append(f"{short(best)}, {r['ms'] / best['ms']:.1f}x" if best else "")
                f16.append(row)
    errors = ("Errors: max of premultiplied RGBA in 8-bit levels against the float64 integrator's converged "
              "image (VTK: against its own finest image). Times: for every engine alike, the median of --frames "
              "frames after one warm-up frame.")
    write_table("accuracy_presets", command,
                ["scene", "preset", "pyvr ms", "max err", "moderngl ms", "pyvr at <= its error: config, ms, speed-up"],
                presets, device=device, note=errors + " Per preset ours and the moderngl reference render the same "
                "rule; the last column is our cheapest configuration (preset, sweep step or error target) with equal "
                "or lower error, and how much faster it is than the reference's preset.")
    if f16:
        write_table("accuracy_float16", command,
                    ["scene", "reference preset", "moderngl ms", "max err", "pyvr float32 at <= its error",
                     "pyvr float16 at <= its error"], f16, device=device, note=errors)
    write_table("accuracy_targets", command,
                ["scene", "target (levels)", "step", "ms", "measured max", "reference's own error (estimate)",
                 "cost vs cheapest step meeting it",
                 "fastest frame meeting it: config, ms: chosen / fastest", "chosen in"], targets, device=device,
                note="config_for_error with its default pilot (a quarter of the frame's side, at least 64). Cost: "
                "the chosen step against the largest step, probed at sqrt(2)x and 2x, that still meets the target; "
                "and the chosen frame's time against the fastest frame of this run (sweeps, pre-integrated sweeps, "
                "probes) within the target. The reference's own error is Richardson's estimate for the converged "
                "image the errors are measured against: a measured max within it of the target cannot tell a miss. "
                f"Chosen in: the median of {CHOICES} searches' times, each cold (after the transfer function is "
                "set again, which drops the tables kept from earlier pilots, and a frame of each kind), also in "
                "frames of the chosen config; the data's gradient is measured once per loaded volume before them "
                "(under 0.4 s for 256^3).")
    if peers:
        write_table("accuracy_vtk", command,
                    ["scene", "peer", "sample distance", "ms", "max err vs own finest", "finest vs half its distance",
                     "pyvr at <= that error (colour): config, ms, peer / pyvr", "peak level: peer / pyvr",
                     "pyvr at <= that error relative to peak: config, ms, peer / pyvr"], peers, device=device,
                    note=errors + f" VTK's frames hold colour over black and no alpha, so they are scored on RGB, and "
                    f"the frame of ours matched with each is chosen by its RGB error too. VTK's finest image is at "
                    f"distance {VTK_SWEEP[0] / 2:g}; 'finest vs half' is its max error against VTK's frame at "
                    "half that distance. VTK lights and colours a scene its own way, so its images and ours peak at "
                    "different levels (the brightest colour channel of the image each is scored against); the last "
                    "column matches errors as fractions of those peaks, the one before last in levels.")


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 3
    rows = (len(results) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 4 * rows), squeeze=False)
    style = {"pyvr": "o-", "pyvr-f16": "o-.", "pyvr-preint": "D-", "moderngl": "s--", "vtk-cpu": "^:",
             "vtk-gpu": "v:"}
    for ax, res in zip(axes.ravel(), results):
        for engine, fmt in style.items():
            for kind in ("sweep", "preset", "target"):
                pts = sorted((p for p in res["points"] if p["engine"] == engine and p["kind"] == kind),
                             key=lambda p: p["ms"])
                if pts:
                    ax.loglog([p["ms"] for p in pts], [max(p["max"], 1e-3) for p in pts],
                              fmt if kind != "target" else "*", label=f"{engine} {kind}", markersize=5)
        ax.set_title(res["scene"])
        ax.set_xlabel("frame time (ms)")
        ax.set_ylabel("max error (levels)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(results):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="smaller volumes and images (a smoke run)")
    ap.add_argument("--no-vtk", action="store_true")
    ap.add_argument("--no-reference", action="store_true")
    ap.add_argument("--only", help="run only scenes whose name contains this")
    ap.add_argument("--json", default=out_path("accuracy.json"))
    ap.add_argument("--plot", default=out_path("accuracy.png"))
    args = ap.parse_args()
    use_vtk = not args.no_vtk
    if use_vtk:
        try:
            import vtk  # noqa: F401
        except ImportError:
            print("vtk is not installed (pip install vtk): VTK peers skipped")
            use_vtk = False
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    t0 = time.perf_counter()
    chosen = [sc for sc in scenes(args.quick) if not args.only or args.only in sc[0]]
    runs = []
    for sc in chosen:
        print(f"rendering {sc[0]} (ours, reference)...", flush=True)
        runs.append((sc, *run_scene(sc, args.frames, not args.no_reference)))
    results = []
    for sc, res, lut in runs:
        if use_vtk:
            run_vtk(sc, lut, res, args.frames)
        report(res)
        results.append(res)
    with open(args.json, "w") as f:
        json.dump(results, f, indent=1)
    flags = " ".join(f for f, on in (("--quick", args.quick), ("--no-vtk", not use_vtk),
                                     ("--no-reference", args.no_reference)) if on)
    if not args.only:
        write_tables(results, f"benches/accuracy.py --frames {args.frames} {flags}".strip(),
                     VolumeRenderer(8, 8).device)
    plot(results, args.plot)
    print(f"\njson: {os.path.normpath(args.json)}\nplot: {os.path.normpath(args.plot)}\n"
          f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
