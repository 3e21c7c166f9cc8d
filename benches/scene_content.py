"""Frame cost against scene content: does cost follow what is visible?

256^3 volumes in [-1, 1]^3, 512x512, balanced preset, isometric camera.
For each scene, with and without empty-space skipping: median frame time,
samples actually taken per pixel, and the fraction of empty 8^3 cells.
Then memory per voxel by input dtype, and the cost of a camera-only
re-render (bytes uploaded, time) next to the first render.

Run: .venv/bin/python benches/scene_content.py [--size PX] [--volume N] [--frames N]
"""

import argparse
import time
import warnings

import numpy as np

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))


def scenes(n):
    helix = create_sample_volume(n, "helix")
    torus = create_sample_volume(n, "torus")
    spheres = create_sample_volume(n, "double_sphere")
    return {
        "empty TF": (spheres, OpacityTransferFunction.linear(0.0, 0.0)),
        "sparse (helix, one_step 0.5)": (helix, OpacityTransferFunction.one_step(0.5, 0.0, 0.6)),
        "narrow band (torus, peak 0.7)": (torus, OpacityTransferFunction.peaks([0.7], opacity=0.8, eps=0.02)),
        "dense (double_sphere, linear 0-0.1)": (spheres, OpacityTransferFunction.linear(0.0, 0.1)),
        "fully opaque (linear 1-1)": (spheres, OpacityTransferFunction.linear(1.0, 1.0)),
    }


def timed(r, frames):
    r.render()
    times = []
    for _ in range(frames):
        t = time.perf_counter()
        r.render()
        times.append((time.perf_counter() - t) * 1e3)
    return float(np.median(times))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--volume", type=int, default=256)
    ap.add_argument("--frames", type=int, default=3)
    args = ap.parse_args()
    px = args.size * args.size
    camera = Camera.isometric_view(distance=3.0)
    ctf = ColorTransferFunction.from_colormap("plasma")
    print(f"{args.volume}^3 volumes, {args.size}x{args.size}, balanced, Light.default() (gradient shading)")
    print(f"{'scene':38s} {'skip':>5s} {'ms':>8s} {'samples/px':>11s} {'empty cells':>12s}")
    dense_ms = None
    for name, (data, otf) in scenes(args.volume).items():
        for skip in (False, True):
            r = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(), light=Light.default())
            r.empty_space_skipping = skip
            r.load_volume(Volume(data, None, *BOX))
            r.set_camera(camera)
            r.set_transfer_functions(ctf, otf)
            ms = timed(r, args.frames)
            if name.startswith("dense") and skip:
                dense_ms = ms
            print(f"{name:38s} {str(skip):>5s} {ms:8.1f} {r.last_frame_stats['samples'] / px:11.1f} "
                  f"{r.empty_fraction():12.2f}")

    print("\nmemory per voxel on the GPU (volume texture, plus normals when given):")
    base = create_sample_volume(64, "sphere")
    for label, data, normals in [
        ("uint8", (base * 255).astype(np.uint8), None),
        ("uint16", (base * 65535).astype(np.uint16), None),
        ("float32", base, None),
        ("float64 (stored as float32)", base.astype(np.float64), None),
        ("float32 + normals (RGBA16F)", base, compute_normal_volume(base)),
    ]:
        r = VolumeRenderer(8, 8)
        r.load_volume(Volume(data, normals))
        print(f"  {label:30s} {r.counters()['volume_bytes'] / base.size:5.1f} bytes/voxel")

    data = create_sample_volume(args.volume, "double_sphere")
    r = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(), light=Light.default())
    t = time.perf_counter()
    r.load_volume(Volume(data, compute_normal_volume(data), *BOX))
    r.set_camera(camera)
    r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.1))
    r.render()
    first_ms = (time.perf_counter() - t) * 1e3
    first_up = r.last_frame_stats["uploaded_bytes"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r.set_camera(Camera.front_view(distance=3.0))
        t = time.perf_counter()
        r.render()
        cam_ms = (time.perf_counter() - t) * 1e3
    print(f"\nfirst render (upload + frame): {first_ms:.0f} ms, {first_up / 1e6:.1f} MB uploaded")
    print(f"camera-only re-render:         {cam_ms:.0f} ms, {r.last_frame_stats['uploaded_bytes']} bytes uploaded")
    if dense_ms:
        print(f"\nempty TF costs {timed_empty(args, camera, ctf) / dense_ms * 100:.2f}% of the dense scene's frame")


def timed_empty(args, camera, ctf):
    r = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(), light=Light.default())
    r.load_volume(Volume(create_sample_volume(args.volume, "double_sphere"), None, *BOX))
    r.set_camera(camera)
    r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.0))
    return timed(r, args.frames)


if __name__ == "__main__":
    main()
