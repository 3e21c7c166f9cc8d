"""Checks that Cargo.toml's ``rust-version`` is what the locked dependencies
really require: the highest ``rust-version`` any package in the build graph
declares (read from ``cargo metadata``). A lower value would promise users a
toolchain that cannot build the crate; a higher one would turn away one that
can. Exits 1, naming the package that decides, when they differ."""

import json
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def version_key(text):
    return tuple(int(part) for part in text.split("."))


def main():
    declared = tomllib.loads((ROOT / "Cargo.toml").read_text())["package"]["rust-version"]
    meta = json.loads(subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--features", "python", "--locked"],
        cwd=ROOT, check=True, capture_output=True, text=True).stdout)
    ours = {pkg["id"] for pkg in meta["packages"] if pkg["source"] is None}
    # Normal (not dev or build-only) dependencies reachable from this crate.
    nodes = {node["id"]: node for node in meta["resolve"]["nodes"]}
    reach, todo = set(), list(ours)
    while todo:
        node = nodes[todo.pop()]
        for dep in node["deps"]:
            if any(kind["kind"] is None for kind in dep["dep_kinds"]) and dep["pkg"] not in reach:
                reach.add(dep["pkg"])
                todo.append(dep["pkg"])
    needed = max(((pkg.get("rust_version") or "0", pkg["name"]) for pkg in meta["packages"] if pkg["id"] in reach),
                 key=lambda item: version_key(item[0]))
    if version_key(needed[0]) != version_key(declared):
        print(f"Cargo.toml says rust-version = {declared!r}, but {needed[1]} declares {needed[0]}: "
              f"set rust-version = {needed[0]!r}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
