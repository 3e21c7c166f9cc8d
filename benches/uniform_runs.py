"""Uniform runs: frames with runs through uniform cells taken as one segment
(``renderer.uniform_runs``, the default) against the same frames marched
one segment at a time through them (empty cells are leapt in both), on
scenes made of constant regions in [-1, 1]^3: the 256^3 Shepp-Logan phantom under the
accuracy benchmark's transfer function, and a 256^3 uint8 label map (four
labelled ellipsoids in a labelled background, every label visible, so no
cell is empty). Ambient light (runs need colour and opacity from the table
alone), 512x512, isometric camera at distance 3, early termination at 0.95;
midpoint and pre-integrated segments (whose cells are judged over the
values of whole segments, so the share of uniform cells falls with the step).
Frames alternate between the two settings; median of --frames each after a
warm-up.

    .venv/bin/python benches/uniform_runs.py [--frames 5]

Prints the table and writes out/uniform_runs.json (docs/performance.md's table).
"""

import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import shepp_logan_3d  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

STEPS = [0.0025, 0.005, 0.01, 0.02, 0.04]
BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))


def label_map(n):
    """Four ellipsoids of labels 1-4 in a background of label 0, as uint8."""
    c = (np.arange(n) + 0.5) / n * 2 - 1
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    lab = np.zeros((n, n, n), np.uint8)
    for k, (x0, y0, z0, a, b, cc) in enumerate([(0.0, 0.0, 0.0, 0.8, 0.6, 0.7), (-0.3, 0.2, 0.1, 0.3, 0.25, 0.4),
                                                 (0.35, -0.2, 0.0, 0.25, 0.3, 0.2), (0.1, 0.3, -0.35, 0.2, 0.2, 0.2)]):
        inside = ((x - x0) / a) ** 2 + ((y - y0) / b) ** 2 + ((z - z0) / cc) ** 2 <= 1
        lab[inside] = 60 * (k + 1)
    return lab


def scenes():
    shepp_otf = OpacityTransferFunction([(0.0, 0.0), (0.15, 0.0), (0.25, 0.02), (0.35, 0.3), (1.0, 0.05)])
    yield "Shepp-Logan", Volume(shepp_logan_3d(256), None, *BOX), ColorTransferFunction.from_colormap("bone"), shepp_otf
    ctf = ColorTransferFunction([(0.0, (0.2, 0.3, 0.9)), (0.25, (0.9, 0.2, 0.1)), (0.5, (0.1, 0.8, 0.2)),
                                 (0.75, (0.9, 0.9, 0.2)), (1.0, (1.0, 1.0, 1.0))])
    otf = OpacityTransferFunction([(0.0, 0.002), (0.25, 0.01), (0.5, 0.03), (0.75, 0.2), (1.0, 0.5)])
    yield "label map (uint8)", Volume(label_map(256), None, *BOX), ctf, otf


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=5)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rows, device = [], ""
    for name, vol, ctf, otf in scenes():
        r = VolumeRenderer(512, 512, light=Light.ambient_only(1.0))
        device = r.device
        r.load_volume(vol)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ctf, otf)
        for kind, step in [(k, h) for k in ("midpoint", "pre-integrated") for h in STEPS]:
            cfg = RenderConfig(step_size=step, max_steps=5000, pre_integrated=kind == "pre-integrated")
            times, samples, images = {False: [], True: []}, {}, {}
            for runs in (False, True):
                r.uniform_runs = runs
                r.render(config=cfg)  # warm-up
            for _ in range(args.frames):
                for runs in (False, True):
                    r.uniform_runs = runs
                    t = time.perf_counter()
                    images[runs] = r.render(dtype=np.float32, premultiplied=True, config=cfg)
                    times[runs].append((time.perf_counter() - t) * 1e3)
                    samples[runs] = r.last_frame_stats["samples"]
            off, on = float(np.median(times[False])), float(np.median(times[True]))
            diff = float(np.abs(images[True] - images[False]).max() * 255)
            rows.append([name, kind, step, f"{r.uniform_fraction():.2f}", round(off, 1), round(on, 1),
                         f"{off / on:.2f}", f"{samples[True] / samples[False]:.2f}", f"{diff:.4f}"])
            print(*rows[-1], sep="\t", flush=True)
    write_table("uniform_runs", f"python benches/uniform_runs.py --frames {args.frames}",
                ["scene", "segments", "step", "uniform cells (of visible)", "runs off: ms", "runs on: ms", "off / on",
                 "samples on / off", "max image difference, levels"], rows, device=device,
                note="512x512, ambient light, early termination at 0.95, empty cells leapt in both; median of "
                     f"{args.frames} alternating frames each after a warm-up.")


if __name__ == "__main__":
    main()
