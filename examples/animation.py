"""
A turntable animation
=====================

A turntable animation: a camera path rendered frame by frame with a
progress bar and written to GIF and MP4 as the frames arrive.

Renders fuel.vti (a real 64^3 simulation, shipped with pyvr), with a light that follows the camera.
Writes out/orbit.gif and out/orbit.mp4 (or the paths given).

Run: .venv/bin/python examples/animation.py [--size 320] [--frames 48] [--out out/orbit.gif out/orbit.mp4]
Needs: pip install 'pyvr-rs[animation,progress]'
"""

import argparse
import os

import pyvr
from _common import out_path
from pyvr import RenderConfig, VolumeRenderer, save_animation
from pyvr.camera import Camera, CameraPath
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction



def main():
    ap = argparse.ArgumentParser(description="A turntable animation of fuel.vti, written to GIF and MP4.")
    ap.add_argument("--size", type=int, default=320)
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--fps", type=float, default=16)
    ap.add_argument("--out", nargs="+", default=[out_path("orbit.gif"), out_path("orbit.mp4")])
    args = ap.parse_args()
    volume = pyvr.datasets.fuel()
    renderer = VolumeRenderer(args.size, args.size, config=RenderConfig.balanced(),
                              light=Light.camera_linked(azimuth_offset=0.5, elevation_offset=0.3, ambient=0.3))
    renderer.load_volume(volume)
    renderer.set_transfer_functions(ColorTransferFunction.from_colormap("turbo"),
                                    OpacityTransferFunction(control_points=[(0.0, 0.0), (0.03, 0.0), (0.15, 0.5),
                                                                            (1.0, 1.0)]))
    start = Camera.fit(volume, azimuth=0.6, elevation=0.4)
    start.distance *= 0.6
    # One full turn; the last frame would repeat the first, so a loop leaves it out.
    path = CameraPath.orbit(start, turns=1)
    for out in args.out:
        n = save_animation(renderer.render_path(path, args.frames, endpoint=False), out, fps=args.fps,
                           background=(0.04, 0.04, 0.06))
        print(f"wrote {n} frames to {out} ({os.path.getsize(out) / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
