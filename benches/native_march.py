"""The native CPU march against the shader: runs the Rust measurement
(benches/native_march.rs: the balanced benchmark frame, its volume as
float32 and as fixed16, by the shader and by the native march in turn, in
one run) and writes its rows as out/native_march.json for docs/speed.md.

Run: .venv/bin/python benches/native_march.py [size] [n]   (default 512 256; needs cargo)
"""

import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402


def main():
    args = sys.argv[1:]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "rows.json")
        env = {**os.environ, "NATIVE_MARCH_JSON": path}
        subprocess.run(["cargo", "bench", "--quiet", "--bench", "native_march", "--", *args],
                       cwd=os.path.join(HERE, ".."), env=env, check=True)
        with open(path) as f:
            result = json.load(f)
    size, n = (args + ["512", "256"][len(args):])[:2]
    write_table(
        "native_march", "benches/native_march.py",
        ["storage", "engine", "ms", "samples (M)", "ns per sample", "the shader's ns over this engine's",
         "max difference from the shader's image (levels)"],
        result["rows"], device=result["device"],
        note=f"{size}x{size}, {n}^3 double sphere with normals, balanced, empty-space skipping, every core; "
             "median of 3 after a warm-up. shader: the WGSL march on the adapter wgpu picked; native: the "
             "AVX2 march of src/cpu (eight rays in a register's lanes).",
    )


if __name__ == "__main__":
    main()
