"""Scenes and renderers the tests share: one place for the set-up that
every test module would otherwise repeat."""

import warnings

import numpy as np

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction


def blob(shape, centre=(0.0, 0.0, 0.0), width=None, scale=None):
    """A smooth Gaussian on the [-1, 1] grid of ``shape`` (float32):
    ``exp(-r^2 / width^2)`` around ``centre``, or ``exp(-scale * r^2)``."""
    axes = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    r2 = sum((c - c0) ** 2 for c, c0 in zip(axes, centre))
    return np.exp(-scale * r2 if scale is not None else -r2 / width**2).astype(np.float32)


def make_renderer(volume, *, size=(48, 40), config=None, light=None, camera=None, ctf=None, otf=None,
                  value_range=None, precision="float32", skip=True):
    """A renderer with ``volume`` loaded, a camera and transfer functions set.
    Defaults: balanced, the default light, isometric at distance 3, viridis
    colours over a linear 0 -> 0.4 opacity ramp."""
    r = VolumeRenderer(*size, config=config or RenderConfig.balanced(), light=light or Light.default())
    r.empty_space_skipping = skip
    r.load_volume(volume, precision=precision)
    r.set_camera(camera or Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ctf or ColorTransferFunction.from_colormap("viridis"),
                             otf or OpacityTransferFunction.linear(0.0, 0.4), value_range=value_range)
    return r


def frame(r, **options):
    """The renderer's premultiplied float32 frame, its warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return r.render(dtype=np.float32, premultiplied=True, **options)
