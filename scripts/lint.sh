#!/usr/bin/env bash
# Style and lint checks CI enforces: rustfmt (rustfmt.toml), clippy with
# warnings as errors (allowed lints and why: Cargo.toml [lints.clippy]),
# ruff (pyproject.toml [tool.ruff]), no import circles in the package, and
# Cargo.toml's rust-version. Needs the .venv scripts/setup.sh makes.
set -euo pipefail
cd "$(dirname "$0")/.."
if command -v rustup >/dev/null; then
    for c in rustfmt clippy; do
        rustup component list --installed 2>/dev/null | grep -q "^$c" || rustup component add "$c" >/dev/null 2>&1
    done
fi
[ -x .venv/bin/ruff ] || .venv/bin/python -m pip install -q ruff
echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy (core, then with the Python binding)"
cargo clippy --quiet --all-targets -- -D warnings
PYO3_PYTHON="$PWD/.venv/bin/python" cargo clippy --quiet --all-targets --features python -- -D warnings
echo "== ruff check"
.venv/bin/ruff check --quiet python tests benches examples tools
echo "== no import circles in the package (deferred imports counted)"
.venv/bin/python tools/import_graph.py --all
echo "== rust-version is what the locked dependencies declare"
.venv/bin/python tools/rust_version.py
