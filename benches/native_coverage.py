"""Frames the native march took over from the shader later than the
benchmark frame of benches/native_march.py: back-to-front order, the power
opacity correction, single scattering's shadow rays, gradients taken from
central differences at each lit sample, float16 values, and 8-bit volumes
kept as 8-bit codes (fuel.vti's own storage, and the benchmark's double
sphere quantised to it), lit from their gradients, which the native
march's renderer stores beside the values, or (at precision "float32")
from normals stored apart from the codes (a texture of 8-bit normals); and the benchmark scene stored
as float16 and float32 (value, normal) texels, which the march reads a ray
at a time; and unbiased frames (ratio tracking), without early termination
so that both engines draw the same points (with it, the roulette's numbers
hash each point's offset, which their logarithms may round apart). Each
frame is rendered by the shader and by the native march alternately in one
process (`VolumeRenderer.native_march` off and on), and compared by median
time and by the largest difference between their premultiplied images.

Output: a table on stdout and out/native_coverage.json (docs/performance.md).

Run: .venv/bin/python benches/native_coverage.py [--frames N] [--size PX]
"""

import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402
from accuracy import BOX, FUEL  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume, load_vti  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402


def renderer(volume, light, otf, size, native=True, precision="auto"):
    r = VolumeRenderer(size, size, light=light)
    r.native_march = native
    r.load_volume(volume, precision=precision)
    r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), otf)
    return r


def cases(size):
    """(label, renderer, config); a renderer of None reuses the one before."""
    ds = create_sample_volume(256, "double_sphere")
    balanced = RenderConfig.balanced()
    out = [
        ("benchmark scene, back to front",
         renderer(Volume(ds, compute_normal_volume(ds), *BOX), Light.default(),
                  OpacityTransferFunction.linear(0.0, 0.1), size), balanced.replace(order="back_to_front")),
        ("benchmark scene, power correction", None, balanced.replace(opacity_correction="power")),
        ("benchmark scene, unbiased", None, balanced.replace(unbiased=True, early_ray_termination=False)),
        ("double sphere 256^3 as float16, unlit",
         renderer(Volume(ds, None, *BOX), Light.ambient_only(1.0), OpacityTransferFunction.linear(0.0, 0.1), size,
                  precision="float16"), balanced),
        # (value, normal) texels in float32 and in float16: read a ray at a time.
        ("benchmark scene stored as float16",
         renderer(Volume(ds, compute_normal_volume(ds), *BOX), Light.default(),
                  OpacityTransferFunction.linear(0.0, 0.1), size, precision="float16"), balanced),
        ("benchmark scene stored as float32",
         renderer(Volume(ds, compute_normal_volume(ds), *BOX), Light.default(),
                  OpacityTransferFunction.linear(0.0, 0.1), size, precision="float32"), balanced),
        ("double sphere 256^3 as uint8, unlit",
         renderer(Volume(np.round(ds * 255).astype(np.uint8), None, *BOX), Light.ambient_only(1.0),
                  OpacityTransferFunction.linear(0.0, 0.1), size), balanced),
        ("double sphere 256^3 as uint8, mip", None, balanced.replace(model="mip")),
        # 8-bit codes with normals at precision "float32" (by default they
        # are packed as 16-bit fixed point): normals in a texture of their own.
        ("double sphere 256^3 as uint8, lit from normals stored apart",
         renderer(Volume(np.round(ds * 255).astype(np.uint8), compute_normal_volume(ds), *BOX), Light.default(),
                  OpacityTransferFunction.linear(0.0, 0.1), size, precision="float32"), balanced),
        # Values alone, lit: fixed16 texels hold no gradients, so each lit
        # sample takes central differences (six more reads) in both engines.
        ("double sphere 256^3 as fixed16, lit by central differences",
         renderer(Volume(ds, None, *BOX), Light.default(), OpacityTransferFunction.linear(0.0, 0.1), size,
                  precision="fixed16"), balanced),
    ]
    if os.path.exists(FUEL):
        raw = load_vti(FUEL).data
        assert np.array_equal(raw, np.round(raw)) and 0 <= raw.min() and raw.max() <= 255, "fuel.vti holds bytes"
        fuel = Volume(raw.astype(np.uint8), None, *BOX)
        out += [
            ("fuel.vti as uint8, unlit, linear(0, 0.5)",
             renderer(fuel, Light.ambient_only(1.0), OpacityTransferFunction.linear(0.0, 0.5), size), balanced),
            ("fuel.vti as uint8, mip", None, balanced.replace(model="mip")),
            ("fuel.vti as uint8, unbiased", None, balanced.replace(unbiased=True, early_ray_termination=False)),
            ("fuel.vti as uint8, isosurface 0.3", None, balanced.replace(model="isosurface", iso_value=0.3)),
            # Lit from its gradients: the shader's renderer never packs them
            # (it takes central differences at each lit sample); the native
            # one stores the values with their gradients at its first frame.
            ("fuel.vti as uint8, lit from its gradients",
             tuple(renderer(fuel, Light.default(), OpacityTransferFunction.linear(0.0, 0.5), size, native)
                   for native in (False, True)), balanced),
            ("fuel.vti as uint8, lit from normals stored apart",
             renderer(Volume(fuel.data, compute_normal_volume(raw.astype(np.float32) / 255), *BOX), Light.default(),
                      OpacityTransferFunction.linear(0.0, 0.5), size, precision="float32"), balanced),
            ("fuel.vti as uint8, single scattering (lit)",
             renderer(fuel, Light.default(), OpacityTransferFunction.linear(0.0, 0.5), size),
             balanced.replace(model="single_scattering")),
        ]
    return out


def frame(r, cfg, native):
    """`r`: one renderer for both engines, or (the shader's, the native march's)."""
    if isinstance(r, tuple):
        r = r[native]
    r.native_march = native
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        img = r.render(dtype=np.float32, premultiplied=True, config=cfg)
        dt = time.perf_counter() - t
    engine = r.last_frame_stats["engine"]
    assert engine == ("native" if native else "gpu"), f"the {'native' if native else 'shader'} frame ran on {engine}"
    return img, dt


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args()
    rows = []
    r = None
    for label, new, cfg in cases(args.size):
        r = new or r
        shader_img, _ = frame(r, cfg, False)
        native_img, _ = frame(r, cfg, True)
        times = {False: [], True: []}
        for _ in range(args.frames):
            for native in (False, True):
                times[native].append(frame(r, cfg, native)[1])
        shader, native = (float(np.median(times[k]) * 1e3) for k in (False, True))
        diff = np.abs(native_img - shader_img)
        levels = diff.max() * 255
        far = int((diff.max(axis=-1) * 255 > 0.25).sum())
        rows.append([label, round(shader, 1), round(native, 1), f"{shader / native:.2f}x", f"{levels:.3f}", far])
        print(f"  {label:<44} shader {shader:7.1f} ms  native {native:7.1f} ms  {shader / native:5.2f}x  "
              f"max difference {levels:.3f} levels ({far} pixels over 0.25)", flush=True)
    write_table(
        "native_coverage", f"benches/native_coverage.py --frames {args.frames}",
        ["frame", "shader ms", "native ms", "shader / native", "max difference (levels)", "pixels over 0.25 level"],
        rows, device=VolumeRenderer(8, 8).device,
        note=f"{args.size}x{args.size}, balanced, isometric camera at distance 3; both engines alternately in one "
             f"process, median of {args.frames} frames each after a warm-up; differences between their "
             "premultiplied images.",
    )


if __name__ == "__main__":
    main()
