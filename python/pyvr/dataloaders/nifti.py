"""NIfTI-1/2 (``.nii``, ``.nii.gz``) through nibabel (``pip install 'pyvr-rs[nifti]'``)."""

from pathlib import Path
from typing import Optional

import numpy as np

from .._extras import require
from .._numbers import check_count
from .image import FileFormatError, GridImage, check_shape, check_spacing


def _check_layout(path, img) -> None:
    """The data where the header says, checked before it is read: in a
    single file it starts after the header, and an uncompressed file holds
    all of it (a header that lies about its size is an error, not an
    allocation)."""
    header = img.header
    offset = int(getattr(img.dataobj, "offset", 0))
    single = bytes(header["magic"]).rstrip(b"\x00") in (b"n+1", b"n+2")
    if single and offset < int(header["sizeof_hdr"]):
        raise FileFormatError(f"{path}: vox_offset {offset} lies inside the {int(header['sizeof_hdr'])}-byte header")
    if single and str(path).lower().endswith(".nii"):  # uncompressed: its length says how much data it holds
        need = offset + int(np.prod(img.shape, dtype=object)) * header.get_data_dtype().itemsize
        size = Path(path).stat().st_size
        if size < need:
            raise FileFormatError(f"{path}: the header declares {need} bytes (from offset {offset}), "
                                  f"the file holds {size}")


#: Header extensions larger than this are refused before nibabel reads them
#: (it reads them whole, into memory): real ones (DICOM fields, comments)
#: are kilobytes to a few megabytes.
MAX_EXTENSION_BYTES = 64 << 20


def _extension_bytes(path) -> int:
    """Bytes of header extensions the file declares (its vox_offset past
    the header), read from the first bytes only (decompressing no more)."""
    import gzip
    import struct

    opener = gzip.open if str(path).lower().endswith(".gz") else open
    try:
        with opener(path, "rb") as f:
            head = f.read(540)
    except Exception:  # OSError, EOFError, zlib.error: nibabel reports what is wrong with such a file
        return 0
    for order in ("<", ">"):
        if len(head) >= 112 and struct.unpack(order + "i", head[:4])[0] == 348:
            offset = struct.unpack(order + "f", head[108:112])[0]
            # NaN or inf: nibabel reports the header as it finds it.
            return max(0, int(offset) - 352) if np.isfinite(offset) else 0
        if len(head) >= 176 and struct.unpack(order + "i", head[:4])[0] == 540:
            return max(0, struct.unpack(order + "q", head[168:176])[0] - 544)
    return 0


def load_nifti(path, *, index: Optional[int] = None, max_extension_bytes: int = MAX_EXTENSION_BYTES) -> GridImage:
    """Reads a NIfTI image reoriented to RAS+ (nibabel's closest canonical
    orientation): axis 0 increases towards the patient's right, axis 1
    anterior, axis 2 superior, as scanners' world coordinates do. Spacing is
    the voxel size, origin the first voxel's centre from the affine (after
    reorientation), units the header's spatial unit. Scaling (scl_slope,
    scl_inter) is applied; unscaled integer data keeps its type. A 4-D image
    needs ``index`` (which volume of the series). Header extensions over
    ``max_extension_bytes`` (64 MiB) are refused before they are read."""
    nib = require("nibabel", "nifti", "Reading NIfTI")
    path = str(path)
    limit = check_count("max_extension_bytes", max_extension_bytes, low=0, high=1 << 62)
    extension = _extension_bytes(path)
    if extension > limit:
        raise FileFormatError(f"{path}: the header declares {extension} bytes of extensions (vox_offset), over "
                              f"max_extension_bytes={limit}; pass a larger max_extension_bytes to read them")
    try:
        img = nib.load(path)
    except FileNotFoundError:
        raise
    except Exception as e:  # nibabel raises several types for damaged headers
        raise FileFormatError(f"{path}: not a readable NIfTI file ({type(e).__name__}: {e})") from None
    _check_layout(path, img)
    shape = img.shape
    if len(shape) == 4:
        if index is None:
            if shape[3] != 1:
                raise FileFormatError(f"{path}: a 4-D image of {shape[3]} volumes; pass index= to choose one")
            index = 0
        index = check_count("index", index, low=0, high=shape[3] - 1)  # True is not an index
        img = img.slicer[..., index]
    elif len(shape) != 3:
        raise FileFormatError(f"{path}: a {len(shape)}-D image; a volume needs 3 dimensions")
    affine = np.asarray(img.affine, np.float64)
    if not (np.all(np.isfinite(affine)) and abs(np.linalg.det(affine[:3, :3])) > 0):
        raise FileFormatError(f"{path}: the affine (voxel to world) must be finite and invertible, "
                              f"got {affine[:3].tolist()}")
    check_shape(path, img.shape, img.get_data_dtype())
    try:
        img = nib.as_closest_canonical(img)
        data = np.asanyarray(img.dataobj)
    except (OSError, MemoryError):
        raise
    except Exception as e:  # a truncated .gz (EOFError), an orientation nibabel cannot read, ...
        raise FileFormatError(f"{path}: cannot read the data ({type(e).__name__}: {e})") from None
    affine = img.affine
    spacing = check_spacing(path, np.sqrt((affine[:3, :3] ** 2).sum(axis=0)))
    units = img.header.get_xyzt_units()[0]
    return GridImage(data, spacing, affine[:3, 3].astype(np.float64),
                     Path(path).name.split(".")[0], "nifti", units=None if units == "unknown" else units,
                     extra={"affine": affine.copy()})
