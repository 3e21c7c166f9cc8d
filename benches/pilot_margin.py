"""How much a frame's maximum error exceeds its pilot's: the margin
config_for_error keeps when it measures steps on a pilot smaller than the
frame.

For each scene of benches/accuracy.py, at the finest pilot step
config_for_error starts from (h_f) and at 2, 4 and 8 times it: the frame's
maximum error against the converged image, and the default pilot's (a
quarter of the frame's side) against its own image at h_f. Their ratio is
what the pilot misses; config_for_error keeps the pilot within 0.4 of the
target and 0.2 for early termination, so ratios up to 2 are covered.

Run: .venv/bin/python benches/pilot_margin.py [--quick]
"""

import argparse
import os
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from accuracy import scenes  # noqa: E402  (also sets up the paths and backend)

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer, accuracy  # noqa: E402
from pyvr.camera import Camera  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small volumes and frames")
    args = ap.parse_args()
    rows = []
    for name, vol, ctf, otf, light, px in scenes(args.quick):
        r = VolumeRenderer(px, px, light=light)
        r.load_volume(vol)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ctf, otf)
        r.set_config(RenderConfig.balanced())
        conv, _ = accuracy.converged_image(r, tolerance=0.1)
        feats = accuracy.scene_features(r)
        longest = feats["longest_chord"]
        h_f = max(accuracy.initial_step(feats, r.config.reference_step_size) / 4, feats["spacing"] / 16)
        side = max(64, -(-px // 4))
        size = (side, side)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fine = r.render(dtype=np.float32, premultiplied=True, size=size, config=accuracy._exact(r.config, h_f, longest))
            for k in (2, 4, 8):
                cfg = accuracy._exact(r.config, h_f * k, longest)
                frame = accuracy.error_metrics(r.render(dtype=np.float32, premultiplied=True, config=cfg), conv)["max"]
                pilot = accuracy.error_metrics(r.render(dtype=np.float32, premultiplied=True, size=size, config=cfg),
                                               fine)["max"]
                ratio = frame / pilot if pilot > 0 else float("inf")
                rows.append([name, f"{px}, {side}", f"{h_f * k:.4g}", f"{frame:.2f}", f"{pilot:.2f}", f"{ratio:.2f}"])
                print(" | ".join(rows[-1]), flush=True)
    write_table("pilot_margin", "benches/pilot_margin.py" + (" --quick" if args.quick else ""),
                ["scene", "frame, pilot side", "step", "frame max err", "pilot max err", "frame / pilot"], rows,
                device=VolumeRenderer(8, 8).device,
                note="Frame: against the float64 integrator's converged image; pilot: against itself at the finest "
                "step config_for_error starts from, half the first step listed for each scene. No early termination.")


if __name__ == "__main__":
    main()
