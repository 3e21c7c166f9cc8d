"""Huge sizes, address-space limits, Ctrl-C, fork and multiprocessing: each
case runs in its own interpreter (tests/hostile/run_case.py), so an abort, a
crash or a hang fails the test instead of the test run."""

import os
import resource
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))


def run(case, *args, address_space=None, timeout=120):
    """(result line, peak RSS in MiB) of a case; fails on any other death."""
    def limit():
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    p = subprocess.run([sys.executable, os.path.join(HERE, "run_case.py"), case, *args], capture_output=True,
                       text=True, timeout=timeout, preexec_fn=limit)
    assert p.returncode == 0, f"{case} died with {p.returncode}: {p.stderr[-2000:]}"
    lines = [l for l in p.stdout.splitlines() if l.startswith(("OK", "RAISED", "PEAK_RSS_MIB"))]
    result = next(l for l in lines if not l.startswith("PEAK"))
    rss = float(next(l for l in lines if l.startswith("PEAK")).split()[1])
    return result, rss


GiB = 1 << 30


@pytest.mark.parametrize("case, expected, limit", [
    ("lut_1e9", "RAISED ValueError: lut_size must be at most", None),
    ("otf_2_40", "RAISED ValueError: lut_size must be at most", None),
    ("size_2_40", "RAISED ValueError: size must be at most", None),
    ("float64_20000", "RAISED MemoryError: render_float64 at 20000x20000 needs about", None),
    ("core_float64_20000", "RAISED MemoryError: a 20000x20000 float64 image needs", None),
    ("vti_bomb", "RAISED FileFormatError: ", 4 * GiB),
    ("float16_3_75gib", "RAISED MemoryError: loading volume (960, 1024, 1024) needs about", 8 * GiB),
])
def test_huge_requests_raise_before_allocating(case, expected, limit):
    result, rss = run(case, address_space=limit)
    assert result.startswith(expected), result
    assert any(f"RAISED {e}:" in result for e in ("MemoryError", "ValueError", "FileFormatError")), result
    assert rss < 1024, f"{case} peaked at {rss} MiB before refusing"


@pytest.mark.parametrize("case, limit", [
    # 256 GiB of float32 as a broadcast view: over every device limit.
    ("broadcast_4096", None),
    # 4 GiB of float32, as float16 over the device's 2 GiB upload limit, under an 8 GiB address space.
    ("float16_4gib", 8 * GiB),
    # 2.1 GiB: over lavapipe's upload limit.
    ("4096_4096_33", None),
])
def test_volumes_over_the_device_limits_load_as_bricks_without_reading(case, limit):
    """Bricks are read when a frame needs them, so loading costs neither time
    nor memory; what a frame then costs follows pyvr.bricks."""
    result, rss = run(case, address_space=limit)
    assert result.startswith("OK bricks"), result
    assert rss < 1024, f"{case} peaked at {rss} MiB"


@pytest.mark.parametrize("case", ["sigint_gpu", "sigint_native", "sigint_shadow_rays", "sigint_float64",
                                  "sigint_float64_quiet"])
def test_ctrl_c_stops_long_work_within_a_second(case):
    result, _ = run(case)
    assert result.startswith("OK interrupted"), result
    assert float(result.split()[-1]) < 1.0, result


def test_ctrl_c_or_a_work_bound_ends_tiny_adaptive_tolerances():
    # 1e-12 used to cut every segment 2^24 times; now at most MAX_PIECES.
    result, _ = run("sigint_adaptive")
    assert result.startswith("OK"), result
    assert float(result.split()[-1]) < 5.0, result


def test_a_forked_child_renders_with_the_parents_renderer():
    result, _ = run("fork_child_renders", timeout=60)
    assert result == "OK child 0 0", result


def test_a_forked_child_renders_with_the_parents_bricked_renderer():
    result, _ = run("fork_bricked", timeout=120)
    assert result == "OK child 0", result


@pytest.mark.parametrize("method", ["fork", "spawn", "forkserver"])
def test_multiprocessing_pools_render_the_same_frames(method):
    result, _ = run("pool", method, timeout=120)
    assert result == f"OK {method} [0]", result


def test_no_runtime_dir_still_renders_quietly():
    p = subprocess.run([sys.executable, os.path.join(HERE, "run_case.py"), "xdg"], capture_output=True, text=True,
                       timeout=60, env={k: v for k, v in os.environ.items() if k != "XDG_RUNTIME_DIR"})
    assert "OK rendered" in p.stdout and "XDG_RUNTIME_DIR" not in p.stderr, p.stderr


def test_a_memmapped_volume_four_times_the_budget_streams_within_it(tmp_path):
    """Out-of-core: a 256 MiB file (601 MiB of bricks with their ghosts)
    through a 64 MiB budget. Bricks are read from the file, uploaded and
    freed one at a time, so the process grows by a few bricks, never by the
    file (measured: 20 MiB)."""
    import numpy as np

    shape = (256, 256, 1024)
    path = tmp_path / "big.raw"
    mm = np.memmap(path, dtype=np.float32, mode="w+", shape=shape)
    z = np.linspace(0.0, 1.0, shape[2], dtype=np.float32)
    for i in range(shape[0]):
        mm[i] = z * (i / shape[0])
    mm.flush()
    del mm
    result, rss = run("memmap_stream", str(path), "x".join(map(str, shape)), "64")
    assert result.startswith("OK base"), result
    base = float(result.split()[2])
    assert int(result.split()[-1]) >= 4 * 64, result  # the device copy would be 4x the budget
    assert rss - base < 64, f"peak {rss} MiB against {base} MiB after a small frame: {result}"
