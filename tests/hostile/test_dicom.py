"""DICOM series that do not form one grid: each raises FileFormatError
naming the slices at fault, where it loaded a distorted volume before
(slices repeated, tilted, unevenly spaced) or an all-NaN one (a rescale
slope of NaN)."""

import numpy as np
import pytest

from test_loaders import ORIGIN, SPACING, write_dicom_series

pydicom = pytest.importorskip("pydicom")

from pyvr.dataloaders import FileFormatError, load_dicom_series  # noqa: E402


def series(tmp_path, slices=4):
    data = np.arange(5 * 6 * slices, dtype=np.uint16).reshape(5, 6, slices)
    folder = tmp_path / "series"
    write_dicom_series(folder, data, shuffle=False)
    return folder


def edit(folder, name, **fields):
    ds = pydicom.dcmread(str(folder / name))
    for k, v in fields.items():
        setattr(ds, k, v)
    ds.save_as(str(folder / name))


def test_an_even_series_loads_with_its_gap(tmp_path):
    img = load_dicom_series(series(tmp_path))
    assert img.data.shape == (5, 6, 4)
    assert img.spacing[2] == pytest.approx(SPACING[2])


def test_two_slices_at_one_position(tmp_path):
    folder = series(tmp_path)
    edit(folder, "s2.dcm", ImagePositionPatient=[ORIGIN[0], ORIGIN[1], ORIGIN[2] + 1 * SPACING[2]])
    with pytest.raises(FileFormatError, match=r"s1\.dcm and s2\.dcm lie at the same position"):
        load_dicom_series(folder)


def test_slices_that_are_not_parallel(tmp_path):
    folder = series(tmp_path)
    edit(folder, "s3.dcm", ImageOrientationPatient=[1, 0, 0, 0, 0.9, 0.43589])
    with pytest.raises(FileFormatError, match=r"s3\.dcm: its ImageOrientationPatient .* not parallel"):
        load_dicom_series(folder)


@pytest.mark.parametrize("moved_by", [0.5, 0.05])
def test_a_gap_off_the_grid(tmp_path, moved_by):
    # Slice 3 of 4 moved along the normal by half a gap, and by 5% of one:
    # the median gap no longer fits every pair.
    folder = series(tmp_path)
    z = ORIGIN[2] + (3 + moved_by) * SPACING[2]
    edit(folder, "s3.dcm", ImagePositionPatient=[ORIGIN[0], ORIGIN[1], z])
    with pytest.raises(FileFormatError, match=r"gap between s2\.dcm and s3\.dcm is .* unevenly spaced"):
        load_dicom_series(folder)


def test_a_gap_within_rounding_loads(tmp_path):
    # Positions written to a hundredth of a millimetre round gaps by less
    # than 1%: still one grid.
    folder = series(tmp_path)
    edit(folder, "s3.dcm", ImagePositionPatient=[ORIGIN[0], ORIGIN[1], ORIGIN[2] + 3 * SPACING[2] + 0.004])
    assert load_dicom_series(folder).data.shape == (5, 6, 4)


def test_a_missing_slice(tmp_path):
    folder = series(tmp_path, slices=5)
    (folder / "s2.dcm").unlink()
    with pytest.raises(FileFormatError, match="unevenly spaced"):
        load_dicom_series(folder)


# pydicom warns that "NaN" is no decimal string, writing and reading it.
@pytest.mark.filterwarnings("ignore:Invalid value for VR DS")
@pytest.mark.parametrize("field", ["RescaleSlope", "RescaleIntercept"])
def test_a_rescale_that_is_not_finite(tmp_path, field):
    folder = series(tmp_path)
    mode = pydicom.config.settings.writing_validation_mode
    pydicom.config.settings.writing_validation_mode = pydicom.config.IGNORE
    try:
        edit(folder, "s1.dcm", **{field: "NaN"})
    finally:
        pydicom.config.settings.writing_validation_mode = mode
    with pytest.raises(FileFormatError, match=r"s1\.dcm: RescaleSlope .* must be finite"):
        load_dicom_series(folder)


def test_an_integral_rescale_past_every_integer_type(tmp_path):
    # An intercept of 1e30 is an integer no integer type holds: float32
    # values (it ended the loader with StopIteration, which ends a map()
    # over many series silently).
    folder = series(tmp_path)
    for n in range(4):
        edit(folder, f"s{n}.dcm", RescaleIntercept="1e30")
    img = load_dicom_series(folder)
    assert img.data.dtype == np.float32
    np.testing.assert_allclose(img.data, 1e30, rtol=1e-6)


def test_a_rescale_past_float32(tmp_path):
    folder = series(tmp_path)
    edit(folder, "s0.dcm", RescaleSlope="1e38")
    with pytest.raises(FileFormatError, match="beyond float32's range"):
        load_dicom_series(folder)



# Found by the fuzzer: a NaN position went through numpy's arithmetic
# (its "invalid value" warnings) and was refused naming no slice.
@pytest.mark.filterwarnings("ignore:Invalid value for VR DS", "error::RuntimeWarning")
@pytest.mark.parametrize(("field", "value", "message"), [
    ("ImagePositionPatient", ["NaN", 0, 0], r"s2\.dcm: its ImagePositionPatient .* is not finite"),
    ("ImageOrientationPatient", [1, 0, 0, 0, "NaN", 0], r"s2\.dcm: ImageOrientationPatient .* not two unit directions"),
])
def test_geometry_that_is_not_finite(tmp_path, field, value, message):
    folder = series(tmp_path)
    mode = pydicom.config.settings.writing_validation_mode
    pydicom.config.settings.writing_validation_mode = pydicom.config.IGNORE
    try:
        edit(folder, "s2.dcm", **{field: value})
    finally:
        pydicom.config.settings.writing_validation_mode = mode
    with pytest.raises(FileFormatError, match=message):
        load_dicom_series(folder)
