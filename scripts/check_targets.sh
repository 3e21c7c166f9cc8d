#!/usr/bin/env bash
# Checks that the crate, with its Python binding, compiles for the targets
# the release workflow (.github/workflows/release.yml) builds wheels for:
# Windows x64, macOS on both CPUs, Linux aarch64. `cargo check` needs no
# linker or SDK for them, only each target's standard library (rustup
# downloads it the first time).
set -euo pipefail
cd "$(dirname "$0")/.."
targets=(x86_64-pc-windows-msvc aarch64-apple-darwin x86_64-apple-darwin aarch64-unknown-linux-gnu)
rustup target add "${targets[@]}" >/dev/null 2>&1
for target in "${targets[@]}"; do
    echo "== cargo check --target $target --features python"
    # abi3: the binding needs no interpreter of the target, only its version floor.
    PYO3_CROSS_PYTHON_VERSION=3.11 cargo check --quiet --locked --features python --target "$target"
done
