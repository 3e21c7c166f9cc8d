"""Run pyvr 0.4.1's own test suite against the installed pyvr, and sort
what fails.

    .venv/bin/python tools/pyvr041_suite.py PATH/TO/pyvr-0.4.1

PATH is a checkout of pyvr 0.4.1 (its ``tests/`` and ``example_data/``
are copied to a scratch folder and run there, so its package is never on
the path; none of it enters this repository). Prints the passed and
failed tests of each module, the tests that were not collected, and every
failure with its class from ``tests/compat/pyvr041_suite_expected.toml``:
OpenGL internals (tests of OpenGL internals: ``ModernGLManager``, the GL calls
behind ``renderer.gl_manager``, the GLSL files) or the row of
``docs/migration.toml`` whose change it tests. Exits 1 when a test fails
that the file does not expect, or an expected failure passes.
"""

import collections
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXPECTED = ROOT / "tests" / "compat" / "pyvr041_suite_expected.toml"
MIGRATION = ROOT / "docs" / "migration.toml"


def main(source: str) -> int:
    src = Path(source)
    expected = tomllib.loads(EXPECTED.read_text())
    rows = [c["was"] for c in tomllib.loads(MIGRATION.read_text())["change"]]
    expected_fail = {t: "OpenGL internals" for t in expected["opengl"]["tests"]}
    for change in expected["changes"]:
        row = [w for w in rows if w.startswith(change["was"])]
        if len(row) != 1:
            sys.exit(f"{EXPECTED.name}: no single row of docs/migration.toml starts {change['was']!r}")
        expected_fail.update({t: f"documented change: {row[0]}" for t in change["tests"]})
    uncollectable = set(expected["opengl"]["modules"])
    with tempfile.TemporaryDirectory() as tmp:
        for part in ("tests", "example_data"):
            shutil.copytree(src / part, Path(tmp) / part)
        report = Path(tmp) / "report.xml"
        env = dict(os.environ, MPLBACKEND="Agg")
        subprocess.run([sys.executable, "-m", "pytest", "tests", "-q", "-p", "no:cacheprovider",
                        "--continue-on-collection-errors", f"--junitxml={report}"], cwd=tmp, env=env,
                       stdout=subprocess.DEVNULL)
        cases = ET.parse(report).getroot().iter("testcase")
        per_module = collections.defaultdict(lambda: [0, 0])
        failed, passed, not_collected = [], set(), []
        for case in cases:
            bad = case.find("failure") is not None or case.find("error") is not None
            if not case.get("classname"):  # a module that failed to import
                not_collected.append(case.get("name").replace(".", "/") + ".py")
                continue
            node = _nodeid(case)
            if bad:
                failed.append(node)
            elif case.find("skipped") is None:
                passed.add(node)
            per_module[node.split("::")[0]][1 if bad else 0] += 1
    for module, (ok, bad) in sorted(per_module.items()):
        print(f"{module:70s} {ok:4d} passed {bad:4d} failed")
    total_ok = sum(v[0] for v in per_module.values())
    total_bad = sum(v[1] for v in per_module.values())
    print(f"{'total':70s} {total_ok:4d} passed {total_bad:4d} failed")
    if not_collected:
        print("not collected (OpenGL internals):" if set(not_collected) <= uncollectable else "not collected:")
        for m in sorted(set(not_collected)):
            print("  ", m)
    unexpected = [t for t in failed if t not in expected_fail]
    by_reason = collections.defaultdict(list)
    for t in failed:
        by_reason[expected_fail.get(t, "UNEXPECTED")].append(t)
    for reason, tests in sorted(by_reason.items()):
        print(f"\n{len(tests)} failed: {reason}")
        for t in sorted(tests):
            print("   ", t)
    now_passing = sorted(t for t in expected_fail if t in passed)
    for t in now_passing:
        print("expected to fail, passed:", t)
    stray = set(not_collected) - uncollectable
    return 1 if unexpected or now_passing or stray else 0


def _nodeid(case) -> str:
    """pytest's node id of a junit test case (path::Class::test)."""
    parts = case.get("classname", "").split(".")
    path, rest = [], []
    for i, p in enumerate(parts):
        path.append(p)
        if p.startswith("test_") and (i + 1 == len(parts) or parts[i + 1][:1].isupper()):
            rest = parts[i + 1:]
            break
    return "::".join(["/".join(path) + ".py"] + rest + [case.get("name")])


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
