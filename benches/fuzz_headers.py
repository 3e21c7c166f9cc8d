"""Fuzzes the headers pyvr parses or checks itself (NRRD attached and
detached, NIfTI-1, raw + .raw.info) for a while (default 2 minutes per
format): mutated headers (tests/hostile/header_fuzz.py) must read
consistently or be refused naming the file, each read within 10 s; any
other outcome stops the run with the case kept under out/fuzz_headers/.
Runs under a 4 GiB address-space limit, so a header whose sizes were
allocated rather than checked cannot take the machine down. Prints and
writes out/fuzz_headers.json.

    .venv/bin/python benches/fuzz_headers.py [--seconds 120] [--seed 0]
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
from header_fuzz import FORMATS, check_one, mutate, write_case  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=120.0, help="per format")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
    rnd = random.Random(args.seed)
    rows = []
    for fmt in sorted(FORMATS):
        seed = FORMATS[fmt][1]()
        # Bound now: the call runs before the loop moves on.
        counts = fuzz(args.seconds, rnd, lambda rnd, folder, fmt=fmt, seed=seed: write_case(folder, fmt, mutate(seed, rnd)),
                      check_one, f"fuzz_headers/{fmt}-failure")
        if counts is None:
            return 1
        total = counts["ok"] + counts["refused"]
        rows.append([fmt, total, counts["ok"], counts["refused"], 0, round(counts["seconds"])])
        print(f"{fmt}: {total} cases in {counts['seconds']:.0f} s: {counts['ok']} read, {counts['refused']} "
              "refused, 0 other outcomes", flush=True)
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    write_table("fuzz_headers", f"python benches/fuzz_headers.py --seconds {args.seconds:g} --seed {args.seed}",
                ["format", "cases", "read", "refused", "other", "seconds"], rows,
                note=f"Peak RSS of the whole run: {peak_mib:.0f} MiB.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
