"""DICOM series (a folder of slices, e.g. one CT or MR scan) through
pydicom (``pip install 'pyvr-rs[dicom]'``)."""

from pathlib import Path
from typing import Optional

import numpy as np

from .._extras import require
from .image import FileFormatError, GridImage, check_shape, check_spacing


def load_dicom_series(path, *, series_uid: Optional[str] = None) -> GridImage:
    """Reads the slices of one series in folder ``path`` (or the series of
    file ``path``), sorted by their position along the slice normal.

    Axis 0 runs along the rows' direction (ImageOrientationPatient's first
    vector, +x for axial slices), axis 1 along the columns' (second vector),
    axis 2 along the normal (their cross product), in patient millimetres.
    Spacing: PixelSpacing (column spacing for x, row spacing for y) and the
    distance between slice positions, which must be one grid: slices
    parallel (the same ImageOrientationPatient), one per position, evenly
    spaced (within 1% of the gap); anything else raises FileFormatError
    naming the slices, rather than loading a distorted volume.
    RescaleSlope/RescaleIntercept are applied (CT values in Hounsfield
    units); integer results stay integers. A folder with several series
    needs ``series_uid``.
    """
    pydicom = require("pydicom", "dicom", "Reading DICOM")
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"DICOM series not found: {p}")
    files = sorted(f for f in p.iterdir() if f.is_file()) if p.is_dir() else [p]
    slices = []
    for f in files:
        try:
            ds = pydicom.dcmread(str(f), stop_before_pixels=True)
        except Exception:
            continue  # not DICOM (DICOMDIR files, notes, thumbnails)
        if "PixelData" not in ds and "ImagePositionPatient" not in ds:
            continue
        slices.append((f, ds))
    if not slices:
        raise FileFormatError(f"{p}: no DICOM slices found")
    uids = sorted({str(getattr(ds, "SeriesInstanceUID", "")) for _, ds in slices})
    if series_uid is None:
        if len(uids) > 1:
            raise ValueError(f"{p} holds {len(uids)} series {uids}: pass series_uid= to choose one")
        series_uid = uids[0]
    slices = [(f, ds) for f, ds in slices if str(getattr(ds, "SeriesInstanceUID", "")) == series_uid]
    if not slices:
        raise ValueError(f"{p} has no series {series_uid!r}; it holds {uids}")
    first = slices[0][1]
    orient = _orientation(slices[0][0], first)
    for f, ds in slices[1:]:
        if np.abs(_orientation(f, ds) - orient).max() > ORIENTATION_TOLERANCE:
            raise FileFormatError(
                f"{f}: its ImageOrientationPatient {list(_orientation(f, ds).ravel())} differs from "
                f"{slices[0][0].name}'s {list(orient.ravel())}: the slices are not parallel, so they do not "
                "form one grid (a localizer or a reformat mixed into the series?)"
            )
    normal = np.cross(orient[0], orient[1])

    def position(ds):
        try:
            return np.array(ds.ImagePositionPatient, np.float64)
        except AttributeError:
            return np.array([0.0, 0.0, float(getattr(ds, "InstanceNumber", 0))])

    for f, ds in slices:
        if not np.all(np.isfinite(position(ds))):
            raise FileFormatError(f"{f}: its ImagePositionPatient {list(position(ds))} is not finite")
    slices.sort(key=lambda s: float(position(s[1]) @ normal))
    rows, cols = int(first.Rows), int(first.Columns)
    for f, ds in slices:
        if (int(ds.Rows), int(ds.Columns)) != (rows, cols):
            raise FileFormatError(f"{f}: slice of {ds.Rows}x{ds.Columns} in a series of {rows}x{cols}")
    check_shape(p, (cols, rows, len(slices)), np.float32)
    z = np.array([position(ds) @ normal for _, ds in slices])
    if not np.all(np.isfinite(z)):
        raise FileFormatError(f"{p}: a slice's ImagePositionPatient is not finite")
    dz = _slice_gap(p, [f for f, _ in slices], z) if len(z) > 1 else float(getattr(first, "SliceThickness", 1.0) or 1.0)
    try:
        sy, sx = (float(v) for v in first.PixelSpacing)
    except AttributeError:
        sx = sy = 1.0
    planes = []
    slope_any, icpt_any = False, False
    for f, _ in slices:
        ds = pydicom.dcmread(str(f))
        try:
            px = ds.pixel_array
        except Exception as e:
            raise FileFormatError(f"{f}: cannot decode its pixels ({type(e).__name__}: {e})") from None
        slope = float(getattr(ds, "RescaleSlope", 1) or 1)
        icpt = float(getattr(ds, "RescaleIntercept", 0) or 0)
        if not (np.isfinite(slope) and np.isfinite(icpt)):
            raise FileFormatError(f"{f}: RescaleSlope {slope} and RescaleIntercept {icpt} must be finite numbers")
        slope_any |= slope != 1
        icpt_any |= icpt != 0
        planes.append((px, slope, icpt))
    integral = not slope_any and all(float(i).is_integer() for _, _, i in planes)
    out_dtype = np.float32
    if integral:
        lo = min(int(px.min()) + int(i) for px, _, i in planes)
        hi = max(int(px.max()) + int(i) for px, _, i in planes)
        fits = [t for t in (np.int16, np.uint16, np.int32, np.int64) if np.iinfo(t).min <= lo and hi <= np.iinfo(t).max]
        # (Past int64, as floats: an intercept of 1e30 is integral too.)
        integral = bool(fits)
        out_dtype = fits[0] if fits else np.float32
    if not integral:
        top = max(max(abs(float(px.min())), abs(float(px.max()))) * abs(s) + abs(i) for px, s, i in planes)
        if not top <= float(np.finfo(np.float32).max):
            raise FileFormatError(f"{p}: its rescaled values reach {top:.3g}, beyond float32's range")
    vol = np.empty((cols, rows, len(planes)), out_dtype)
    for k, (px, slope, icpt) in enumerate(planes):
        # pixel_array is (rows, columns): row index runs along y, column along x.
        if integral:
            vol[:, :, k] = (px.astype(np.int64) + int(icpt)).T
        else:
            vol[:, :, k] = (px.astype(np.float64) * slope + icpt).T
    origin = position(slices[0][1])
    modality = str(getattr(first, "Modality", ""))
    return GridImage(
        vol, check_spacing(p, (sx, sy, dz)), origin, p.name, "dicom", units="mm",
        value_unit="HU" if modality == "CT" else None,
        extra={"orientation": orient.copy(), "modality": modality, "series_uid": series_uid},
    )


# Direction cosines are written with a few decimals; two slices of one
# acquisition agree to far better than this.
ORIENTATION_TOLERANCE = 1e-4
# Slice positions are written to a hundredth of a millimetre or finer: gaps
# within 1% of the series' gap (or 0.01 mm) are one grid.
GAP_TOLERANCE = 0.01


def _orientation(f, ds) -> np.ndarray:
    """The slice's two direction cosines (rows, columns), checked."""
    try:
        o = np.array(ds.ImageOrientationPatient, np.float64).reshape(2, 3)
    except AttributeError:
        return np.array([[1, 0, 0], [0, 1, 0]], np.float64)
    except (TypeError, ValueError):
        raise FileFormatError(f"{f}: ImageOrientationPatient must be six numbers") from None
    n = np.cross(o[0], o[1]) if np.all(np.isfinite(o)) else np.zeros(3)  # NaN arithmetic warns
    if not (np.all(np.isfinite(o)) and np.linalg.norm(n) > 0.5):
        raise FileFormatError(f"{f}: ImageOrientationPatient {list(o.ravel())} is not two unit directions at right angles")
    return o


def _slice_gap(p, files, z) -> float:
    """The one distance between neighbouring slices (sorted positions
    ``z``), or FileFormatError naming the slices that break the grid."""
    gaps = np.diff(z)
    dz = float(np.median(gaps))
    tolerance = max(GAP_TOLERANCE * abs(dz), 0.01)
    k = int(np.argmin(gaps))
    if not gaps[k] > tolerance:
        raise FileFormatError(
            f"{p}: {files[k].name} and {files[k + 1].name} lie at the same position ({z[k]:.4g} mm along the "
            "slice normal): a series holds one slice per position (two acquisitions mixed? pass series_uid=, "
            "or remove the repeated slices)"
        )
    k = int(np.argmax(np.abs(gaps - dz)))
    if abs(gaps[k] - dz) > tolerance:
        raise FileFormatError(
            f"{p}: the gap between {files[k].name} and {files[k + 1].name} is {gaps[k]:.4g} mm where the "
            f"series' is {dz:.4g} mm: slices missing or unevenly spaced do not form one grid (resample the "
            "series to even spacing first)"
        )
    return dz
