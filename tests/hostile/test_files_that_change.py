"""A file that changes under a volume mapped from it: each case in its own
interpreter (run_case.py), so SIGBUS fails the test instead of the run."""

import pytest

from test_processes import run


@pytest.mark.parametrize("layout", ["C", "F", "view"])
def test_a_memmap_cut_short_after_loading_is_a_clear_error(layout, tmp_path):
    path = tmp_path / "v.dat"
    result, _ = run("truncated_memmap", layout, str(path), timeout=120)
    assert result.startswith(f"RAISED ValueError: {path} ends before the memmap's shape"), result


def test_a_memmap_whose_file_was_saved_over_keeps_its_volume(tmp_path):
    # Bricks were read by the path, so a file renamed over it after loading
    # rendered as if it were the volume (an all-zero file: an empty frame).
    result, _ = run("replaced_memmap", str(tmp_path / "v.dat"), timeout=120)
    assert result == "OK the same frame", result
