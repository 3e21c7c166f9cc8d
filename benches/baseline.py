"""This engine against an earlier commit of itself, on this machine, in one
run: the preset benchmark (examples/benchmark.py: the 256^3 benchmark scene,
512x512, lit) for each preset, the two builds taking turns.

A speed-up quoted against a figure measured in another session compares two
machines as much as two engines: on one Intel Xeon VM lavapipe ran the
filing-time engine's balanced frame in 656-676 ms, where the figure filed for
it, from an earlier VM, was 1293 ms. So the baseline is rebuilt here.

The earlier commit is checked out into a git worktree under the temporary
folder and built with maturin into its own virtual environment and its own
cargo target folder (the first build compiles the dependencies too: about
10 minutes on 2 cores; later runs reuse it). A target folder shared with
this checkout would hand the earlier commit's library to this checkout's
next build: cargo finds its own artifacts fresh and does not copy them
back out. Each build runs its own
examples/benchmark.py (the same scene and timing). Each round runs
every preset in a fresh process per build, alternating which goes first;
the table gives each build's median over the rounds' medians and their
ratio.

Run: .venv/bin/python benches/baseline.py [--rev 1d93391] [--rounds 3] [--frames 5]
(needs git, cargo and pip's registry)
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _report import write_table  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), ".."))
# The last commit before the performance issue's work began: the engine the
# issue's figures were filed against.
FILED = "1d93391"
PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]
ROW = re.compile(r"^(\w+)\s+[\d.]+\s+\d+\s+\d+\s+\d+\s+([\d.]+)\s")


def build(rev: str) -> tuple:
    """A virtual environment with pyvr built at `rev`: its python, and the
    worktree holding `rev`'s examples."""
    short = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.strip()
    tree = os.path.join(tempfile.gettempdir(), f"pyvr-baseline-{short}")
    venv = tree + "-venv"
    python = os.path.join(venv, "bin", "python")
    if not os.path.isdir(tree):
        subprocess.run(["git", "worktree", "add", "--detach", tree, short], cwd=ROOT, check=True)
    if not os.path.exists(python):
        subprocess.run([sys.executable, "-m", "venv", venv], check=True)
        subprocess.run([python, "-m", "pip", "install", "-q", "maturin>=1.7,<2", "numpy", "scipy", "pillow"],
                       check=True)
    env = dict(os.environ, VIRTUAL_ENV=venv, CARGO_TARGET_DIR=tree + "-target")
    print(f"building {short} in {tree} ...", flush=True)
    subprocess.run([os.path.join(venv, "bin", "maturin"), "develop", "--release", "-q"], cwd=tree, env=env,
                   check=True, stdout=subprocess.DEVNULL)
    return python, tree


def medians(python: str, tree: str, frames: int) -> dict:
    """Median ms per preset from one run of `tree`'s examples/benchmark.py."""
    env = dict(os.environ, PYVR_OUT=tempfile.mkdtemp())
    out = subprocess.run([python, os.path.join(tree, "examples", "benchmark.py"), "--frames", str(frames)],
                         cwd=os.path.join(tree, "examples"), env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{tree}/examples/benchmark.py failed:\n{out.stdout}\n{out.stderr}")
    got = {m.group(1): float(m.group(2)) for m in map(ROW.match, out.stdout.splitlines()) if m}
    missing = [p for p in PRESETS if p not in got]
    if missing:
        raise RuntimeError(f"no timing for {missing} in:\n{out.stdout}\n{out.stderr}")
    return got


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rev", default=FILED, help=f"the earlier commit (default {FILED})")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds (default 3)")
    ap.add_argument("--frames", type=int, default=5, help="timed frames per preset and run (default 5)")
    args = ap.parse_args()
    builds = {"earlier": build(args.rev), "this": (sys.executable, ROOT)}
    runs = {k: [] for k in builds}
    for i in range(args.rounds):
        for k in (["earlier", "this"] if i % 2 == 0 else ["this", "earlier"]):
            runs[k].append(medians(*builds[k], args.frames))
            print(f"round {i + 1}, {k}: " + ", ".join(f"{p} {runs[k][-1][p]:.0f}" for p in PRESETS), flush=True)
    rows = []
    for p in PRESETS:
        old = float(np.median([r[p] for r in runs["earlier"]]))
        new = float(np.median([r[p] for r in runs["this"]]))
        rows.append([p, f"{old:.1f}", f"{new:.1f}", f"{old / new:.2f}x"])
        print(" | ".join(rows[-1]))
    import pyvr

    write_table("baseline", f"benches/baseline.py --rev {args.rev} --rounds {args.rounds}",
                ["preset", f"{args.rev} ms", "this commit ms", "speed-up"], rows,
                device=pyvr.VolumeRenderer(8, 8).device,
                note=f"The preset benchmark scene (256^3, 512x512, lit), each build in its own process, "
                     f"{args.rounds} alternating rounds; each cell is the median over rounds of the median of "
                     f"{args.frames} warm frames.")


if __name__ == "__main__":
    main()
