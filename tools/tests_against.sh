#!/usr/bin/env bash
# Runs this checkout's tests against pyvr as it was at another commit, to
# show that new tests can fail: a test written for a fix should fail on the
# commit before it. The package at REV is built (release, this machine only)
# and put first on PYTHONPATH; the tests are this checkout's, with REV's
# conftest.py (the conftest reads the core's limits, whose names change).
#
#   tools/tests_against.sh REV [pytest arguments]
#   tools/tests_against.sh a44ac90 tests/hostile -q
#
# Needs .venv (scripts/setup.sh) and cargo. The build has its own target
# folder, target/against, kept between runs so dependencies compile once
# (a folder shared with this checkout's builds would hand them REV's
# library: cargo finds its own artifacts fresh and does not copy them out).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 1 ]; then
    echo "usage: $0 REV [pytest arguments]" >&2
    exit 2
fi
rev=$(git rev-parse --verify "$1^{commit}")
shift
here=$PWD
work=$(mktemp -d "${TMPDIR:-/tmp}/pyvr-at-${rev:0:7}-XXXX")
cleanup() {
    git -C "$here" worktree remove --force "$work/src" >/dev/null 2>&1 || true
    rm -rf "$work"
}
trap cleanup EXIT

git worktree add --detach -q "$work/src" "$rev"
echo "== building pyvr at ${rev:0:12} (release)"
CARGO_TARGET_DIR="$here/target/against" \
    .venv-build/bin/maturin build --release -q -m "$work/src/Cargo.toml" --out "$work/dist" >/dev/null
.venv/bin/python -m pip install -q --disable-pip-version-check --no-deps --target "$work/site" "$work"/dist/*.whl

# The tests run from a copy laid out like the checkout (tests/, pyproject.toml
# for pytest's settings, ../shared beside it for the data).
mkdir -p "$work/main"
cp -a tests pyproject.toml "$work/main/"
[ -e ../shared ] && ln -s "$(cd ../shared && pwd)" "$work/shared"
if git -C "$work/src" cat-file -e HEAD:tests/conftest.py 2>/dev/null; then
    cp "$work/src/tests/conftest.py" "$work/main/tests/conftest.py"
fi
cd "$work/main"
PYTHONPATH="$work/site" "$here/.venv/bin/python" - <<'EOF'
import pyvr
print(f"== pyvr from {pyvr.__file__}")
EOF
set +e
PYTHONPATH="$work/site" "$here/.venv/bin/python" -m pytest -p no:cacheprovider "$@"
rc=$?
exit $rc
