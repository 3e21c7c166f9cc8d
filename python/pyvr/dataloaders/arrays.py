"""Arrays saved as arrays: numpy's ``.npy``/``.npz`` and zarr (``pip
install 'pyvr-rs[zarr]'``). Their axes are taken in pyvr's order (axis 0 along
x), as an array handed to ``Volume`` is."""

from pathlib import Path
from typing import Optional

import numpy as np

from .._extras import require
from .image import FileFormatError, GridImage, check_shape, check_spacing, choose_key


def _image(path, data, spacing, origin, fmt, name, units=None) -> GridImage:
    if data.ndim != 3:
        raise FileFormatError(f"{path}: array of shape {data.shape}; a volume needs 3 dimensions")
    if data.dtype.kind not in "biuf":
        raise FileFormatError(f"{path}: array of dtype {data.dtype}; a volume needs real numbers")
    sp = check_spacing(path, spacing if spacing is not None else (1.0, 1.0, 1.0))
    org = np.zeros(3) if origin is None else np.asarray(origin, np.float64).reshape(3)
    return GridImage(data, sp, org, name, fmt, units=units)


def load_npy(path, *, key: Optional[str] = None, spacing=None, origin=None, mmap: bool = False) -> GridImage:
    """``.npy`` (memory-mapped with ``mmap=True``) or one array of an
    ``.npz`` (``key``, or its only array). Pickled objects are refused."""
    path = str(path)
    try:
        obj = np.load(path, mmap_mode="r" if mmap else None, allow_pickle=False)
    except FileNotFoundError:
        raise
    except ValueError as e:
        raise FileFormatError(f"{path}: not a readable .npy/.npz file ({e})") from None
    if isinstance(obj, np.lib.npyio.NpzFile):
        with obj:
            data = obj[choose_key(path, obj.keys(), key)]
        fmt = "npz"
    else:
        data, fmt = obj, "npy"
    return _image(path, data, spacing, origin, fmt, Path(path).name.split(".")[0])


def load_zarr(path, *, key: Optional[str] = None, spacing=None, origin=None) -> GridImage:
    """A zarr array (or the array ``key`` of a group). Spacing and origin
    come from the arguments, else the array's ``spacing``/``origin``
    attributes, else 1 and 0. Read into memory whole."""
    zarr = require("zarr", "zarr", "Reading zarr")
    path = str(path)
    try:
        node = zarr.open(path, mode="r")
    except FileNotFoundError:
        raise
    except Exception as e:
        raise FileFormatError(f"{path}: not a readable zarr store ({type(e).__name__}: {e})") from None
    if not hasattr(node, "shape"):
        names = sorted(node.array_keys()) if hasattr(node, "array_keys") else []
        node = node[choose_key(path, names, key, "a zarr group of arrays")]
    if len(node.shape) != 3:
        raise FileFormatError(f"{path}: array of shape {node.shape}; a volume needs 3 dimensions")
    check_shape(path, node.shape, node.dtype)
    attrs = dict(node.attrs)
    data = np.asarray(node[...])
    return _image(path, data, spacing if spacing is not None else attrs.get("spacing"),
                  origin if origin is not None else attrs.get("origin"), "zarr",
                  Path(path).name.split(".")[0], units=attrs.get("units"))
