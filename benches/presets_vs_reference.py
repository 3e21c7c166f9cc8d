"""pyvr's benchmark scene at every preset: our wgpu renderer next to the
moderngl/GLSL reference renderer (same rendering rule, OpenGL on the same
machine), measured in one run.

Scene: 256^3 double_sphere with normals, bounds [-1, 1]^3, 512x512,
isometric camera at distance 3, plasma + linear(0, 0.1), Light.default().
Per preset: median frame time over --frames frames after one warm-up (upload
time excluded for both), the speed ratio, and the difference between the two
images (premultiplied RGBA, 8-bit levels).

Run: .venv/bin/python benches/presets_vs_reference.py [--frames N] [--size PX] [--volume N]
"""

import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, os.path.join(HERE, "..", "examples"))
os.environ.setdefault("PYVR_BACKEND", "vulkan")  # keep wgpu off the EGL context

from benchmark import PRESETS, benchmark_scene  # noqa: E402
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from reference.moderngl_reference import ReferenceRenderer, _context  # noqa: E402


def timed(fn, frames):
    fn()
    out, times = None, []
    for _ in range(frames):
        t = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t) * 1e3)
    return out, float(np.median(times))


def side_by_side(scene, light, ref, preset, size, frames):
    """Our frame and the reference's at `preset` ((volume, camera, ctf, otf)
    of the scene): the median ms of each, the difference of their images in
    8-bit levels, and our last frame's statistics."""
    volume, camera, ctf, otf = scene
    cfg = getattr(RenderConfig, preset)()
    r = VolumeRenderer(size, size, config=cfg, light=light)
    r.load_volume(volume)
    r.set_camera(camera)
    r.set_transfer_functions(ctf, otf)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours, t_ours = timed(lambda: r.render(dtype=np.float32, premultiplied=True), frames)
    theirs, t_ref = timed(lambda: ref.render(camera, light, cfg), frames)
    d = np.abs(np.round(np.clip(ours, 0, 1) * 255) - np.round(np.clip(theirs, 0, 1) * 255))
    return t_ours, t_ref, d, r.last_frame_stats, r.device


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--volume", type=int, default=256)
    ap.add_argument("--presets", default=",".join(PRESETS))
    args = ap.parse_args()
    volume, camera, ctf, otf, _ = benchmark_scene(args.volume)
    light = Light.default()
    ref = ReferenceRenderer(volume, ctf, otf, args.size, args.size)
    print(f"scene: {args.volume}^3 double_sphere + normals, {args.size}x{args.size}")
    print(f"reference: moderngl {_context().info['GL_RENDERER']}")
    lines = []
    for name in args.presets.split(","):
        t_ours, t_ref, d, _, device = side_by_side((volume, camera, ctf, otf), light, ref, name, args.size, args.frames)
        lines.append((name, t_ours, t_ref, d.mean(), np.percentile(d, 99.9), d.max()))
        print(f"  {name}: ours {t_ours:.0f} ms, reference {t_ref:.0f} ms", flush=True)
    print(f"device: {device}")
    print(f"{'preset':14s} {'ours ms':>9s} {'moderngl ms':>12s} {'speed-up':>9s} {'mean diff':>10s} {'p99.9':>6s} {'max':>5s}")
    for name, a, b, mean, p, mx in lines:
        print(f"{name:14s} {a:9.1f} {b:12.1f} {b / a:8.2f}x {mean:10.4f} {p:6.2f} {mx:5.0f}")
    write_table("presets", f"benches/presets_vs_reference.py --frames {args.frames}",
                ["preset", "pyvr (wgpu) ms", "moderngl reference ms", "speed-up", "difference, 8-bit levels: mean / max"],
                [[n, round(a), round(b), f"{b / a:.1f}x", f"{mean:.4f} / {mx:.0f}"] for n, a, b, mean, p, mx in lines],
                device=device, note=f"{args.volume}^3 double_sphere with normals, {args.size}x{args.size}; median of "
                f"{args.frames} frames after a warm-up, uploads excluded; reference: moderngl on "
                f"{_context().info['GL_RENDERER']}.")


if __name__ == "__main__":
    main()
