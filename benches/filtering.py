"""What the texture units' interpolation costs in accuracy, and what exact
filtering (RenderConfig.exact_filtering: the volume's trilinear and the
tables' linear lookups done in the shader with f32 weights) costs in time.

GPUs' texture units weigh texels in fixed point with 8 fractional bits, so
a steep transfer function (a step, narrow peaks) sampled through them has an
error floor that smaller steps do not lower. On a CPU adapter both kinds of
frame interpolate in f32 (the native march, lavapipe), and the columns
agree.

Scenes: those of benches/accuracy.py whose transfer functions are steep or
whose references are tight (the helix, the narrow peaks, fuel.vti, Shepp-
Logan), at --steps, midpoint and pre-integrated, without early termination
(as the accuracy sweep). Errors: max premultiplied error in 8-bit levels
against the float64 integrator's converged image. Times: the median of
--frames frames after a warm-up, both kinds alike.

Run: .venv/bin/python benches/filtering.py [--frames N] [--quick]
"""

import argparse
import os
import sys
import warnings

import numpy as np

os.environ.setdefault("TQDM_DISABLE", "1")  # the float64 integrator's progress bars

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from accuracy import REFERENCE_HALVINGS, scenes, timed  # noqa: E402
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer, accuracy  # noqa: E402
from pyvr.camera import Camera  # noqa: E402

SCENES = ("shepp_logan", "helix (sparse)", "fuel.vti", "narrow peaks (torus)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--steps", default="0.00125,0.0025,0.005,0.01")
    ap.add_argument("--quick", action="store_true", help="smaller volumes and images (a smoke run)")
    args = ap.parse_args()
    steps = [float(s) for s in args.steps.split(",")]
    rows = []
    device = ""
    for name, vol, ctf, otf, light, px in scenes(args.quick):
        if name not in SCENES:
            continue
        r = VolumeRenderer(px, px, light=light)
        device = r.device
        r.load_volume(vol)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ctf, otf)
        conv, info = accuracy.converged_image(r, tolerance=0.1, max_halvings=REFERENCE_HALVINGS)
        print(f"== {name} ({px}x{px}); converged at step {info['step']:.4g}", flush=True)
        for pre in (False, True):
            for h in steps:
                cfg = RenderConfig(step_size=h, max_steps=int(3.5 / h) + 2, early_ray_termination=False,
                                   pre_integrated=pre)
                got = []
                for exact in (False, True):
                    r.set_config(cfg.replace(exact_filtering=exact))
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        img, ms = timed(lambda: r.render(dtype=np.float32, premultiplied=True), args.frames)  # noqa: B023
                    got.append((accuracy.error_metrics(img, conv)["max"], ms))
                kind = "pre-integrated" if pre else "midpoint"
                (e_hw, t_hw), (e_ex, t_ex) = got
                rows.append((name, kind, h, e_hw, e_ex, t_hw, t_ex))
                print(f"  {kind:15s} step {h:<8g} max error: texture units {e_hw:7.2f}, exact {e_ex:7.2f}; "
                      f"ms {t_hw:7.2f} / {t_ex:7.2f} ({t_ex / t_hw:.2f}x)", flush=True)
    print(f"device: {device}")
    write_table("filtering", f"benches/filtering.py --frames {args.frames}",
                ["scene", "kind", "step", "max error: texture units", "max error: exact", "ms: texture units",
                 "ms: exact", "exact / texture units"],
                [[n, k, h, f"{a:.2f}", f"{b:.2f}", f"{ta:.2f}", f"{tb:.2f}", f"{tb / ta:.2f}x"]
                 for n, k, h, a, b, ta, tb in rows],
                device=device, note="Max premultiplied error (8-bit levels) against the float64 integrator's "
                "converged image, no early termination; median of the frames after a warm-up. 'texture units': "
                "the sampler interpolates the volume and the tables; 'exact': exact_filtering=True.")


if __name__ == "__main__":
    main()
