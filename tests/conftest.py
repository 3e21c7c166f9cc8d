import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))

# Keep wgpu off its GL backend in tests: a wgpu GL instance would take over
# the EGL context the moderngl reference renderer uses in this process.
os.environ.setdefault("PYVR_BACKEND", "vulkan")

SHARED_DATA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``shader`` test the shader engine itself (its passes,
    texture sampling, table uploads, or the native engine against it). With
    no GPU adapter (not even lavapipe) there is no shader engine: the native
    engine renders every frame, and those tests cannot run."""
    from pyvr.renderer import device_limits

    if device_limits()["gpu_adapter"]:
        return
    skip = pytest.mark.skip(reason="tests the shader engine, which needs a GPU adapter (none opened here: "
                                   "the native engine renders every frame)")
    for item in items:
        if item.get_closest_marker("shader"):
            item.add_marker(skip)


@pytest.fixture(autouse=True)
def _exact_filtering_on_gpus(request, monkeypatch):
    """Tests compare frames with the float64 integrator at tolerances finer
    than GPUs' texture units interpolate (fixed-point weights, 8 fractional
    bits: 15 levels on a 12-bit CT's steep window on an H200). Where the
    adapter is a GPU, renderers made in a test interpolate in the shader
    (the documented ``PYVR_EXACT_FILTERING=1``, which
    RenderConfig.exact_filtering sets per config), except in tests marked
    texture_units, which compare the two (tests/test_filtering.py). On a
    CPU adapter, or with none, both interpolate in f32 and nothing changes."""
    from pyvr.renderer import device_limits

    if device_limits()["cpu_device"] or request.node.get_closest_marker("texture_units"):
        return
    monkeypatch.setenv("PYVR_EXACT_FILTERING", "1")


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def levels(img):
    """Float image in [0, 1] to 8-bit levels as the renderer rounds them."""
    return np.round(np.clip(img, 0.0, 1.0) * 255.0)
