"""Memory that grows with use: a transfer-function change per drag event
(the interface's opacity editor) and reloads, each measured in its own
interpreter (run_case.py) after a warm-up."""

import pytest

from test_processes import run


@pytest.mark.parametrize("kind", ["tf", "load"])
def test_resident_memory_stays_flat(kind):
    # Replaced tables and their staging memory were kept until a GPU
    # submission; frames of the native march submit none: 19.5 KiB per
    # change (57 MiB over 3,000). Allocator noise stays well under 1 KiB.
    result, _ = run("growth", kind, "3000", timeout=300)
    assert result.startswith("OK "), result
    per_call = float(result.split()[1])
    assert per_call < 1.0, result
