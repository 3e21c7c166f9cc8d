import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))

# Keep wgpu off its GL backend in tests: a wgpu GL instance would take over
# the EGL context the moderngl reference renderer uses in this process.
os.environ.setdefault("PYVR_BACKEND", "vulkan")

SHARED_DATA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data")


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def levels(img):
    """Float image in [0, 1] to 8-bit levels as the renderer rounds them."""
    return np.round(np.clip(img, 0.0, 1.0) * 255.0)
