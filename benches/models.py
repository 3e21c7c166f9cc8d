"""What each optical model costs on the same scene, and a picture of each.

Scenes: the fuel injection volume (../shared/data/fuel.vti, 64^3, values
scaled to [0, 1], box [-1, 1]^3) and pyvr's benchmark scene (256^3
double_sphere with normals). 512x512, balanced preset, isometric camera at
distance 3. For each model: median frame time over --frames frames after
one warm-up frame, samples taken per pixel (shadow-ray samples included)
and the passes the frame took. Writes the gallery of the fuel scene to
--gallery (PNG).

Run: .venv/bin/python benches/models.py [--size PX] [--frames N] [--gallery PATH]
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "examples"))

from _common import out_path, save_grid  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume, load_vti  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

FUEL = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "fuel.vti")
BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))


def model_setups():
    """(label, config changes, colour TF, opacity TF, light) per model."""
    plasma = ColorTransferFunction.from_colormap("plasma", value_range=(0.0, 0.35))
    gray = ColorTransferFunction.from_colormap("gray")
    dense = OpacityTransferFunction([(0.0, 0.0), (0.05, 0.02), (0.6, 0.5), (1.0, 0.5)])
    sun = Light.directional([-1.0, -0.6, -0.4], ambient=0.3, diffuse=0.9)
    return [
        ("emission_absorption", {}, plasma, dense, Light.default()),
        ("absorption", {"model": "absorption"}, gray, OpacityTransferFunction.linear(0.0, 0.1), Light.default()),
        ("emission", {"model": "emission"}, plasma, OpacityTransferFunction.linear(0.0, 0.1), Light.default()),
        ("single_scattering", {"model": "single_scattering", "anisotropy": 0.3}, plasma, dense, sun),
        ("mip", {"model": "mip"}, ColorTransferFunction.from_colormap("inferno"),
         OpacityTransferFunction.linear(0.0, 1.0), Light.default()),
        # Every ray through fuel.vti's box meets zeros: its minimum is 0 everywhere.
        ("minip", {"model": "minip"}, ColorTransferFunction.from_colormap("viridis"),
         OpacityTransferFunction.linear(1.0, 0.0), Light.default()),
        ("average", {"model": "average"}, ColorTransferFunction.from_colormap("viridis", value_range=(0.0, 0.08)),
         OpacityTransferFunction([(0.0, 0.0), (0.08, 1.0), (1.0, 1.0)]), Light.default()),
        ("isosurface", {"model": "isosurface", "iso_value": 0.3}, ColorTransferFunction.single_color((0.85, 0.75, 0.6)),
         dense, sun),
        ("ea + pre-integration", {"pre_integrated": True}, plasma, dense, Light.default()),
        ("ea + jitter", {"jitter": True}, plasma, dense, Light.default()),
        ("ea unbiased", {"unbiased": True}, plasma, dense, Light.default()),
        ("ea back-to-front", {"order": "back_to_front"}, plasma, dense, Light.default()),
    ]


def run(volume, size, frames, keep_images=False):
    rows, images = [], []
    for label, changes, ctf, otf, light in model_setups():
        cfg = RenderConfig.balanced().replace(**changes)
        r = VolumeRenderer(size, size, config=cfg, light=light)
        r.load_volume(volume)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ctf, otf)
        img = r.render()
        times = []
        for _ in range(frames):
            t = time.perf_counter()
            r.render()
            times.append((time.perf_counter() - t) * 1e3)
        st = r.last_frame_stats
        rows.append((label, float(np.median(times)), st["samples"] / (size * size), st["passes"], st["engine"]))
        if keep_images:
            img = img.copy()
            if label == "emission":
                img[..., 3] = img[..., :3].max(axis=-1)  # additive glow: show it added to the background
            elif label == "absorption":
                # Shown as a radiograph: transmittance over a white backlight.
                img[..., :3] = (255 - img[..., 3:4].astype(np.int32)).astype(np.uint8)
                img[..., 3] = 255
            images.append(img)
    return rows, images


def table(title, rows, name, args):
    print(f"\n{title}")
    base = rows[0][1]
    # Whole-frame time over samples (setup and readback included).
    ns = {label: ms * 1e6 / max(spp * args.size**2, 1.0) for label, ms, spp, _, _ in rows}
    print(f"{'model':<22} {'ms/frame':>9} {'vs EA':>6} {'samples/px':>11} {'ns/sample':>10} {'passes':>6} engine")
    for label, ms, spp, passes, engine in rows:
        print(f"{label:<22} {ms:9.1f} {ms / base:6.2f} {spp:11.1f} {ns[label]:10.1f} {passes:6d} {engine}")
    write_table(name, f"benches/models.py --frames {args.frames}",
                ["model", "ms per frame", "vs emission_absorption", "samples per pixel", "ns per sample", "passes",
                 "engine"],
                [[label, f"{ms:.1f}", f"{ms / base:.2f}", f"{spp:.1f}", f"{ns[label]:.1f}", passes, engine]
                 for label, ms, spp, passes, engine in rows],
                device=VolumeRenderer(8, 8).device,
                note=f"{title}, {args.size}x{args.size}, balanced, isometric camera at distance 3; median of "
                f"{args.frames} frames after a warm-up. ns per sample: frame time over samples taken (shadow "
                "samples included; the native march's maximum and minimum projections leap cells that cannot "
                "change their pixel, uncounted); average's (one fetch and a sum per sample) is what a sample costs "
                "this device at the least. engine: native, the CPU march of src/cpu (where the adapter is a CPU); "
                "gpu, the shader.")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--gallery", default=out_path("models.png"))
    ap.add_argument("--skip-benchmark-scene", action="store_true")
    args = ap.parse_args()
    print(f"{args.size}x{args.size}, balanced (step 0.01), isometric camera at distance 3")
    if os.path.exists(FUEL):
        fuel = load_vti(FUEL).data / np.float32(255.0)
        vol = Volume(fuel.astype(np.float32), None, *BOX)
        rows, images = run(vol, args.size, args.frames, keep_images=True)
        table("fuel.vti (64^3 float32)", rows, "models_fuel", args)
        labels = [r[0] for r in rows[:8]]
        labels[1] = "absorption (over white)"
        labels[5] = "minip (0 on every ray)"
        save_grid(images[:8], labels, args.gallery, cols=4)
        print(f"gallery: {os.path.normpath(args.gallery)}")
    else:
        print(f"{FUEL} not found: fuel scene skipped")
    if not args.skip_benchmark_scene:
        ds = create_sample_volume(256, "double_sphere")
        vol = Volume(ds, compute_normal_volume(ds), *BOX)
        rows, _ = run(vol, args.size, args.frames)
        table("benchmark scene (256^3 double_sphere with normals)", rows, "models_benchmark", args)


if __name__ == "__main__":
    main()
