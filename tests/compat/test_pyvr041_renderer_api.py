"""pyvr 0.4.1's renderer API as code written for it uses it: transfer
functions by its protocol, ``gl_manager.cleanup()``, its messages raised
for real; and the consumers that need pyvr's own renderer say so. (The
window on a renderer with pyvr 0.4.1's API only is tested in
tests/test_interface.py.)"""

import numpy as np
import pytest

from pyvr import VolumeRenderer
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.volume import Volume


@pytest.fixture
def volume():
    d = create_sample_volume(24, "double_sphere")
    return Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]), max_bounds=np.array([1.0, 1, 1]))


def test_newer_consumers_name_the_renderer_they_need(volume):
    from pyvr import distributed

    wrapper = object()  # e.g. a wrapper with pyvr 0.4.1's methods only
    with pytest.raises(TypeError, match="Expected VolumeRenderer instance"):
        distributed.render(wrapper, volume)
    with pytest.raises(TypeError, match="Expected VolumeRenderer instance"):
        distributed.render_path(wrapper, [])


def test_duck_typed_transfer_functions_use_pyvr_041s_protocol_only(volume):
    """An object with ``lut_size`` and ``to_lut`` is a transfer function, as
    in pyvr 0.4.1; any other attribute it has (even one named value_range)
    is not read."""

    class Ramp:
        lut_size = 64
        value_range = "not pyvr's"

        def to_lut(self, size=None):
            return np.linspace(0.0, 1.0, size or self.lut_size)

    class Grey(Ramp):
        def to_lut(self, size=None):
            return np.repeat(np.linspace(0.0, 1.0, size or self.lut_size)[:, None], 3, axis=1)

    r = VolumeRenderer(16, 16)
    r.load_volume(volume)
    r.set_transfer_functions(Grey(), Ramp())
    assert r.value_range == volume.value_range
    np.testing.assert_allclose(r.lut[:, 3], np.linspace(0, 1, 64), atol=1e-7)


def test_gl_manager_is_a_stand_in_for_pyvr_041s_cleanup():
    r = VolumeRenderer(8, 6)
    m = r.gl_manager
    assert m is r.gl_manager and (m.width, m.height) == (8, 6)
    assert m.cleanup() is None
    assert "no OpenGL context" in repr(m)
    from pyvr.moderngl_renderer.renderer import ModernGLVolumeRenderer

    assert ModernGLVolumeRenderer is VolumeRenderer


def test_pyvr_041_messages_at_run_time(tmp_path):
    """A few of pyvr 0.4.1's messages, raised for real (the surface test
    reads them from the source)."""
    from pyvr.camera import Camera, CameraPath
    from pyvr.dataloaders import load_vtk_volume
    from pyvr.datasets import create_sample_volume as make

    vti = tmp_path / "a.vti"
    vti.write_text(
        '<VTKFile type="ImageData" version="1.0"><ImageData WholeExtent="0 1 0 1 0 1" Origin="0 0 0" '
        'Spacing="1 1 1"><Piece Extent="0 1 0 1 0 1"><PointData Scalars="density">'
        '<DataArray type="Float32" Name="density" format="ascii">0 1 2 3 4 5 6 7</DataArray>'
        "</PointData></Piece></ImageData></VTKFile>")
    with pytest.raises(ValueError, match=r"Scalar array 'Scalars_' not found in .*a\.vti\. "
                                         r"Available arrays: \['density'\]"):
        load_vtk_volume(vti)
    assert load_vtk_volume(vti, scalars_name="density").shape == (2, 2, 2)
    with pytest.raises(ValueError, match="^n_frames must be at least 1$"):
        CameraPath([Camera(), Camera.front_view()]).generate_frames(0)
    with pytest.raises(ValueError, match="Unknown shape: x. Available shapes: sphere, torus, double_sphere"):
        make(8, "x")
    with pytest.raises(ValueError, match="target must be a 3D numpy array"):
        Camera(target=np.zeros(2))
