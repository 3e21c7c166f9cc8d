"""Fuzzes pyvr's .vti reader for a while (default 10 minutes): mutated
files (tests/hostile/vti_fuzz.py) must read consistently or raise
FileFormatError naming the file; any other outcome stops the run with the
file kept under out/fuzz_vti/. Prints and writes out/fuzz_vti.json: cases,
outcomes, and the peak RSS (zlib bombs included).

    .venv/bin/python benches/fuzz_vti.py [--seconds 600] [--seed 0]
"""

import argparse
import os
import random
import resource
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "hostile"))
sys.path.insert(0, HERE)

from _fuzz import fuzz  # noqa: E402
from _report import write_table  # noqa: E402
from vti_fuzz import check_one, mutate, seeds  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rnd = random.Random(args.seed)
    base = seeds()

    def make_case(rnd, folder):
        path = os.path.join(folder, "case.vti")
        with open(path, "wb") as f:
            f.write(mutate(rnd.choice(base), rnd))
        return path

    counts = fuzz(args.seconds, rnd, make_case, check_one, "fuzz_vti/failure")
    if counts is None:
        return 1
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    total = counts["ok"] + counts["refused"]
    elapsed = counts["seconds"]
    print(f"{total} cases in {elapsed:.0f} s: {counts['ok']} read, {counts['refused']} refused with "
          f"FileFormatError, 0 other outcomes; peak RSS {peak_mib:.0f} MiB")
    write_table("fuzz_vti", f"python benches/fuzz_vti.py --seconds {args.seconds:g} --seed {args.seed}",
                ["cases", "read", "refused", "other", "seconds", "peak RSS (MiB)"],
                [[total, counts["ok"], counts["refused"], 0, round(elapsed), round(peak_mib)]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
