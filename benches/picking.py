"""What picking costs: 10^5 pixels (default) of the preset benchmark's
scene (examples/benchmark.py: 256^3, 512x512, balanced step) picked at
once with renderer.pick, per model; the pixels are drawn at random over
the image. Picks run the float64 integrator's rules on every core, so the
time is per ray marched to the picked point (all the way through where
nothing is picked) and does not depend on the GPU.

Run: .venv/bin/python benches/picking.py [--picks 100000]
"""

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "examples"))

from benchmark import benchmark_scene  # noqa: E402
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.lighting import Light  # noqa: E402

MODELS = {
    "emission_absorption (opacity 0.5)": RenderConfig.balanced(),
    "mip": RenderConfig.balanced().replace(model="mip"),
    "isosurface (0.5)": RenderConfig.balanced().replace(model="isosurface", iso_value=0.5),
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--picks", type=int, default=100_000)
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args()
    volume, camera, ctf, otf, _ = benchmark_scene(256)
    rnd = np.random.default_rng(0)
    x, y = rnd.integers(0, args.size, args.picks), rnd.integers(0, args.size, args.picks)
    rows = []
    for name, config in MODELS.items():
        r = VolumeRenderer(args.size, args.size, config=config, light=Light.default())
        r.load_volume(volume)
        r.set_camera(camera)
        r.set_transfer_functions(ctf, otf)
        r.pick(x[:100], y[:100])  # warm: threads and pages touched once
        t = time.perf_counter()
        picks = r.pick(x, y)
        seconds = time.perf_counter() - t
        rows.append([name, args.picks, round(seconds, 2), round(seconds / args.picks * 1e6, 1),
                     round(float(picks.hit.mean()), 3)])
        print(*rows[-1], flush=True)
    write_table("picking", f"python benches/picking.py --picks {args.picks} --size {args.size}",
                ["model", "picks", "seconds", "µs a pick", "share that hit"], rows,
                note=f"{os.cpu_count()} cores; the 256^3 benchmark volume, {args.size}^2, balanced step.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
