"""pyvr on a GPU: the benchmark scene's samples per second against the card's
texture rate, and our frames against the moderngl reference (pyvr 0.4.1's
rendering rule, OpenGL) on the same card.

Scene: 256^3 double_sphere with normals, bounds [-1, 1]^3, isometric camera
at distance 3, plasma + linear(0, 0.1), Light.default() (as
benches/presets_vs_reference.py). For each preset and each image size in
--sizes: the median frame time over --frames frames after one warm-up, by the
host clock around render() (submission and the copy back of the image are
in it, uploads are not), for both renderers; the samples our frame took
(last_frame_stats) and the rate that gives; and the difference between the
two images (premultiplied RGBA, 8-bit levels).

Texture rate: --texture-rate, the card's bilinear lookups per second in
G/s (texture units x clock, from the card's datasheet; wgpu does not report
it). A lit sample of this scene makes five bilinear lookups' worth of
texture work: a trilinear fetch of the volume and one of its normals (two
bilinear lookups each) and one of the colour/opacity table. "texture use"
is samples/s x 5 over the rate, so 100% is the texture units' limit; frames
that skip empty space and stop early spend no lookups on what they skip.

On a machine whose adapter is a CPU this runs too (the frames are the
native march's or lavapipe's), but the texture rate means nothing there.

Run: .venv/bin/python benches/gpu_card.py [--frames N] [--sizes 512,2048] [--texture-rate G]
"""

import argparse
import os
import sys


HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, os.path.join(HERE, "..", "examples"))
os.environ.setdefault("PYVR_BACKEND", "vulkan")  # keep wgpu off the EGL context

from benchmark import PRESETS, benchmark_scene  # noqa: E402
from _report import write_table  # noqa: E402
from presets_vs_reference import side_by_side  # noqa: E402
from pyvr import VolumeRenderer  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from reference.moderngl_reference import ReferenceRenderer, _context  # noqa: E402

# Bilinear lookups a lit sample of the benchmark scene costs the texture
# units: volume and normals trilinear (two each), the table one.
LOOKUPS_PER_SAMPLE = 5


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--sizes", default="512,2048")
    ap.add_argument("--volume", type=int, default=256)
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--texture-rate", type=float, default=0.0,
                    help="the card's bilinear texture lookups per second, in G/s (0: not reported)")
    args = ap.parse_args()
    volume, camera, ctf, otf, _ = benchmark_scene(args.volume)
    light = Light.default()
    gl = _context().info["GL_RENDERER"]
    device = VolumeRenderer(8, 8).device
    print(f"scene: {args.volume}^3 double_sphere + normals; ours on {device}; reference: moderngl on {gl}", flush=True)
    rows = []
    for size in (int(s) for s in args.sizes.split(",")):
        ref = ReferenceRenderer(volume, ctf, otf, size, size)
        for name in args.presets.split(","):
            t_ours, t_ref, d, stats, _ = side_by_side((volume, camera, ctf, otf), light, ref, name, size, args.frames)
            samples = stats["samples"]
            rate = samples / (t_ours * 1e-3)
            use = rate * LOOKUPS_PER_SAMPLE / (args.texture_rate * 1e9) if args.texture_rate > 0 else float("nan")
            rows.append((size, name, t_ours, t_ref, samples, rate, use, d.mean(), d.max(), stats["engine"]))
            print(f"  {size}² {name}: ours {t_ours:.2f} ms ({samples / 1e6:.1f} M samples, {rate / 1e9:.2f} G/s), "
                  f"reference {t_ref:.2f} ms", flush=True)
    print(f"{'size':>5s} {'preset':14s} {'ours ms':>8s} {'moderngl ms':>11s} {'speed-up':>8s} {'M samples':>9s} "
          f"{'G samples/s':>11s} {'texture use':>11s} {'diff mean':>9s} {'max':>4s}")
    for size, name, a, b, s, rate, use, mean, mx, _ in rows:
        print(f"{size:5d} {name:14s} {a:8.2f} {b:11.2f} {b / a:7.2f}x {s / 1e6:9.1f} {rate / 1e9:11.2f} "
              f"{'-' if use != use else f'{use:.1%}':>11s} {mean:9.4f} {mx:4.0f}")
    rate_note = (f"texture use: samples/s x {LOOKUPS_PER_SAMPLE} bilinear lookups over the card's "
                 f"{args.texture_rate:.0f} G lookups/s (datasheet)" if args.texture_rate > 0
                 else "texture use: not reported (no --texture-rate)")
    write_table("gpu_card", f"benches/gpu_card.py --frames {args.frames} --sizes {args.sizes}"
                + (f" --texture-rate {args.texture_rate:g}" if args.texture_rate > 0 else ""),
                ["image", "preset", "pyvr ms", "moderngl reference ms", "speed-up", "samples (M)", "G samples/s",
                 "texture use", "difference, 8-bit levels: mean / max"],
                [[f"{size}²", name, f"{a:.2f}", f"{b:.2f}", f"{b / a:.1f}x", f"{s / 1e6:.1f}", f"{rate / 1e9:.2f}",
                  "-" if use != use else f"{use:.0%}", f"{mean:.4f} / {mx:.0f}"]
                 for size, name, a, b, s, rate, use, mean, mx, _ in rows],
                device=device, note=f"{args.volume}^3 double_sphere with normals, lit; median of {args.frames} frames "
                f"after a warm-up by the host clock (submission and the image's copy back included, uploads "
                f"excluded), both renderers alike; reference: moderngl on {gl}; {rate_note}.")


if __name__ == "__main__":
    main()
