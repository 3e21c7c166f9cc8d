"""The loop the fuzzing benchmarks share: cases made and checked for a
while, counted by outcome; the first case whose check fails stops the run
and is kept, with its traceback printed."""

import os
import random
import shutil
import tempfile
import time
import traceback
from typing import Callable, Optional


def fuzz(seconds: float, rnd: random.Random, make_case: Callable, check: Callable[[str], str],
         keep_as: str) -> Optional[dict]:
    """Runs ``make_case(rnd, folder) -> path`` then ``check(path)`` ("ok" or
    "refused") on fresh folders for ``seconds``. Returns the counts and the
    seconds taken, or None after a failure, whose folder is kept as
    ``keep_as``-<n> (under out/)."""
    counts = {"ok": 0, "refused": 0}
    start = time.time()
    while time.time() - start < seconds:
        with tempfile.TemporaryDirectory() as folder:
            path = make_case(rnd, folder)
            try:
                counts[check(path)] += 1
            except BaseException:
                kept = os.path.join("out", f"{keep_as}-{sum(counts.values())}")
                shutil.copytree(folder, kept)
                traceback.print_exc()
                print(f"FAILED on case {sum(counts.values()) + 1}; its files are kept in {kept}")
                return None
    return {**counts, "seconds": time.time() - start}
