"""
The preset benchmark
====================

pyvr's preset benchmark: 256^3 double_sphere with normals, bounds [-1, 1]^3,
512x512, isometric camera at distance 3, plasma + linear(0, 0.1).

For each preset: a fresh renderer, one warm-up frame, then timed frames.
Prints ms per frame and writes out/benchmark_<preset>.png.

Run: .venv/bin/python examples/benchmark.py [--frames N] [--size PX] [--presets a,b]
"""

import argparse
import time
import warnings

import numpy as np

from _common import out_path, save_grid
from pyvr.camera import Camera
from pyvr.config import RenderConfig
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.moderngl_renderer import VolumeRenderer
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]


def benchmark_scene(n=256):
    t = time.perf_counter()
    data = create_sample_volume(n, "double_sphere")
    volume = Volume(data=data, normals=compute_normal_volume(data),
                    min_bounds=np.array([-1.0, -1.0, -1.0], np.float32), max_bounds=np.array([1.0, 1.0, 1.0], np.float32))
    camera = Camera.from_spherical(target=np.array([0.0, 0.0, 0.0], np.float32), distance=3.0,
                                   azimuth=np.pi / 4, elevation=np.pi / 6, roll=0.0)
    ctf = ColorTransferFunction.from_colormap("plasma")
    otf = OpacityTransferFunction.linear(0.0, 0.1)
    return volume, camera, ctf, otf, time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=5, help="timed frames per preset (default 5)")
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--volume", type=int, default=256, help="volume edge length (default 256)")
    ap.add_argument("--presets", default=",".join(PRESETS))
    args = ap.parse_args()

    volume, camera, ctf, otf, t_scene = benchmark_scene(args.volume)
    print(f"scene: {args.volume}^3 double_sphere + normals, {args.size}x{args.size}, built in {t_scene:.1f} s")
    rows, images, labels = [], [], []
    for name in args.presets.split(","):
        config = getattr(RenderConfig, name)()
        t0 = time.perf_counter()
        renderer = VolumeRenderer(args.size, args.size, config=config, light=Light.default())
        renderer.load_volume(volume)
        renderer.set_camera(camera)
        renderer.set_transfer_functions(ctf, otf)
        setup_ms = (time.perf_counter() - t0) * 1e3
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            t0 = time.perf_counter()
            image = renderer.render()
            first_ms = (time.perf_counter() - t0) * 1e3
        times = []
        for _ in range(args.frames):
            t0 = time.perf_counter()
            image = renderer.render()
            times.append((time.perf_counter() - t0) * 1e3)
        path = out_path(f"benchmark_{name}.png")
        renderer.render_to_pil(image).save(path)
        images.append(image)
        labels.append(f"{name}: {np.median(times):.0f} ms")
        truncated = any("cannot cross" in str(w.message) for w in caught)
        rows.append((name, config, setup_ms, first_ms, times, truncated))

    print(f"device: {renderer.device}")
    print(f"volume stored as: {renderer.counters()['volume_storage']} (precision {renderer.precision!r})")
    engine = renderer.last_frame_stats.get("engine")
    print(f"frames marched by: {'the native CPU march' if engine == 'native' else 'the shader'} ({engine})")
    print(f"{'preset':14s} {'step':>6s} {'max_steps':>9s} {'setup ms':>9s} {'first ms':>9s} "
          f"{'median ms':>10s} {'mean±std ms':>14s} {'FPS':>6s}  note")
    for name, cfg, setup_ms, first_ms, times, truncated in rows:
        t = np.array(times)
        note = "max_steps cuts rays short (warned)" if truncated else ""
        print(f"{name:14s} {cfg.step_size:6.3f} {cfg.max_steps:9d} {setup_ms:9.0f} {first_ms:9.0f} "
              f"{np.median(t):10.1f} {t.mean():8.1f}±{t.std():<5.1f} {1e3 / np.median(t):6.2f}  {note}")
    print("wrote", save_grid(images, labels, out_path("benchmark_presets.png"), cols=len(images)))


if __name__ == "__main__":
    main()
