"""``pyvr.load``: one call from a file to a Volume, for every format pyvr
reads, choosing the reader by extension or, failing that, by content."""

from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Dict, Optional

import numpy as np

from ..volume import Volume
from .image import FileFormatError, GridImage, to_volume

#: format name -> (reader module, function, extensions)
FORMATS: Dict[str, tuple] = {
    "vti": ("vti", "load_vti", (".vti",)),
    "vtk": ("legacy_vtk", "load_legacy_vtk", (".vtk",)),
    "nifti": ("nifti", "load_nifti", (".nii", ".nii.gz")),
    "nrrd": ("nrrd", "load_nrrd", (".nrrd", ".nhdr")),
    "dicom": ("dicom", "load_dicom_series", (".dcm", ".ima")),
    "tiff": ("tiff", "load_tiff", (".tif", ".tiff")),
    "npy": ("arrays", "load_npy", (".npy", ".npz")),
    "zarr": ("arrays", "load_zarr", (".zarr",)),
    "raw": ("raw", "load_raw", (".raw", ".raw.info")),
}


def _reader(fmt: str) -> Callable[..., GridImage]:
    import importlib

    module, func, _ = FORMATS[fmt]
    return getattr(importlib.import_module(f"{__package__}.{module}"), func)


def detect_format(path) -> str:
    """The format of ``path``: by extension, else by its first bytes, else
    (for a folder) DICOM slices or a zarr store."""
    p = Path(path)
    name = p.name.lower()
    for fmt, (_, _, exts) in FORMATS.items():
        if any(name.endswith(e) for e in exts):
            return fmt
    if p.is_dir():
        if (p / ".zarray").exists() or (p / "zarr.json").exists() or (p / ".zgroup").exists():
            return "zarr"
        return "dicom"
    if (p.parent / (p.name + ".info")).exists():
        return "raw"
    with open(p, "rb") as f:
        head = f.read(352)
    if head.startswith(b"\x93NUMPY") or head.startswith(b"PK\x03\x04"):
        return "npy"
    if head.startswith(b"NRRD"):
        return "nrrd"
    if head.startswith(b"# vtk DataFile"):
        return "vtk"
    if b"<VTKFile" in head:
        return "vti"
    if head[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return "tiff"
    if len(head) >= 348 and head[344:347] in (b"n+1", b"ni1", b"n+2", b"ni2"):
        return "nifti"
    if head[128:132] == b"DICM":
        return "dicom"
    raise FileFormatError(
        f"{p}: cannot tell its format from the name or content; pass format= one of {sorted(FORMATS)}"
    )


_PACKAGE = Path(__file__).resolve().parents[1]


def _raised_in_pyvr(error: BaseException) -> bool:
    """Whether the innermost frame of the error's traceback is pyvr's own."""
    tb = error.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and Path(tb.tb_frame.f_code.co_filename).resolve().is_relative_to(_PACKAGE)


@contextmanager
def _named_errors(path, fmt: str):
    """Errors from the libraries under a reader (zipfile, numcodecs, numpy's
    linear algebra, EOFError, StopIteration, ...) as FileFormatError naming
    the file. pyvr's own errors (a bad argument, a refused file), OSError,
    MemoryError and a missing extra's ImportError pass unchanged."""
    try:
        yield
    except (FileFormatError, OSError, MemoryError, ImportError):
        raise
    except Exception as e:
        ours = isinstance(e, (TypeError, ValueError)) and not isinstance(e, np.linalg.LinAlgError)
        if ours and _raised_in_pyvr(e):
            raise
        raise FileFormatError(f"{path}: not a readable {fmt} file ({type(e).__name__}: {e})") from e


def read(path, *, format: Optional[str] = None, **options) -> GridImage:
    """The file as a GridImage (voxels and physical geometry), without
    making a Volume. ``options`` go to the format's reader."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"No such file or folder: {str(p)!r}")
    fmt = format or detect_format(p)
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {sorted(FORMATS)}, got {fmt!r}")
    if fmt in ("vti", "vtk", "nifti", "nrrd", "tiff", "npy", "raw") and p.is_dir():
        raise IsADirectoryError(f"{p} is a folder; a {fmt} volume is one file")
    with _named_errors(p, fmt):
        return _reader(fmt)(p, **options)


def load(path, *, format: Optional[str] = None, box: str = "unit", normals: bool = False,
         value_range="data", **options) -> Volume:
    """Load a volume file as a Volume ready to render.

    Formats (chosen by extension, else by content; or ``format=``):
    ``.vti`` and legacy ``.vtk`` (no VTK needed), ``.raw`` + ``.raw.info``,
    ``.npy``/``.npz``, and through optional extras NIfTI (``[nifti]``),
    NRRD (``[nrrd]``), DICOM series folders (``[dicom]``), TIFF stacks
    (``[tiff]``), zarr (``[zarr]``). ``options`` go to the reader (e.g.
    ``array=`` for VTK files, ``key=`` for npz/zarr, ``index=`` for 4-D
    NIfTI, ``spacing=`` for TIFF/npy/zarr).

    The voxels keep their type and values (Hounsfield units, densities):
    ``value_range="data"`` (default) sets ``volume.value_range`` to the
    data's finite min..max, so the transfer functions span the data; pass
    ``(low, high)`` (e.g. ``window_level(400, 40)``) or None for pyvr's
    [0, 1] rule.

    ``box="unit"`` (default) maps the physical box into pyvr's world,
    keeping proportions: longest side from -1 to 1, centred at the origin,
    so pyvr's presets and cameras suit every file; ``box="physical"`` keeps
    the file's coordinates. ``volume.metadata`` holds the physical spacing,
    origin, bounds, units and ``world_per_unit`` (world length of one
    physical unit). ``normals=True`` precomputes normals (else lighting
    uses the field's gradient, which knows the spacing).
    """
    image = read(path, format=format, **options)
    # Lazy formats (zarr) read their chunks here, for the data's value range.
    with _named_errors(path, format or detect_format(Path(path))):
        vol = to_volume(image, box=box, normals=normals, value_range=value_range)
    vol.metadata["path"] = str(path)
    return vol
