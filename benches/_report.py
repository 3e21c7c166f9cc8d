"""Benchmark results as tables: each benchmark writes its tables as JSON
(out/<name>.json) stamped with date, machine, device and commit, and
tools/docs_tables.py puts them into the docs pages. Nothing in a docs
table is typed by hand."""

import datetime
import json
import os
import platform
import subprocess

OUT = os.environ.get("PYVR_OUT", os.path.join(os.path.dirname(__file__), "..", "out"))


def cpu_model() -> str:
    """The processor's model name: the same benchmark on two CPUs of one
    architecture can differ by 1.4x (lavapipe's frames) in opposite
    directions for different engines."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def stamp(device: str = "") -> dict:
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=here).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True, cwd=here).stdout.strip()
    except OSError:  # no git where the tree was copied to (a lent GPU machine, say)
        commit, dirty = "", ""
    # A copy of the tree (on another machine, whose git state may be stale or
    # missing) names the commit it was made from in PYVR_COMMIT.
    if os.environ.get("PYVR_COMMIT"):
        commit, dirty = os.environ["PYVR_COMMIT"], ""
    commit = commit or "unknown"
    return {
        "date": datetime.date.today().isoformat(),
        "machine": f"{platform.node()} ({os.cpu_count()} cores, {platform.machine()}, {cpu_model()})",
        "device": device,
        "commit": commit + ("+changes" if dirty else ""),
    }


def write_table(name: str, command: str, columns: list, rows: list, device: str = "", note: str = "") -> str:
    """Writes out/<name>.json: the table and how it was made. PYVR_TABLE_PREFIX
    is put before the name, so that a run on another machine (a GPU's, say)
    fills its own tables in the docs rather than this machine's."""
    name = os.environ.get("PYVR_TABLE_PREFIX", "") + name
    os.makedirs(OUT, exist_ok=True)
    path = os.path.normpath(os.path.join(OUT, f"{name}.json"))
    table = {"name": name, "command": command, "columns": columns, "rows": rows, "note": note, **stamp(device)}
    with open(path, "w") as f:
        json.dump(table, f, indent=1)
    print(f"table {name}: {path}")
    return path
