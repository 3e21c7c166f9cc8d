"""One renderer shared by threads, and generators interleaved: each case in
its own interpreter (run_case.py), so a deadlock fails the test by its
timeout instead of hanging the run."""

from test_processes import run


def test_accumulated_means_never_mix_states():
    # Another thread switches transfer functions and cameras as fast as it
    # can while this one averages frames: each mean is one state's.
    result, _ = run("accumulate_race", "40", timeout=300)
    assert result == "OK 0 of 40 means mixed states", result


def test_interleaved_render_paths_keep_the_users_camera():
    result, _ = run("interleaved_paths", timeout=120)
    assert result == "OK 0 of 6 frames wrong, camera kept: True", result
