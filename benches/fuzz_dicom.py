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

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))  # the loader tests' DICOM writer
sys.path.insert(0, os.path.join(HERE, "..", "tests", "hostile"))
sys.path.insert(0, HERE)

from _fuzz import fuzz  # noqa: E402
from _report import write_table  # noqa: E402
from dicom_fuzz import check_one, mutate, write_series  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rnd = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        seed = os.path.join(tmp, "seed")
        write_series(seed)

        def make_case(rnd, folder):
            case = os.path.join(folder, "series")
            shutil.copytree(seed, case)
            mutate(case, rnd)
            return case

        counts = fuzz(args.seconds, rnd, make_case, check_one, "fuzz_dicom/failure")
    if counts is None:
        return 1
    total = counts["ok"] + counts["refused"]
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{total} series in {counts['seconds']:.0f} s: {counts['ok']} loaded, {counts['refused']} refused, "
          f"0 other outcomes; peak RSS {peak_mib:.0f} MiB")
    write_table("fuzz_dicom", f"python benches/fuzz_dicom.py --seconds {args.seconds:g} --seed {args.seed}",
                ["series", "loaded", "refused", "other", "seconds", "peak RSS (MiB)"],
                [[total, counts["ok"], counts["refused"], 0, round(counts["seconds"]), round(peak_mib)]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
