"""What a frame costs besides its samples: the pixels whose rays miss the
volume, and making each pixel what `render()` returns (8-bit codes or
floats, straight or premultiplied colour).

A 128^3 torus with a narrow opacity band (balanced) seen from an isometric
camera at distance 3 (the box fills most of the view) and 30 (it covers
about 1% of the pixels), and with an empty transfer function; at 512x512
and 2048x2048; returned as render()'s default (uint8, straight colour),
float32 straight colour and float32 premultiplied. Median of --frames
warm frames each.

Run: .venv/bin/python benches/frame_overhead.py [--frames N]
(run it with PYTHONPATH=<an older checkout>/python to time that one's frames.)
"""

import argparse
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("PYVR_BACKEND", "vulkan")

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import create_sample_volume  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

OUTPUTS = {
    "uint8, straight (default)": dict(),
    "float32, straight": dict(dtype=np.float32),
    "float32, premultiplied": dict(dtype=np.float32, premultiplied=True),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=9)
    args = ap.parse_args()
    torus = Volume(create_sample_volume(128, "torus"))
    band = OpacityTransferFunction.peaks([0.7], opacity=0.8, eps=0.02)
    views = [("fills the view (distance 3)", band, 3.0), ("1% of the view (distance 30)", band, 30.0),
             ("empty transfer function", OpacityTransferFunction.linear(0.0, 0.0), 3.0)]
    rows = []
    for size in (512, 2048):
        for view, otf, distance in views:
            r = VolumeRenderer(size, size)
            r.load_volume(torus)
            r.set_camera(Camera.isometric_view(distance=distance))
            r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), otf)
            r.set_config(RenderConfig.balanced())
            for output, kw in OUTPUTS.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r.render(**kw)
                    times = []
                    for _ in range(args.frames):
                        t = time.perf_counter()
                        r.render(**kw)
                        times.append((time.perf_counter() - t) * 1e3)
                ms = float(np.median(times))
                samples = r.last_frame_stats["samples"]
                row = [f"{size}²", view, output, round(ms, 2), round(samples / 1e6, 3),
                       round(ms * 1e6 / (size * size), 1)]
                rows.append(row)
                print("  ".join(str(c) for c in row), flush=True)
    write_table(
        "frame_overhead", f"benches/frame_overhead.py --frames {args.frames}",
        ["image", "volume", "returned as", "ms", "samples (M)", "ns per pixel"], rows, device=r.device,
        note=f"128^3 torus, narrow opacity band, balanced, isometric camera; median of {args.frames} warm frames "
             "of render(), the returned array's conversion included.")


if __name__ == "__main__":
    main()
