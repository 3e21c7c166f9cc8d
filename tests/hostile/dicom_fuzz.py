"""The DICOM series fuzzer's pieces, shared by the short test
(test_dicom_fuzz.py) and the long run (benches/fuzz_dicom.py): a valid
four-slice CT series, mutations of the fields pyvr assembles a volume from (positions, orientations, pixel spacing, sizes,
rescale, pixel data, slices missing or repeated), and the one check every
outcome must pass."""

import random
import shutil
from pathlib import Path

import numpy as np

from pyvr.dataloaders import FileFormatError, load_dicom_series

SHAPE = (5, 6, 4)  # columns (x), rows (y), slices (z)

_EXTREMES = [0, -1, 1e-30, 1e30, float("nan"), float("inf"), 65535, 2**31 - 1]


def write_series(folder) -> None:
    """The seed: a four-slice CT series of SHAPE, in slice order, by the
    loader tests' writer."""
    from test_loaders import write_dicom_series

    write_dicom_series(Path(folder), np.arange(np.prod(SHAPE), dtype=np.uint16).reshape(SHAPE), shuffle=False)


def mutate(folder, rnd: random.Random) -> None:
    """One to three mutations of the series in ``folder``."""
    import pydicom

    folder = Path(folder)
    for _ in range(rnd.randint(1, 3)):
        files = sorted(folder.glob("*.dcm"))
        if not files:
            return
        name = rnd.choice(files)
        kind = rnd.randrange(8)
        if kind == 0:
            name.unlink()  # a slice missing
            continue
        if kind == 1:
            shutil.copy(name, folder / f"copy{rnd.randrange(1000)}.dcm")  # a slice twice
            continue
        try:
            ds = pydicom.dcmread(str(name))
        except Exception:
            continue  # an earlier mutation left it unreadable: the reader's business
        if kind == 2:
            pos = list(ds.ImagePositionPatient)
            pos[rnd.randrange(3)] = rnd.choice(_EXTREMES + [pos[2] + rnd.uniform(-3, 3)])
            ds.ImagePositionPatient = pos
        elif kind == 3:
            o = list(ds.ImageOrientationPatient)
            o[rnd.randrange(6)] = rnd.choice(_EXTREMES + [0.5])
            ds.ImageOrientationPatient = o
        elif kind == 4:
            ds.PixelSpacing = [rnd.choice(_EXTREMES + [0.5]), rnd.choice(_EXTREMES + [0.5])]
        elif kind == 5:
            setattr(ds, rnd.choice(["Rows", "Columns"]), rnd.choice([0, 1, 7, 65535]))
        elif kind == 6:
            setattr(ds, rnd.choice(["RescaleSlope", "RescaleIntercept"]), rnd.choice(_EXTREMES))
        elif ds.get("PixelData") is not None:
            ds.PixelData = ds.PixelData[: rnd.randrange(len(ds.PixelData) + 1)]
        try:
            ds.save_as(str(name))
        except (ValueError, OverflowError, TypeError):
            pass  # pydicom refuses to write it: the series stays as it was


def check_one(folder) -> str:
    """Reads the series: a result must be 3-D, hold the slices given, with
    finite positive spacing; a failure must be FileFormatError naming the
    folder or a slice, or OSError. Returns "ok" or "refused"."""
    folder = Path(folder)
    try:
        image = load_dicom_series(folder)
    except FileFormatError as e:
        assert folder.name in str(e) or ".dcm" in str(e), f"error names neither folder nor slice: {e}"
        return "refused"
    except OSError:
        return "refused"
    assert image.data.ndim == 3 and all(d >= 1 for d in image.data.shape), image.data.shape
    assert image.data.shape[2] <= len(list(folder.glob("*.dcm"))), image.data.shape
    spacing = np.asarray(image.spacing, np.float64)
    assert np.all(np.isfinite(spacing)) and np.all(spacing > 0), spacing
    return "ok"
