"""The documented fallback backend (PYVR_BACKEND=gl, wgpu's OpenGL path;
llvmpipe here) renders the same frames as Vulkan. It runs in its own
process: a wgpu GL instance takes over the EGL context moderngl uses in
the test process."""

import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from run_case import gl_scenes  # noqa: E402


def test_gl_renders_what_vulkan_renders(tmp_path):
    out = tmp_path / "gl.npz"
    p = subprocess.run([sys.executable, os.path.join(HERE, "run_case.py"), "gl_frames", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert "OK saved" in p.stdout, p.stdout[-2000:] + p.stderr[-3000:]
    gl = np.load(out)
    assert "Gl" in str(gl["device"]), gl["device"]
    vk = gl_scenes()
    for name, img in vk.items():
        assert img[..., 3].max() > 0.2, name
        # The same WGSL through two compilers: float rounding only.
        assert np.abs(gl[name] - img).max() < 1.0 / 255, (name, np.abs(gl[name] - img).max() * 255)
