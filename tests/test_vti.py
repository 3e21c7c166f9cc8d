"""The .vti reader against files written here in three of VTK's encodings,
with a field whose every value names its (x, y, z) index."""

import base64
import os
import struct
import zlib

import numpy as np
import pytest

from conftest import SHARED_DATA
from pyvr.datasets import load_vti

SHAPE = (5, 4, 3)  # x, y, z


def field():
    x, y, z = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    return (x + 10 * y + 100 * z).astype(np.float32)


def xml(array_xml, appended=b"", header="UInt32", compressor=None):
    comp = f' compressor="{compressor}"' if compressor else ""
    ext = f"0 {SHAPE[0] - 1} 0 {SHAPE[1] - 1} 0 {SHAPE[2] - 1}"
    head = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
            f'header_type="{header}"{comp}>\n<ImageData WholeExtent="{ext}" Origin="1 2 3" Spacing="0.5 0.5 2">\n'
            f'<Piece Extent="{ext}"><PointData Scalars="f">{array_xml}</PointData></Piece>\n</ImageData>\n')
    return head.encode() + appended + b"</VTKFile>\n"


def vtk_order(a):
    return np.ascontiguousarray(a.transpose(2, 1, 0)).tobytes()  # x fastest


def test_ascii(tmp_path):
    text = " ".join(str(v) for v in np.frombuffer(vtk_order(field()), np.float32))
    p = tmp_path / "a.vti"
    p.write_bytes(xml(f'<DataArray type="Float32" Name="f" format="ascii">{text}</DataArray>'))
    im = load_vti(str(p))
    assert np.array_equal(im.data, field()) and im.data.shape == SHAPE
    assert np.allclose(im.origin, [1, 2, 3]) and np.allclose(im.spacing, [0.5, 0.5, 2])
    lo, hi = im.bounds()
    assert np.allclose(lo, [0.75, 1.75, 2.0]) and np.allclose(hi, [3.25, 3.75, 8.0])


def test_inline_base64(tmp_path):
    raw = vtk_order(field())
    enc = base64.b64encode(struct.pack("<I", len(raw)) + raw).decode()
    p = tmp_path / "b.vti"
    p.write_bytes(xml(f'<DataArray type="Float32" Name="f" format="binary">{enc}</DataArray>'))
    assert np.array_equal(load_vti(str(p)).data, field())


@pytest.mark.parametrize("block", [16, 1 << 15])
def test_appended_zlib_base64(tmp_path, block):
    raw = vtk_order(field())
    blocks = [raw[i:i + block] for i in range(0, len(raw), block)]
    comp = [zlib.compress(b) for b in blocks]
    last = len(blocks[-1]) if len(blocks[-1]) < block else 0
    header = struct.pack(f"<{3 + len(comp)}I", len(comp), block, last, *(len(c) for c in comp))
    payload = b"_" + base64.b64encode(header) + base64.b64encode(b"".join(comp))
    p = tmp_path / "c.vti"
    p.write_bytes(xml('<DataArray type="Float32" Name="f" format="appended" offset="0"/>',
                      b'<AppendedData encoding="base64">' + payload + b"</AppendedData>\n",
                      compressor="vtkZLibDataCompressor"))
    assert np.array_equal(load_vti(str(p)).data, field())


def test_errors(tmp_path):
    p = tmp_path / "d.vti"
    p.write_bytes(xml('<DataArray type="Float32" Name="f" NumberOfComponents="3" format="ascii">0</DataArray>'))
    with pytest.raises(ValueError, match="Multi-component scalars not supported. Array .f. has 3 components, expected 1"):
        load_vti(str(p))
    p.write_bytes(xml('<DataArray type="Float32" Name="f" format="ascii">1 2 3</DataArray>'))
    with pytest.raises(ValueError, match="values for extent"):
        load_vti(str(p))


def test_fuel_when_present():
    path = os.path.join(SHARED_DATA, "fuel.vti")
    if not os.path.exists(path):
        return  # the data set lives beside the project, not in it
    im = load_vti(path)
    assert im.data.shape == (64, 64, 64) and im.data.dtype == np.float32
    assert im.data.min() == 0 and im.data.max() == 255
