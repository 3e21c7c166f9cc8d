"""NIfTI-1/2 (``.nii``, ``.nii.gz``) through nibabel (``pip install 'pyvr[nifti]'``)."""

from pathlib import Path
from typing import Optional

import numpy as np

from .._extras import require
from .._numbers import check_count
from .image import FileFormatError, GridImage, check_shape, check_spacing


def load_nifti(path, *, index: Optional[int] = None) -> GridImage:
    """Reads a NIfTI image reoriented to RAS+ (nibabel's closest canonical
    orientation): axis 0 increases towards the patient's right, axis 1
    anterior, axis 2 superior, as scanners' world coordinates do. Spacing is
    the voxel size, origin the first voxel's centre from the affine (after
    reorientation), units the header's spatial unit. Scaling (scl_slope,
    scl_inter) is applied; unscaled integer data keeps its type. A 4-D image
    needs ``index`` (which volume of the series)."""
    nib = require("nibabel", "nifti", "Reading NIfTI")
    path = str(path)
    try:
        img = nib.load(path)
    except FileNotFoundError:
        raise
    except Exception as e:  # nibabel raises several types for damaged headers
        raise FileFormatError(f"{path}: not a readable NIfTI file ({type(e).__name__}: {e})") from None
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
    img = nib.as_closest_canonical(img)
    check_shape(path, img.shape, img.get_data_dtype())
    data = np.asanyarray(img.dataobj)
    affine = img.affine
    spacing = check_spacing(path, np.sqrt((affine[:3, :3] ** 2).sum(axis=0)))
    units = img.header.get_xyzt_units()[0]
    return GridImage(data, spacing, affine[:3, 3].astype(np.float64),
                     Path(path).name.split(".")[0], "nifti", units=None if units == "unknown" else units,
                     extra={"affine": affine.copy()})
