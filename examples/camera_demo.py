"""
Cameras
=======

pyvr's camera demo: six views of a double sphere (presets, orbit, path).

Run: .venv/bin/python examples/camera_demo.py  (writes out/camera_demo.png)
"""

import numpy as np

from _common import out_path, save_grid
from pyvr.camera import Camera, CameraController, CameraPath
from pyvr.config import RenderConfig
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.moderngl_renderer import VolumeRenderer
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

data = create_sample_volume(128, "double_sphere")
volume = Volume(data=data, normals=compute_normal_volume(data),
                min_bounds=np.array([-1.0, -1.0, -1.0], np.float32), max_bounds=np.array([1.0, 1.0, 1.0], np.float32))
renderer = VolumeRenderer(384, 384, config=RenderConfig.balanced())
renderer.load_volume(volume)
renderer.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.1))

controller = CameraController(Camera.front_view(distance=3.0))
controller.orbit(delta_azimuth=np.pi / 4, delta_elevation=np.pi / 6)
target = np.array([0.0, 0.0, 0.0], np.float32)
path = CameraPath([Camera.front_view(distance=2.5), Camera(target=target, azimuth=3 * np.pi / 4,
                                                             elevation=np.pi / 6, roll=0.0, distance=4.0)])
views = {
    "front": Camera.front_view(distance=3.0),
    "side": Camera.side_view(distance=3.0),
    "top": Camera.top_view(distance=3.0),
    "isometric": Camera.isometric_view(distance=3.0),
    "orbit (+45°, +30°)": controller.params,
    "path t=0.7": path.interpolate(0.7),
}
images = []
for name, cam in views.items():
    renderer.set_camera(cam)
    images.append(renderer.render())
    print(f"{name:20s} az={np.degrees(cam.azimuth):7.1f}° el={np.degrees(cam.elevation):6.1f}° d={cam.distance:.2f}")
print("wrote", save_grid(images, list(views), out_path("camera_demo.png")))
