"""What clip planes and an opaque scene's depth cost a frame: the preset
benchmark's scene (examples/benchmark.py: 256^3, 512x512, lit, balanced)
with no planes, with 1 and with 16 planes that keep the whole volume (the
same samples: what is left is the planes' own cost, once per camera ray),
with one plane that cuts the volume in half (fewer samples), and with a
depth image (render(depth=)) that stops no ray and one that stops every
ray at the camera's distance. Each engine present here (the
native march, and the shader where a Vulkan adapter opens); cases take
turns within each round, and the table gives medians over --rounds rounds
and each case's time as a ratio to no planes from the same run.

Run: .venv/bin/python benches/clip_planes.py [--rounds 7] [--size 512]
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "examples"))
os.environ.setdefault("PYVR_BACKEND", "vulkan")

from benchmark import benchmark_scene  # noqa: E402
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.renderer import device_limits  # noqa: E402

# Planes whose kept side holds the whole [-1, 1] box, facing every way.
AROUND = [((-2.0 * x, -2.0 * y, -2.0 * z), (x, y, z))
          for x, y, z in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1),
                          (1, 1, 0), (1, -1, 0), (-1, 1, 0), (-1, -1, 0), (0, 1, 1), (0, 1, -1),
                          (0, -1, 1), (0, -1, -1), (1, 0, 1), (1, 0, -1)]]
CASES = {
    "none": ([], None),
    "1 keeping all": (AROUND[:1], None),
    "16 keeping all": (AROUND, None),
    "1 cutting half": ([((0.0, 0.0, 0.0), (1.0, 0.3, 0.2))], None),
    "depth image, no surface": ([], np.inf),
    "depth image at the target": ([], 3.0),
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args()
    volume, camera, ctf, otf, _ = benchmark_scene(256)
    engines = ["native"] + (["shader"] if device_limits()["gpu_adapter"] else [])
    rows = []
    for engine in engines:
        r = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(), light=Light.default())
        r._engine.native_march = engine == "native"
        r.load_volume(volume)
        r.set_camera(camera)
        r.set_transfer_functions(ctf, otf)
        times = {name: [] for name in CASES}
        samples = {}
        depths = {name: None if d is None else np.full((args.size, args.size), d) for name, (_, d) in CASES.items()}
        for name, (planes, _) in CASES.items():  # warm each case once
            r.set_clip_planes(planes)
            r.render(depth=depths[name])
        for _ in range(args.rounds):
            for name, (planes, _) in CASES.items():
                r.set_clip_planes(planes)
                t = time.perf_counter()
                r.render(depth=depths[name])
                times[name].append(time.perf_counter() - t)
                samples[name] = r.last_frame_stats["samples"]
                assert r.last_frame_stats["engine"] == ("native" if engine == "native" else "gpu")
        base = statistics.median(times["none"])
        for name in CASES:
            ms = statistics.median(times[name])
            rows.append([engine, name, round(ms * 1000, 1), round(ms / base, 3), samples[name]])
            print(*rows[-1], flush=True)
    write_table("clip_planes", f"python benches/clip_planes.py --rounds {args.rounds} --size {args.size}",
                ["engine", "case", "ms (median)", "ratio to none", "samples"], rows,
                device=VolumeRenderer(8, 8).device)
    return 0


if __name__ == "__main__":
    sys.exit(main())
