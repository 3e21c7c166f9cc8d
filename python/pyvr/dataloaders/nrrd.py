"""NRRD (``.nrrd``, and ``.nhdr`` with its detached data, raw or gzip)
through pynrrd (``pip install 'pyvr[nrrd]'``)."""

from pathlib import Path

import numpy as np

from .._extras import require
from .image import FileFormatError, GridImage, check_shape, check_spacing


def load_nrrd(path) -> GridImage:
    """Reads a 3-D NRRD with axis 0 the file's fastest axis (x). Spacing
    comes from ``space directions`` (column lengths) or ``spacings``, origin
    from ``space origin``, units from ``space units``."""
    nrrd = require("nrrd", "nrrd", "Reading NRRD")
    path = str(path)
    try:
        header = nrrd.read_header(path)
    except FileNotFoundError:
        raise
    except Exception as e:
        raise FileFormatError(f"{path}: not a readable NRRD header ({type(e).__name__}: {e})") from None
    sizes = header.get("sizes")
    if sizes is None or len(sizes) != 3:
        raise FileFormatError(f"{path}: a volume needs 3 axes, the header says sizes={sizes}")
    try:
        dtype = np.dtype(nrrd.reader._determine_datatype(header))
    except Exception:
        dtype = np.dtype(np.float64)
    check_shape(path, sizes, dtype)
    try:
        data, header = nrrd.read(path, index_order="F")
    except Exception as e:
        raise FileFormatError(f"{path}: cannot read the data ({type(e).__name__}: {e})") from None
    spacing = np.ones(3)
    directions = header.get("space directions")
    if directions is not None:
        d = np.asarray(directions, dtype=np.float64)
        if d.shape[0] == 3 and np.all(np.isfinite(d)):
            spacing = np.sqrt((d ** 2).sum(axis=1))
    elif header.get("spacings") is not None:
        spacing = np.asarray(header["spacings"], np.float64)
    origin = np.asarray(header.get("space origin", np.zeros(3)), np.float64).reshape(-1)[:3]
    units = header.get("space units")
    unit = str(units[0]) if units is not None and len(units) else None
    return GridImage(data, check_spacing(path, spacing), origin,
                     Path(path).name.split(".")[0], "nrrd", units=unit)
