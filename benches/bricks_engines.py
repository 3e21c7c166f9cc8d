"""Bricked volumes on a CPU-only machine: the native march, which takes the
bricks one after another with each ray's state kept in memory, against the
shader on lavapipe, and both against the same volume in one texture.

For each volume (the synthetic torus and ball of benches/scale.py), brick
size and frame (balanced, balanced pre-integrated, maximum intensity
projection, isosurface, balanced unbiased), a single-texture renderer and two bricked ones (native march
on and off) are loaded side by side, every brick resident; each renders a
warm-up frame, then --frames frames in turn, and the medians are compared.
The images are compared with the single texture's (premultiplied, in 8-bit
levels); unbiased frames whose segments take their cells' rates draw each
brick's points at its own cells' rates, and match the single texture in
the mean only.

Run: .venv/bin/python benches/bricks_engines.py [--sizes 256,512] [--frames 5]

Writes out/bricks_engines.json (tools/docs_tables.py puts it into docs/scale.md).
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402
from scale import BOX, SIZE, field_slab  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.renderer import device_limits  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

FRAMES = {
    "balanced": RenderConfig.balanced(),
    "balanced, pre-integrated": RenderConfig.balanced().replace(pre_integrated=True),
    "maximum intensity": RenderConfig.balanced().replace(model="mip"),
    "isosurface 0.3": RenderConfig.balanced().replace(model="isosurface", iso_value=0.3),
    "balanced, unbiased": RenderConfig.balanced().replace(unbiased=True),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="256,512")
    ap.add_argument("--frames", type=int, default=5)
    a = ap.parse_args()
    if not device_limits()["native_march"]:
        sys.exit("the native march does not run here (it needs a CPU adapter with AVX2, FMA and F16C)")
    rows = []
    for n in (int(s) for s in a.sizes.split(",")):
        data = np.stack([field_slab(n, i) for i in range(n)])
        vol = Volume(data=data, min_bounds=BOX[0], max_bounds=BOX[1])
        for side in (n // 4, n // 2):
            for name, cfg in FRAMES.items():
                engines = {"one texture, native": (None, True), "bricks, shader": (side, False),
                           "bricks, native": (side, True)}
                renderers = {}
                for label, (brick, native) in engines.items():
                    r = VolumeRenderer(*SIZE, config=cfg, brick_shape=None if brick is None else (brick,) * 3)
                    r.native_march = native
                    r.load_volume(vol)
                    r.render()
                    renderers[label] = r
                times = {label: [] for label in engines}
                for _ in range(a.frames):
                    for label, r in renderers.items():
                        t = time.perf_counter()
                        r.render()
                        times[label].append(time.perf_counter() - t)
                images = {label: r.render(dtype=np.float32, premultiplied=True) for label, r in renderers.items()}
                ms = {label: 1e3 * statistics.median(t) for label, t in times.items()}
                count = renderers["bricks, native"].bricks["count"]
                for label, r in renderers.items():
                    stats = r.last_frame_stats
                    diff = np.abs(images[label] - images["one texture, native"]).max() * 255
                    rows.append([f"{n}^3", "-" if label.startswith("one") else f"{side}^3 ({count})", name, label,
                                 stats["engine"], round(ms[label], 1), round(stats["samples"] / 1e6, 2),
                                 round(ms["bricks, shader"] / ms[label], 2), float(f"{diff:.2g}")])
                    print(rows[-1], flush=True)
                del renderers
    write_table(
        "bricks_engines", "benches/bricks_engines.py" + (f" --sizes {a.sizes}" if a.sizes != "256,512" else ""),
        ["volume", "bricks (count)", "frame", "renderer", "engine", "ms", "samples (M)",
         "bricks on the shader: ms over this", "max difference from one texture (levels)"],
        rows,
        note=f"{SIZE[0]}x{SIZE[1]}, synthetic torus + ball of benches/scale.py in [-1, 1]^3, every brick resident; "
             f"renderers loaded side by side, a warm-up frame each, then the median of {a.frames} frames rendered "
             "in turn. Differences: premultiplied float images against the single texture's.",
    )


if __name__ == "__main__":
    main()
