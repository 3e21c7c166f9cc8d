"""Frame cost against scene content: does cost follow what is visible?

256^3 volumes in [-1, 1]^3, 512x512, balanced preset, isometric camera.
For each scene, with and without empty-space skipping: median frame time,
samples actually taken per pixel, and the fraction of empty 8^3 cells.
Next to them, in the same run: the moderngl/GLSL reference (pyvr's
semantics, balanced) and VTK's CPU ray caster (vtkFixedPointVolumeRayCastMapper,
sample distance 0.01) on the same scenes (--no-peers to leave them out).
Then memory per voxel by input dtype, and the cost of a camera-only
re-render (bytes uploaded, time) next to the first render.

Run: .venv/bin/python benches/scene_content.py [--size PX] [--volume N] [--frames N]
"""

import argparse
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
os.environ.setdefault("PYVR_BACKEND", "vulkan")  # keep wgpu off the EGL contexts of the peers

from _report import write_table  # noqa: E402
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
    ap.add_argument("--no-peers", action="store_true")
    args = ap.parse_args()
    px = args.size * args.size
    camera = Camera.isometric_view(distance=3.0)
    ctf = ColorTransferFunction.from_colormap("plasma")
    print(f"{args.volume}^3 volumes, {args.size}x{args.size}, balanced, Light.default() (gradient shading)")
    print(f"{'scene':38s} {'skip':>5s} {'ms':>8s} {'samples/px':>11s} {'empty cells':>12s}")
    dense_ms = None
    ours = {}
    table = {}
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
            if skip:
                ours[name] = ms
            print(f"{name:38s} {str(skip):>5s} {ms:8.1f} {r.last_frame_stats['samples'] / px:11.1f} "
                  f"{r.empty_fraction():12.2f}")
            table.setdefault(name, []).append((ms, r.last_frame_stats["samples"] / px, r.empty_fraction()))
    command = f"benches/scene_content.py --frames {args.frames}"
    setting = f"{args.volume}^3 volumes in [-1, 1]^3, {args.size}x{args.size}, balanced, gradient shading"
    write_table("scene_content", command,
                ["scene", "skipping off / on: ms", "samples per pixel", "empty 8^3 cells"],
                [[n, f"{off[0]:.1f} / {on[0]:.1f}", f"{off[1]:.1f} / {on[1]:.1f}", f"{on[2]:.0%}"]
                 for n, (off, on) in table.items()],
                device=r.device, note=setting + f"; median of {args.frames} frames after a warm-up.")
    if not args.no_peers:
        peers(args, camera, ctf, ours)

    print("\nmemory per voxel on the GPU (volume texture, plus normals when given):")
    memory = []
    base = create_sample_volume(64, "sphere")
    normals = compute_normal_volume(base)
    for label, data, nrm, precision in [
        ("uint8", (base * 255).astype(np.uint8), None, "auto"),
        ("uint16", (base * 65535).astype(np.uint16), None, "auto"),
        ("float32", base, None, "auto"),
        ("float64 (stored as float32)", base.astype(np.float64), None, "auto"),
        ("float32 + normals", base, normals, "auto"),
        ("uint8 + normals", (base * 255).astype(np.uint8), normals, "auto"),
        ("float32 + normals, precision='float32'", base, normals, "float32"),
        ("uint8 + normals, precision='float32'", (base * 255).astype(np.uint8), normals, "float32"),
        ("float32, precision='fixed16'", base, None, "fixed16"),
        ("float32, precision='float16'", base, None, "float16"),
        ("float32 + normals, precision='float16'", base, normals, "float16"),
    ]:
        r = VolumeRenderer(8, 8)
        r.load_volume(Volume(data, nrm), precision=precision)
        print(f"  {label:40s} {r.counters()['volume_bytes'] / base.size:5.1f} bytes/voxel")
        memory.append([label, r.counters()["volume_storage"], f"{r.counters()['volume_bytes'] / base.size:.1f}"])
    write_table("memory", command, ["stored as (precision 'auto' unless named)", "device format", "bytes per voxel"],
                memory, device=r.device)

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
    rerender = [["first render (upload + frame)", f"{first_ms:.0f}", f"{first_up:,}"],
                ["camera-only re-render", f"{cam_ms:.0f}", f"{r.last_frame_stats['uploaded_bytes']:,}"]]
    if dense_ms:
        empty = timed_empty(args, camera, ctf)
        print(f"\nempty TF costs {empty / dense_ms * 100:.2f}% of the dense scene's frame")
        rerender.append(["empty TF (share of the dense frame)", f"{empty:.1f} ({empty / dense_ms:.2%})", "0"])
    write_table("rerender", command, ["frame", "ms", "bytes uploaded"], rerender, device=r.device,
                note=f"{args.volume}^3 double_sphere with normals, {args.size}x{args.size}, balanced.")


def peers(args, camera, ctf, ours):
    """The same scenes on the moderngl reference, then VTK's CPU caster
    (after: VTK's EGL windows leave their context current)."""
    from reference.moderngl_reference import ReferenceRenderer

    light = Light.default()
    cfg = RenderConfig.balanced()
    rows = {}
    luts = {}
    for name, (data, otf) in scenes(args.volume).items():
        vol = Volume(data, None, *BOX)
        ref = ReferenceRenderer(vol, ctf, otf, args.size, args.size)
        ref.render(camera, light, cfg)
        times = []
        for _ in range(args.frames):
            t = time.perf_counter()
            ref.render(camera, light, cfg)
            times.append((time.perf_counter() - t) * 1e3)
        ref.release()
        rows[name] = [float(np.median(times))]
        r = VolumeRenderer(8, 8)
        r.set_transfer_functions(ctf, otf)
        luts[name] = r.lut
    try:
        from peers import VtkPeer
    except ImportError:
        VtkPeer = None
    for name, (data, _otf) in scenes(args.volume).items():
        if VtkPeer is None:
            rows[name].append(float("nan"))
            continue
        try:
            peer = VtkPeer("cpu", Volume(data, None, *BOX), luts[name], camera, light, (args.size, args.size),
                           cfg.reference_step_size)
        except ImportError:
            rows[name].append(float("nan"))
            continue
        peer.render(0.01)
        times = []
        for _ in range(args.frames):
            t = time.perf_counter()
            peer.render(0.01)
            times.append((time.perf_counter() - t) * 1e3)
        peer.release()
        rows[name].append(float(np.median(times)))
    print(f"\npeers on the same scenes ({args.size}x{args.size}; ours with skipping, ratio = peer / ours):")
    print(f"{'scene':38s} {'ours':>8s} {'moderngl':>9s} {'ratio':>6s} {'VTK CPU':>8s} {'ratio':>6s}")
    for name, (gl, vt) in rows.items():
        o = ours[name]
        print(f"{name:38s} {o:8.1f} {gl:9.1f} {gl / o:6.1f} {vt:8.1f} {vt / o:6.1f}")
    write_table("scene_peers", f"benches/scene_content.py --frames {args.frames}",
                ["scene", "pyvr ms", "moderngl ms", "moderngl / pyvr", "VTK CPU ms", "VTK / pyvr"],
                [[n, f"{ours[n]:.1f}", f"{gl:.0f}", f"{gl / ours[n]:.1f}", f"{vt:.0f}", f"{vt / ours[n]:.1f}"]
                 for n, (gl, vt) in rows.items()],
                note="Same scenes and run; pyvr with skipping, the moderngl reference at balanced, VTK's "
                "vtkFixedPointVolumeRayCastMapper at sample distance 0.01.")


def timed_empty(args, camera, ctf):
    r = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(), light=Light.default())
    r.load_volume(Volume(create_sample_volume(args.volume, "double_sphere"), None, *BOX))
    r.set_camera(camera)
    r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.0))
    return timed(r, args.frames)


if __name__ == "__main__":
    main()
