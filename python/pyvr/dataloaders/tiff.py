"""TIFF stacks (microscopy) through tifffile (``pip install 'pyvr-rs[tiff]'``)."""

from pathlib import Path

import numpy as np

from .._extras import require
from .image import FileFormatError, GridImage, check_shape, check_spacing


def load_tiff(path, *, spacing=None) -> GridImage:
    """Reads a multi-page TIFF as a volume: pages are z, rows y, columns x,
    so ``data[x, y, z]`` is column x of row y of page z. Spacing is
    ``spacing=(sx, sy, sz)`` if given, else x and y from the resolution tags
    (in the resolution unit) and z from ImageJ's ``spacing`` metadata,
    1 where the file does not say."""
    tifffile = require("tifffile", "tiff", "Reading TIFF")
    path = str(path)
    try:
        with tifffile.TiffFile(path) as tif:
            series = tif.series[0]
            shape = tuple(series.shape)
            if len(shape) != 3:
                raise FileFormatError(f"{path}: a stack of shape {shape}; a volume needs pages x rows x columns")
            check_shape(path, shape, series.dtype)
            stack = series.asarray()
            page = tif.pages[0]
            sx = sy = sz = 1.0
            unit = None
            tags = page.tags
            if "XResolution" in tags and "YResolution" in tags:
                xr, yr = tags["XResolution"].value, tags["YResolution"].value
                if xr[0] and yr[0]:
                    sx, sy = xr[1] / xr[0], yr[1] / yr[0]
            meta = tif.imagej_metadata or {}
            if "spacing" in meta:
                sz = float(meta["spacing"])
            if "unit" in meta:
                unit = str(meta["unit"])
    except FileFormatError:
        raise
    except FileNotFoundError:
        raise
    except Exception as e:
        raise FileFormatError(f"{path}: not a readable TIFF stack ({type(e).__name__}: {e})") from None
    sp = check_spacing(path, spacing if spacing is not None else (sx, sy, sz))
    data = np.asarray(stack).transpose(2, 1, 0)  # a view; the upload copies anyway
    return GridImage(data, sp, np.zeros(3), Path(path).name.split(".")[0], "tiff", units=unit)
