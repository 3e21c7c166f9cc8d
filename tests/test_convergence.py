"""Order of convergence in the step size (in the manner of Etiene et al.,
"Verifying Volume Rendering Using Discretization Error Analysis", TVCG 2014).

Rule: segments sampled at their midpoints, each composited with its exact
Beer–Lambert opacity. For a smooth field and smooth transfer function the
optical depth is a composite midpoint sum and the emission a midpoint sum
weighted by exact segment transmittance, so the error falls as O(h^2):
halving the step divides it by ~4. (Sampling at segment starts, pyvr's
rule, would be O(h).) The volume is trilinear (C0 at voxel faces); kinks
contribute O(h^2) each and do not change the order. Lighting uses supplied
(trilinearly interpolated, so continuous) normals: on-the-fly gradients of a
trilinear field jump at voxel faces, which is first order at worst.
Errors are RMS over the image, against the f64 integrator at h/16.
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume


def smooth_scene(lit):
    n = 24
    ax = np.linspace(-1, 1, n)
    x, y, z = np.meshgrid(ax, ax, ax, indexing="ij")
    data = np.exp(-((x - 0.1) ** 2 + (y + 0.15) ** 2 + z**2) / 0.3).astype(np.float32)
    r = VolumeRenderer(24, 20, light=Light.default() if lit else Light.ambient_only(1.0))
    normals = compute_normal_volume(data) if lit else None
    r.load_volume(Volume(data, normals))
    r.set_camera(Camera(azimuth=0.4, elevation=0.3, distance=2.2))
    r.set_transfer_functions(ColorTransferFunction.two_color_ramp((0.9, 0.2, 0.1), (0.1, 0.5, 1.0)),
                             OpacityTransferFunction.linear(0.0, 0.6))
    return r


def rms(d):
    return float(np.sqrt(np.mean(d**2)))


def config(h):
    return RenderConfig(step_size=h, max_steps=100_000 if h < 1e-3 else 10_000, early_ray_termination=False)


@pytest.mark.parametrize("lit", [False, True])
def test_f64_integrator_converges_at_second_order(lit):
    r = smooth_scene(lit)
    steps = [0.08, 0.04, 0.02, 0.01]
    with pytest.warns(UserWarning, match="very large"):
        ref = r.render_float64(config=config(0.01 / 16), premultiplied=True)
    errors = [rms(r.render_float64(config=config(h), premultiplied=True) - ref) for h in steps]
    orders = [np.log2(a / b) for a, b in zip(errors, errors[1:])]
    print("lit" if lit else "unlit", "errors", errors, "observed orders", orders)
    assert all(1.7 < p < 2.4 for p in orders), orders


def test_gpu_follows_the_same_order_until_float32_noise():
    r = smooth_scene(False)
    with pytest.warns(UserWarning, match="very large"):
        ref = r.render_float64(config=config(0.01 / 16), premultiplied=True)
    steps = [0.08, 0.04, 0.02]
    errors = []
    for h in steps:
        r.set_config(config(h))
        errors.append(rms(r.render(dtype=np.float32, premultiplied=True) - ref))
    orders = [np.log2(a / b) for a, b in zip(errors, errors[1:])]
    print("gpu errors", errors, "observed orders", orders)
    assert all(1.6 < p < 2.5 for p in orders), orders
