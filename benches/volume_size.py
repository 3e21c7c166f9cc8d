"""What a sample costs as the volume outgrows the caches: pyvr's benchmark
frame (double_sphere with normals, [-1,1]^3, 512x512, lit, balanced) with
the scene sampled at 32^3 ... 256^3 voxels, so that every frame takes the
same samples and only the texture's size changes; each stored as float32
(value, normal: 16 bytes a voxel) and as 16-bit fixed point (8 bytes), the
two rendered alternately, with empty-space skipping off (values that round
to the data's least value, 0, would otherwise make cells empty in fixed
point only, and the two would take different samples). Median of --frames
frames after a warm-up; ns per sample counts both cores' wall time once.

Run: .venv/bin/python benches/volume_size.py [--frames 5]
"""

import argparse
import os
import sys
import time

import numpy as np

os.environ.setdefault("PYVR_BACKEND", "vulkan")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
SIZES = [32, 64, 96, 128, 160, 192, 256]
STORAGES = ["float32", "fixed16"]


def renderer(vol, precision):
    r = VolumeRenderer(512, 512, light=Light.default(), config=RenderConfig.balanced())
    r.empty_space_skipping = False
    r.load_volume(vol, precision=precision)
    r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.1))
    r.render()
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=5)
    args = ap.parse_args()
    rows = []
    for n in SIZES:
        ds = create_sample_volume(n, "double_sphere")
        vol = Volume(ds, compute_normal_volume(ds), *BOX)
        rs = {p: renderer(vol, p) for p in STORAGES}
        ts = {p: [] for p in STORAGES}
        for _ in range(args.frames):
            for p, r in rs.items():
                t = time.perf_counter()
                r.render()
                ts[p].append(time.perf_counter() - t)
        samples = rs["float32"].last_frame_stats["samples"]
        device = rs["float32"].device
        ms = {p: 1e3 * float(np.median(ts[p])) for p in STORAGES}
        ns = {p: ms[p] * 1e6 / samples for p in STORAGES}
        mib = {p: rs[p].counters()["volume_bytes"] / 2**20 for p in STORAGES}
        print(f"{n}^3: " + "  ".join(f"{p} {ms[p]:.0f} ms {ns[p]:.2f} ns/sample ({mib[p]:.1f} MiB)" for p in STORAGES),
              flush=True)
        rows.append([f"{n}^3", f"{samples / 1e6:.1f}", *(f"{mib[p]:.1f}" for p in STORAGES),
                     *(f"{ms[p]:.0f}" for p in STORAGES), *(f"{ns[p]:.2f}" for p in STORAGES),
                     f"{ms['float32'] / ms['fixed16']:.2f}x"])
        del rs
    write_table("volume_size", f"benches/volume_size.py --frames {args.frames}",
                ["volume", "samples (M)", "float32 MiB", "fixed16 MiB", "float32 ms", "fixed16 ms",
                 "float32 ns per sample", "fixed16 ns per sample", "float32 / fixed16"],
                rows, device=device,
                note="The benchmark frame (512x512, balanced, lit, no empty-space skipping) over the same scene "
                "sampled at each size; "
                f"both storages rendered alternately, median of {args.frames} frames after a warm-up.")


if __name__ == "__main__":
    main()
