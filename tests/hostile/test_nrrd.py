"""NRRD headers that lie: each case is written and loaded in its own
interpreter (run_case.py), so a hang or a memory bomb fails the test
instead of the run. A detached header reads data only from its own folder
(unless the caller allows more), skips stay inside the file, and
compressed data is inflated no further than the header declares."""

import pytest

from test_processes import run

pytest.importorskip("nrrd")


@pytest.mark.parametrize("kind, expected", [
    ("parent", "RAISED FileFormatError: .*its data file '../secret.raw' is outside the header's folder"),
    ("absolute", "RAISED FileFormatError: .*is outside the header's folder .*pass data_outside_folder=True"),
    ("tail_of_any_file", "RAISED FileFormatError: .*its data file '/etc/passwd' is outside the header's folder"),
    ("line_skip", "RAISED FileFormatError: .*line skip 99999999999 passes the end of h.nrrd"),
    ("gzip_bomb", "RAISED FileFormatError: .*the gzip data holds more than the 4000 bytes the header declares"),
    ("raw_short", "RAISED FileFormatError: .*1000 bytes of data after the skips, the header declares 256000000"),
    ("nan_directions", "RAISED FileFormatError: .*space directions must be three finite vectors"),
    # What is allowed loads: data beside the header, or anywhere when the caller says so.
    ("same_folder", "OK loaded \\(4, 4, 4\\) sum 2016"),
    ("parent_allowed", "OK loaded \\(4, 4, 4\\) sum 2016"),
])
def test_hostile_nrrd(kind, expected, tmp_path):
    import re

    result, rss = run("nrrd", kind, str(tmp_path), timeout=60)
    assert re.match(expected, result), result
    # The bomb inflates to 1 GiB; refusing it must not get there first.
    assert rss < 256, f"{kind} peaked at {rss} MiB"
