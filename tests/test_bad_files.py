"""Damaged and hostile files for the readers pyvr parses itself (.vti,
legacy .vtk, .raw + .raw.info): each gives a ValueError (FileFormatError)
or OSError naming the file and the problem, before any large allocation."""

import struct
import tracemalloc
import zlib

import numpy as np
import pytest

import pyvr
from pyvr.dataloaders import FileFormatError, load_legacy_vtk, load_raw, load_vti, save_raw


def vti(path, extent="0 3 0 3 0 3", dtype="Float32", array_attrs='format="appended" offset="0"', appended=b"",
        compressor=True, piece_extent=None, header="UInt32"):
    comp = ' compressor="vtkZLibDataCompressor"' if compressor else ""
    piece = piece_extent or extent
    path.write_bytes(
        (f'<?xml version="1.0"?><VTKFile type="ImageData" byte_order="LittleEndian" header_type="{header}"{comp}>'
         f'<ImageData WholeExtent="{extent}" Origin="0 0 0" Spacing="1 1 1"><Piece Extent="{piece}">'
         f'<PointData Scalars="s"><DataArray type="{dtype}" Name="s" {array_attrs}/></PointData></Piece>'
         f'</ImageData><AppendedData encoding="raw">_').encode() + appended + b"</AppendedData></VTKFile>")
    return path


def zlib_blocks(raw, block, claimed_last=None):
    comp = [zlib.compress(raw[i:i + block]) for i in range(0, len(raw), block)]
    last = len(raw) % block if claimed_last is None else claimed_last
    return struct.pack(f"<{3 + len(comp)}I", len(comp), block, last, *(len(c) for c in comp)) + b"".join(comp)


def good_payload(n=64):
    return zlib_blocks(np.arange(n, dtype=np.float32).tobytes(), 64)


def test_vti_reads_the_good_file(tmp_path):
    im = load_vti(vti(tmp_path / "ok.vti", appended=good_payload()))
    assert im.data.shape == (4, 4, 4) and im.data[1, 0, 0] == 1 and im.data[0, 0, 1] == 16


@pytest.mark.parametrize("case,kwargs,message", [
    ("truncated", dict(appended=good_payload()[:-20]), "cut short|damaged"),
    ("header says more", dict(appended=zlib_blocks(np.zeros(64, np.float32).tobytes(), 64, claimed_last=0)[:0]
                              + struct.pack("<4I", 1, 2**32 - 1, 0, 10) + b"x" * 10), "the extent needs 256"),
    ("absurd extent", dict(extent="0 99999 0 99999 0 99999"), "GiB"),
    ("negative extent", dict(extent="0 -5 0 3 0 3"), "positive"),
    ("piece differs", dict(piece_extent="0 1 0 3 0 3", appended=good_payload()), "differs from WholeExtent"),
    ("unknown type", dict(dtype="Float128", appended=good_payload()), "Float128"),
    ("too few values", dict(extent="0 4 0 3 0 3", appended=good_payload()), "extent needs 320"),
    ("bad offset", dict(array_attrs='format="appended" offset="999999"', appended=good_payload()), "offset"),
    ("not numbers", dict(extent="0 a 0 3 0 3"), "not 6 integers"),
])
def test_vti_damaged(tmp_path, case, kwargs, message):
    p = vti(tmp_path / "bad.vti", **kwargs)
    with pytest.raises(FileFormatError, match=message) as e:
        load_vti(p)
    assert str(p) in str(e.value)
    assert isinstance(e.value, ValueError)


def test_vti_zlib_bomb_is_capped(tmp_path):
    """A block that inflates to 64 MiB where the header promised 256 bytes
    is refused after inflating at most what was promised."""
    bomb = zlib.compress(bytes(64 << 20), 9)
    payload = struct.pack("<4I", 1, 256, 0, len(bomb)) + bomb
    p = vti(tmp_path / "bomb.vti", appended=payload)
    tracemalloc.start()
    try:
        with pytest.raises(FileFormatError, match="inflates to more"):
            load_vti(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * len(p.read_bytes()) + (1 << 20)  # the file, a copy or two; not 64 MiB


def test_vti_not_xml_and_not_files(tmp_path):
    (tmp_path / "x.vti").write_bytes(b"\x00\x01 garbage")
    with pytest.raises(FileFormatError, match="x.vti.*XML"):
        load_vti(tmp_path / "x.vti")
    with pytest.raises(IsADirectoryError):
        load_vti(tmp_path)
    with pytest.raises(FileNotFoundError):
        pyvr.load(tmp_path / "missing.vti")
    with pytest.raises(IsADirectoryError, match="folder"):
        pyvr.load(tmp_path, format="vti")


LEGACY = ("# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS {dims}\n"
          "SPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA {n}\nSCALARS s {vtype} 1\nLOOKUP_TABLE default\n")


@pytest.mark.parametrize("case,dims,n,vtype,data,message", [
    ("truncated", "4 4 4", 64, "float", b"\0" * 100, "cut short: 100 of 256"),
    ("absurd", "100000 100000 100000", 10**15, "float", b"", "GiB"),
    ("count mismatch", "4 4 4", 60, "float", b"\0" * 256, "disagrees with DIMENSIONS"),
    ("unknown type", "4 4 4", 64, "quaternion", b"", "quaternion"),
    ("zero size", "4 0 4", 0, "float", b"", "positive"),
])
def test_legacy_vtk_damaged(tmp_path, case, dims, n, vtype, data, message):
    p = tmp_path / "bad.vtk"
    p.write_bytes(LEGACY.format(dims=dims, n=n, vtype=vtype).encode() + data)
    with pytest.raises(FileFormatError, match=message) as e:
        load_legacy_vtk(p)
    assert str(p) in str(e.value)


def test_legacy_vtk_other_datasets_and_junk(tmp_path):
    p = tmp_path / "grid.vtk"
    p.write_text("# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 0 float\n")
    with pytest.raises(FileFormatError, match="UNSTRUCTURED_GRID is not supported"):
        load_legacy_vtk(p)
    p.write_text("hello")
    with pytest.raises(FileFormatError, match="not a legacy VTK file"):
        load_legacy_vtk(p)
    p.write_text(LEGACY.replace("BINARY", "ASCII").format(dims="2 1 1", n=2, vtype="float") + "1.0 oops\n")
    with pytest.raises(FileFormatError, match="'oops' is not a number"):
        load_legacy_vtk(p)


def test_raw_damaged(tmp_path):
    save_raw(tmp_path / "v.raw", np.zeros((4, 3, 2), np.uint16))
    assert load_raw(tmp_path / "v.raw").data.shape == (4, 3, 2)
    with open(tmp_path / "v.raw", "ab") as f:
        f.write(b"xx")
    with pytest.raises(FileFormatError, match="holds 50 bytes.*exactly 48"):
        load_raw(tmp_path / "v.raw")
    info = tmp_path / "v.raw.info"
    for text, message in [
        ("dimensions: 100000 100000 100000\ntype: float32\n", "GiB"),
        ("dimensions: 4 3 2\ntype: complex64\n", "unknown type 'complex64'"),
        ("dimensions: 4 3\ntype: uint8\n", "is not 3 numbers"),
        ("dimensions: 4 3 2\n", "no 'type' line"),
        ("dimensions: 4 3 2\ntype: uint8\nbyte_order: middle\n", "byte_order"),
        ("dimensions: 4 3 2\ntype: uint8\nspacing: 1 0 1\n", "spacing must be three positive"),
        ("dimensions: 4 3 2\ntype: uint8\ncolour: blue\n", "unknown key 'colour'"),
    ]:
        info.write_text(text)
        with pytest.raises(FileFormatError, match=message) as e:
            load_raw(tmp_path / "v.raw")
        assert "v.raw" in str(e.value)
    info.unlink()
    with pytest.raises(FileNotFoundError):
        load_raw(tmp_path / "v.raw")


def test_nifti_that_lies(tmp_path):
    """NIfTI headers that disagree with their file: a clear FileFormatError
    naming the file, before the data is read (nibabel would read the header
    as voxels, allocate what the header claims, or raise its own errors)."""
    import struct

    nib = pytest.importorskip("nibabel")
    from pyvr.dataloaders import load_nifti

    data = np.random.RandomState(0).rand(8, 9, 10).astype(np.float32)
    good = tmp_path / "good.nii"
    nib.save(nib.Nifti1Image(data, np.diag([1.0, 2.0, 3.0, 1.0])), good)
    raw = good.read_bytes()
    assert load_nifti(good).data.shape == (8, 9, 10)

    def variant(name, blob):
        (tmp_path / name).write_bytes(blob)
        return tmp_path / name

    at_zero = bytearray(raw)
    struct.pack_into("<f", at_zero, 108, 0.0)  # vox_offset
    singular = bytearray(raw)
    struct.pack_into("<hh", singular, 252, 0, 1)  # qform_code 0, sform_code 1 ...
    struct.pack_into("<12f", singular, 280, *([0.0] * 12))  # ... with an all-zero sform
    gz = tmp_path / "whole.nii.gz"
    nib.save(nib.Nifti1Image(data, np.eye(4)), gz)
    cases = [
        (variant("short.nii", raw[:2000]), r"the header declares 3232 bytes \(from offset 352\), the file holds 2000"),
        (variant("at_zero.nii", bytes(at_zero)), "vox_offset 0 lies inside the 348-byte header"),
        (variant("singular.nii", bytes(singular)), "the affine .* must be finite and invertible"),
        (variant("half.nii.gz", gz.read_bytes()[:300]), "cannot read the data|not a readable NIfTI file"),
    ]
    for path, message in cases:
        with pytest.raises(FileFormatError, match=message) as e:
            load_nifti(path)
        assert str(path) in str(e.value)
