"""Reading volumes from files: pyvr 0.4.1's ``load_vtk_volume`` and
``pyvr.load`` for the formats scans and simulations come in.

Each reader returns a :class:`GridImage` (voxels with axis 0 along x, and
the physical spacing, origin and units); :func:`load` turns one into a
:class:`~pyvr.volume.Volume`. Readers of formats with a library of their
own import it when called; a missing one raises ImportError naming the
extra to install (``pip install 'pyvr-rs[nifti]'`` etc.).
"""

from .arrays import load_npy, load_zarr
from .dicom import load_dicom_series
from .image import FileFormatError, GridImage, to_volume
from .legacy_vtk import load_legacy_vtk
from .load import FORMATS, detect_format, load, read
from .nifti import load_nifti
from .nrrd import load_nrrd
from .raw import load_raw, save_raw
from .tiff import load_tiff
from .vti import load_vti
from .vtk_loader import load_vtk_volume

__all__ = [
    "load_vtk_volume", "load", "read", "detect_format", "FORMATS", "GridImage", "FileFormatError", "to_volume",
    "load_vti", "load_legacy_vtk", "load_raw", "save_raw", "load_npy", "load_zarr", "load_nifti", "load_nrrd",
    "load_dicom_series", "load_tiff",
]
