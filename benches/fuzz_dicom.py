"""Fuzzes how pyvr assembles a DICOM series into a volume for a while
(default 5 minutes): mutated series (tests/hostile/dicom_fuzz.py) must
load consistently or be refused naming the series or a slice; any other
outcome stops the run with the series kept under out/fuzz_dicom/. Prints
and writes out/fuzz_dicom.json.

    .venv/bin/python benches/fuzz_dicom.py [--seconds 300] [--seed 0]
"""

import argparse
import os
import random
import resource
import shutil
import sys
import tempfile
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "hostile"))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402
from dicom_fuzz import check_one, mutate, write_series  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rnd = random.Random(args.seed)
    counts = {"ok": 0, "refused": 0}
    start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        seed = os.path.join(tmp, "seed")
        write_series(seed)
        while time.time() - start < args.seconds:
            case = os.path.join(tmp, "series")
            shutil.rmtree(case, ignore_errors=True)
            shutil.copytree(seed, case)
            mutate(case, rnd)
            try:
                counts[check_one(case)] += 1
            except BaseException:
                kept = os.path.join("out", "fuzz_dicom", f"failure-{sum(counts.values())}")
                shutil.copytree(case, kept)
                traceback.print_exc()
                print(f"FAILED on case {sum(counts.values()) + 1}; the series is kept in {kept}")
                return 1
    elapsed = time.time() - start
    total = sum(counts.values())
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{total} series in {elapsed:.0f} s: {counts['ok']} loaded, {counts['refused']} refused, 0 other outcomes; "
          f"peak RSS {peak_mib:.0f} MiB")
    write_table("fuzz_dicom", f"python benches/fuzz_dicom.py --seconds {args.seconds:g} --seed {args.seed}",
                ["series", "loaded", "refused", "other", "seconds", "peak RSS (MiB)"],
                [[total, counts["ok"], counts["refused"], 0, round(elapsed), round(peak_mib)]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
