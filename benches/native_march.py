"""The native CPU march against the shader: runs the Rust measurement
(benches/native_march.rs: the balanced benchmark frame, its volume as
float32 and as fixed16, by the shader and by the native march in turn, in
one run), then again with the native march's portable path forced
(PYVR_NATIVE_LANES=portable), and writes the rows as out/native_march.json
for docs/performance.md.

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
    rows, device = [], None
    for lanes in ("auto", "portable"):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "rows.json")
            env = {**os.environ, "NATIVE_MARCH_JSON": path, "PYVR_NATIVE_LANES": lanes}
            subprocess.run(["cargo", "bench", "--quiet", "--bench", "native_march", "--", *args],
                           cwd=os.path.join(HERE, ".."), env=env, check=True)
            with open(path) as f:
                result = json.load(f)
        device = result["device"]
        # The portable run's own shader rows repeat the first run's.
        rows += [r for r in result["rows"] if lanes == "auto" or r[1].startswith("native")]
    rows.sort(key=lambda r: r[0] != "float32")
    size, n = (args + ["512", "256"][len(args):])[:2]
    write_table(
        "native_march", "benches/native_march.py",
        ["storage", "engine", "ms", "samples (M)", "ns per sample", "the shader's ns over this engine's",
         "max difference from the shader's image (levels)"],
        rows, device=device,
        note=f"{size}x{size}, {n}^3 double sphere with normals, balanced, empty-space skipping, every core; "
             "median of 3 after a warm-up. shader: the WGSL march on the adapter wgpu picked; native (avx2): "
             "the march of src/cpu, eight rays in an AVX2 register's lanes; native (portable): the same "
             "code on eight lanes of portable Rust (src/cpu/lanes.rs), forced here, the shader's ratio "
             "from that run's own shader frame.",
    )


if __name__ == "__main__":
    main()
