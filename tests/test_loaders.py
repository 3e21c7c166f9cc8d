"""Every format pyvr.load reads, written here with the format's own library
(or by hand where the format is ours to write), read back and checked:
values, axis order (axis 0 along x), spacing, origin and the bounds of the
Volume, on an anisotropic, non-cubic grid, with integer and float types."""

import os
import struct
import sys

import numpy as np
import pytest

import pyvr
from conftest import SHARED_DATA
from pyvr.dataloaders import (FileFormatError, load_dicom_series, load_legacy_vtk, load_nifti, load_npy,
                              load_nrrd, load_raw, load_tiff, load_vtk_volume, load_zarr, read, save_raw)

SHAPE = (5, 4, 3)  # x, y, z: non-cubic
SPACING = (0.5, 0.75, 2.0)  # anisotropic
ORIGIN = (1.0, -2.0, 3.0)


def field(dtype=np.int16):
    """Every value names its index: v = x + 10 y + 100 z."""
    x, y, z = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    return (x + 10 * y + 100 * z).astype(dtype)


def file_order(a):
    """C-order bytes with x fastest, as VTK, raw, NRRD and NIfTI store them."""
    return np.ascontiguousarray(a.transpose(2, 1, 0))


def check_image(im, data, spacing=SPACING, origin=ORIGIN):
    assert im.data.shape == SHAPE
    np.testing.assert_array_equal(im.data, data)
    np.testing.assert_allclose(im.spacing, spacing)
    np.testing.assert_allclose(im.origin, origin)


def check_volume(vol, data, spacing=SPACING):
    """pyvr.load's unit box: the physical box's proportions, longest side 2,
    centred; the data untouched; value_range the data range."""
    np.testing.assert_array_equal(vol.data, data)
    extent = np.array(SHAPE) * np.array(spacing)
    np.testing.assert_allclose(vol.max_bounds - vol.min_bounds, 2 * extent / extent.max(), rtol=1e-6)
    np.testing.assert_allclose(vol.max_bounds + vol.min_bounds, 0, atol=1e-6)
    assert vol.value_range == (float(data.min()), float(data.max()))
    np.testing.assert_allclose(vol.metadata["spacing"], spacing)
    assert vol.metadata["world_per_unit"] == pytest.approx(2 / extent.max())


# -- formats pyvr parses itself -------------------------------------------------

def legacy_vtk(path, data, binary, vtype="short"):
    head = (f"# vtk DataFile Version 3.0\ntest volume\n{'BINARY' if binary else 'ASCII'}\n"
            f"DATASET STRUCTURED_POINTS\nDIMENSIONS {SHAPE[0]} {SHAPE[1]} {SHAPE[2]}\n"
            f"SPACING {SPACING[0]} {SPACING[1]} {SPACING[2]}\nORIGIN {ORIGIN[0]} {ORIGIN[1]} {ORIGIN[2]}\n"
            f"POINT_DATA {data.size}\n")
    other = np.full(data.size * 3, 7, ">f4")  # a vector array before the scalars, skipped
    body = b"VECTORS flow float\n" + (other.tobytes() + b"\n" if binary else " ".join("7" for _ in other).encode() + b"\n")
    body += f"SCALARS density {vtype} 1\nLOOKUP_TABLE default\n".encode()
    flat = file_order(data).ravel()
    if binary:
        body += flat.astype(flat.dtype.newbyteorder(">")).tobytes() + b"\n"
    else:
        body += " ".join(str(v) for v in flat).encode() + b"\n"
    path.write_bytes(head.encode() + body)


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("dtype,vtype", [(np.int16, "short"), (np.float32, "float"), (np.uint8, "unsigned_char")])
def test_legacy_vtk(tmp_path, binary, dtype, vtype):
    p = tmp_path / "v.vtk"
    data = field(dtype) if dtype != np.uint8 else (field() % 256).astype(np.uint8)
    legacy_vtk(p, data, binary, vtype)
    im = load_legacy_vtk(p)
    check_image(im, data)
    assert im.data.dtype == dtype and im.extra["array"] == "density"
    check_volume(pyvr.load(p), data)


def test_raw_with_info(tmp_path):
    data = field(np.uint16)
    save_raw(tmp_path / "v.raw", data, spacing=SPACING, origin=ORIGIN, units="mm")
    check_image(load_raw(tmp_path / "v.raw"), data)
    check_image(load_raw(tmp_path / "v.raw.info"), data)  # either name
    vol = pyvr.load(tmp_path / "v.raw")
    check_volume(vol, data)
    assert vol.metadata["units"] == "mm" and vol.data.dtype == np.uint16
    # Big-endian float data with a header offset, written by hand.
    (tmp_path / "b.raw").write_bytes(b"HEADER!!" + file_order(field(np.float32)).astype(">f4").tobytes())
    (tmp_path / "b.raw.info").write_text(
        "# written by a simulation\nDimensions = 5 4 3\nData type: float\nRatio: 0.5, 0.75, 2\n"
        "origin: 1 -2 3\nEndianness: big\noffset: 8\n")
    im = load_raw(tmp_path / "b.raw")
    check_image(im, field(np.float32))
    assert im.data.dtype == np.float32 and im.data.dtype.isnative
    # "key value" lines, no colon, as many tools write them; keys of two words too.
    (tmp_path / "b.raw.info").write_text("dimensions 5 4 3\ndata type float\nspacing 0.5 0.75 2\n"
                                         "origin 1 -2 3\nbyte order big\nheader size 8\n")
    im = load_raw(tmp_path / "b.raw")
    check_image(im, field(np.float32))
    with pytest.raises(FileFormatError, match="line 2: expected 'key: value' or 'key value', got 'colour red'"):
        (tmp_path / "b.raw.info").write_text("dimensions 5 4 3\ncolour red\n")
        load_raw(tmp_path / "b.raw")


def test_vti_geometry(tmp_path):
    import base64

    raw = file_order(field(np.int16)).tobytes()
    enc = base64.b64encode(struct.pack("<I", len(raw)) + raw).decode()
    ext = f"0 {SHAPE[0] - 1} 0 {SHAPE[1] - 1} 0 {SHAPE[2] - 1}"
    (tmp_path / "v.vti").write_text(
        f'<?xml version="1.0"?><VTKFile type="ImageData" byte_order="LittleEndian"><ImageData WholeExtent="{ext}" '
        f'Origin="1 -2 3" Spacing="0.5 0.75 2"><Piece Extent="{ext}"><PointData Scalars="d">'
        f'<DataArray type="Int16" Name="d" format="binary">{enc}</DataArray></PointData></Piece></ImageData></VTKFile>')
    vol = pyvr.load(tmp_path / "v.vti")
    check_volume(vol, field(np.int16))
    phys = pyvr.load(tmp_path / "v.vti", box="physical")
    lo = np.array(ORIGIN) - 0.5 * np.array(SPACING)
    np.testing.assert_allclose(phys.min_bounds, lo, rtol=1e-6)
    np.testing.assert_allclose(phys.max_bounds, lo + np.array(SHAPE) * SPACING, rtol=1e-6)


def test_npy_and_npz(tmp_path):
    data = field(np.int32)
    np.save(tmp_path / "v.npy", data)
    check_image(load_npy(tmp_path / "v.npy", spacing=SPACING, origin=ORIGIN), data)
    check_volume(pyvr.load(tmp_path / "v.npy", spacing=SPACING), data)
    assert isinstance(read(tmp_path / "v.npy", mmap=True).data, np.memmap)
    np.savez_compressed(tmp_path / "v.npz", a=data, b=data.astype(np.float32) / 7)
    check_image(load_npy(tmp_path / "v.npz", key="b", spacing=SPACING, origin=ORIGIN), data.astype(np.float32) / 7)
    with pytest.raises(ValueError, match="pass key="):
        load_npy(tmp_path / "v.npz")


def test_vtk_loader_keeps_pyvrs_contract():
    path = os.path.join(SHARED_DATA, "fuel.vti")
    if not os.path.exists(path):
        return  # the data set lives beside the project, not in it
    vol = load_vtk_volume(path)
    assert vol.name == "fuel.vti(Scalars_)" and vol.has_normals
    assert vol.data.dtype == np.float32 and vol.data.min() == 0 and vol.data.max() == 1
    np.testing.assert_allclose(vol.min_bounds, -1) and np.testing.assert_allclose(vol.max_bounds, 1)
    with pytest.raises(FileNotFoundError, match="VTK file not found"):
        load_vtk_volume("no/such/file.vti")
    with pytest.raises(ValueError, match="Scalar array 'nope' not found"):
        load_vtk_volume(path, scalars_name="nope")


def test_vtk_loader_axis_order_and_bounds(tmp_path):
    """x is axis 0 and the bounds follow it (pyvr mirrored x and z)."""
    p = tmp_path / "v.vtk"
    legacy_vtk(p, field(np.float32), binary=True, vtype="float")
    vol = load_vtk_volume(p, scalars_name="density")
    f = field(np.float32)
    np.testing.assert_allclose(vol.data, (f - f.min()) / (f.max() - f.min()), atol=1e-7)
    extent = np.array(SHAPE) * SPACING
    np.testing.assert_allclose(vol.max_bounds, extent / extent.max(), rtol=1e-6)


# -- formats read through their libraries ---------------------------------------

def test_nifti(tmp_path):
    nib = pytest.importorskip("nibabel")
    data = field(np.int16)
    affine = np.diag([*SPACING, 1.0])
    affine[:3, 3] = ORIGIN
    img = nib.Nifti1Image(data, affine)
    img.header.set_xyzt_units("mm")
    nib.save(img, tmp_path / "v.nii.gz")
    im = load_nifti(tmp_path / "v.nii.gz")
    check_image(im, data)
    assert im.units == "mm" and im.data.dtype == np.int16
    check_volume(pyvr.load(tmp_path / "v.nii.gz"), data)
    # Stored left-to-right (x flipped): read back in RAS+, so x runs the other way.
    flipped = affine.copy()
    flipped[0, 0] = -SPACING[0]
    nib.save(nib.Nifti1Image(data, flipped), tmp_path / "f.nii")
    im = load_nifti(tmp_path / "f.nii")
    np.testing.assert_array_equal(im.data, data[::-1])
    np.testing.assert_allclose(im.origin, [ORIGIN[0] - (SHAPE[0] - 1) * SPACING[0], *ORIGIN[1:]])
    # 4-D series: one volume chosen by index.
    nib.save(nib.Nifti1Image(np.stack([data, data * 2], axis=-1), affine), tmp_path / "t.nii")
    np.testing.assert_array_equal(load_nifti(tmp_path / "t.nii", index=1).data, data * 2)
    with pytest.raises(ValueError, match="index="):
        load_nifti(tmp_path / "t.nii")
    with pytest.raises(TypeError, match="index must be an integer, got bool"):
        load_nifti(tmp_path / "t.nii", index=True)  # not volume 1
    with pytest.raises(ValueError, match="index must be at most 1, got 2"):
        load_nifti(tmp_path / "t.nii", index=2)


@pytest.mark.parametrize("detached", [False, True])
def test_nrrd(tmp_path, detached):
    nrrd = pytest.importorskip("nrrd")
    data = field(np.uint16)
    header = {"space": "left-posterior-superior", "space directions": np.diag(SPACING), "space origin": np.array(ORIGIN)}
    name = "v.nhdr" if detached else "v.nrrd"
    if detached:
        header["encoding"] = "gzip"
    nrrd.write(str(tmp_path / name), data, header, detached_header=detached, index_order="F")
    check_image(load_nrrd(tmp_path / name), data)
    check_volume(pyvr.load(tmp_path / name), data)


def write_dicom_series(folder, data, slope=1.0, intercept=-1024.0, shuffle=True):
    pytest.importorskip("pydicom")
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    folder.mkdir()
    series = generate_uid()
    order = [2, 0, 1] if shuffle else range(data.shape[2])
    for n, k in enumerate(order):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(str(folder / f"s{n}.dcm"), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.Modality = "CT"
        ds.SeriesInstanceUID = series
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.Rows, ds.Columns = data.shape[1], data.shape[0]
        ds.PixelSpacing = [SPACING[1], SPACING[0]]  # row spacing (y), column spacing (x)
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [ORIGIN[0], ORIGIN[1], ORIGIN[2] + k * SPACING[2]]
        ds.SliceThickness = SPACING[2]
        ds.RescaleSlope, ds.RescaleIntercept = slope, intercept
        ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
        ds.PixelRepresentation = 0
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.PixelData = np.ascontiguousarray(data[:, :, k].T).astype(np.uint16).tobytes()  # (rows, columns)
        ds.save_as(str(folder / f"s{n}.dcm"), enforce_file_format=True)
    (folder / "notes.txt").write_text("not a slice")


def test_dicom_series(tmp_path):
    stored = field(np.uint16)
    write_dicom_series(tmp_path / "ct", stored)
    im = load_dicom_series(tmp_path / "ct")
    check_image(im, stored.astype(np.int32) - 1024)  # Hounsfield units
    assert im.value_unit == "HU" and im.data.dtype == np.int16
    vol = pyvr.load(tmp_path / "ct")
    check_volume(vol, stored.astype(np.int32) - 1024)
    write_dicom_series(tmp_path / "ct2", stored, slope=0.5, intercept=-10.25)
    im = load_dicom_series(tmp_path / "ct2")
    check_image(im, stored * 0.5 - 10.25)
    assert im.data.dtype == np.float32


def test_tiff_stack(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    data = field(np.uint16)
    pages = np.ascontiguousarray(data.transpose(2, 1, 0))  # (z, y, x)
    tifffile.imwrite(tmp_path / "v.tif", pages, imagej=True, resolution=(1 / SPACING[0], 1 / SPACING[1]),
                     metadata={"spacing": SPACING[2], "unit": "um", "axes": "ZYX"})
    im = load_tiff(tmp_path / "v.tif")
    check_image(im, data, origin=(0, 0, 0))
    assert im.units == "um"
    check_volume(pyvr.load(tmp_path / "v.tif"), data)
    np.testing.assert_allclose(load_tiff(tmp_path / "v.tif", spacing=(1, 2, 3)).spacing, (1, 2, 3))


def test_zarr(tmp_path):
    zarr = pytest.importorskip("zarr")
    data = field(np.float32)
    z = zarr.create_array(store=str(tmp_path / "v.zarr"), shape=SHAPE, chunks=(2, 2, 2), dtype="float32")
    z[...] = data
    z.attrs["spacing"] = list(SPACING)
    z.attrs["origin"] = list(ORIGIN)
    check_image(load_zarr(tmp_path / "v.zarr"), data)
    check_volume(pyvr.load(tmp_path / "v.zarr"), data)


def test_detection_by_content(tmp_path):
    data = field(np.float32)
    legacy_vtk(tmp_path / "noext", data, binary=True, vtype="float")
    np.save(tmp_path / "arr.npy", data)
    os.rename(tmp_path / "arr.npy", tmp_path / "arr")
    assert pyvr.dataloaders.detect_format(tmp_path / "noext") == "vtk"
    assert pyvr.dataloaders.detect_format(tmp_path / "arr") == "npy"
    (tmp_path / "junk").write_bytes(b"\x01\x02 not a volume")
    with pytest.raises(FileFormatError, match="junk.*format="):
        pyvr.load(tmp_path / "junk")


@pytest.mark.parametrize("module,extra,call", [
    ("nibabel", "nifti", lambda p: load_nifti(p)),
    ("nrrd", "nrrd", lambda p: load_nrrd(p)),
    ("pydicom", "dicom", lambda p: load_dicom_series(p)),
    ("tifffile", "tiff", lambda p: load_tiff(p)),
    ("zarr", "zarr", lambda p: load_zarr(p)),
])
def test_missing_extra_names_it(monkeypatch, tmp_path, module, extra, call):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(ImportError, match=rf"pip install 'pyvr-rs\[{extra}\]'"):
        call(tmp_path)


def test_import_pyvr_needs_numpy_and_scipy_only():
    import subprocess

    code = ("import sys, pyvr, pyvr.dataloaders; heavy = {'nibabel', 'nrrd', 'pydicom', 'tifffile', 'zarr', "
            "'matplotlib', 'PIL'} & set(sys.modules); print(sorted(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
