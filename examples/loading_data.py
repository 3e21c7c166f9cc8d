"""
Loading real data
=================

Real data in one line each: a volume file loaded with pyvr.load, its
transfer function defined in the data's own units, framed by the default
camera, cropped, and composited over a background.

Renders fuel.vti (a real 64^3 simulation of fuel injection, values 0..255,
shipped with pyvr: ``pyvr.datasets.fuel()``) and a CT-like phantom written to a .raw file
in Hounsfield units with two CT windows. Writes out/loading_data.png.

Run: .venv/bin/python examples/loading_data.py
"""

import os
import tempfile

import numpy as np

import pyvr
from _common import out_path, save_grid
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.dataloaders import save_raw
from pyvr.datasets import shepp_logan_3d
from pyvr.transferfunctions import CT_WINDOWS, ColorTransferFunction, OpacityTransferFunction, window_level

SIZE = 320


def frame(volume, ctf, otf, value_range=None, crop=None, camera=None):
    r = VolumeRenderer(SIZE, SIZE, config=RenderConfig.balanced())
    r.load_volume(volume)
    if camera is not None:
        r.set_camera(camera)
    r.set_transfer_functions(ctf, otf, value_range=value_range)
    if crop is not None:
        r.set_crop_box(*crop)
    return r.render(background=(0.08, 0.08, 0.11))


def main():
    images, labels = [], []
    fuel = pyvr.datasets.fuel()  # unit box, value_range = data range (0..255)
    print(fuel, "value_range", fuel.value_range, "spacing", fuel.metadata["spacing"])
    otf = OpacityTransferFunction([(0.0, 0.0), (0.05, 0.0), (0.3, 0.15), (1.0, 0.6)])
    cam = Camera.fit(fuel, azimuth=0.6, elevation=0.35)
    cam.distance *= 0.5  # the plume fills the middle of its box
    images.append(frame(fuel, ColorTransferFunction.from_colormap("inferno"), otf, camera=cam))
    labels.append("fuel.vti, TF over its data range")
    images.append(frame(fuel, ColorTransferFunction.from_colormap("inferno"), otf, camera=cam,
                        crop=((-1, -1, -1), (1, 0.0, 1))))
    labels.append("cropped at y = 0")
    # A CT-like head phantom in Hounsfield units, anisotropic voxels, in a .raw file.
    # Phantom levels 0 (air), 0.2 (brain), 0.3 (lesions), 1 (skull) as HU.
    hu = np.interp(shepp_logan_3d(128), [0, 0.2, 0.3, 1], [-1000, 30, 70, 1000]).astype(np.int16)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "head.raw")
        save_raw(path, hu[:, :, ::2], spacing=(1.0, 1.0, 2.0), units="mm")  # 128 x 128 x 64, 2 mm slices
        head = pyvr.load(path)
    print(head, "physical extent (mm):", np.subtract(*head.metadata["physical_bounds"][::-1]))
    bone = OpacityTransferFunction([(0.0, 0.0), (0.4, 0.0), (0.5, 0.5), (1.0, 0.8)])
    # Brain (30 HU) faint, lesions (70 HU) dense, skull (clamped to 1) clear.
    tissue = OpacityTransferFunction([(0.0, 0.0), (0.45, 0.0), (0.48, 0.01), (0.55, 0.01), (0.58, 0.4),
                                      (0.9, 0.4), (0.92, 0.0), (1.0, 0.0)])
    cam = Camera.fit(head, azimuth=0.7, elevation=0.3)
    images.append(frame(head, ColorTransferFunction.from_colormap("bone"), bone,
                        value_range=window_level(*CT_WINDOWS["full"]), camera=cam))
    labels.append("raw CT, full window (-1000..3000 HU)")
    images.append(frame(head, ColorTransferFunction.from_colormap("magma"), tissue,
                        value_range=window_level(400, 40), camera=cam, crop=((-1, -1, -1), (1, 1, 0.1))))
    labels.append("same file, window 400/40, cropped")
    print("wrote", save_grid(images, labels, out_path("loading_data.png"), cols=2))


if __name__ == "__main__":
    main()
