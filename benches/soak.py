"""A long session on one renderer: 10,000 frames (default), a transfer-
function change every frame (as the opacity editor makes one per drag
event), a reload of the volume every 100 frames and a new renderer every
1,000. Samples resident memory, open file descriptors and threads every
1,000 frames; the target is a flat line. Prints the table and writes
out/soak.json (out/shader_soak.json with PYVR_TABLE_PREFIX=shader_) for
docs/numerics.md.

    .venv/bin/python benches/soak.py [--frames 10000] [--size 128]
    PYVR_NATIVE_MARCH=0 PYVR_TABLE_PREFIX=shader_ .venv/bin/python benches/soak.py
"""

import argparse
import gc
import os
import sys
import time


HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402

from pyvr import VolumeRenderer  # noqa: E402
from pyvr.datasets import create_sample_volume  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402


def resident_mib() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def count(folder: str) -> int:
    return len(os.listdir(folder))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--size", type=int, default=128)
    args = ap.parse_args()
    data = create_sample_volume(64, "double_sphere")
    ctf = ColorTransferFunction.from_colormap("viridis")
    rows, renderer, start = [], None, time.time()
    for k in range(args.frames + 1):
        if k % 1000 == 0:
            if k:
                gc.collect()
                rows.append([k, round(resident_mib(), 1), count("/proc/self/fd"), count("/proc/self/task"),
                             round(time.time() - start)])
                print(*rows[-1], flush=True)
            if k == args.frames:
                break
            renderer = VolumeRenderer(args.size, args.size)  # the previous one is dropped
        if k % 100 == 0:
            renderer.load_volume(Volume(data))
        renderer.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.05 + (k % 17) * 0.01))
        renderer.render()
    first, last = rows[0], rows[-1]
    note = (f"Growth from frame {first[0]} to {last[0]}: {last[1] - first[1]:+.1f} MiB resident, "
            f"{last[2] - first[2]:+d} file descriptors, {last[3] - first[3]:+d} threads.")
    print(note)
    env = " ".join(f"{k}={os.environ[k]}" for k in ("PYVR_NATIVE_MARCH", "PYVR_ENGINE", "VK_ICD_FILENAMES")
                   if k in os.environ)
    write_table("soak", f"{env + ' ' if env else ''}python benches/soak.py --frames {args.frames} --size {args.size}",
                ["frames", "resident (MiB)", "file descriptors", "threads", "seconds"], rows, note=note)
    return 0


if __name__ == "__main__":
    sys.exit(main())
