"""pyvr 0.4.1's VTK loader, without VTK."""

from pathlib import Path

import numpy as np

from ..volume import Volume
from .image import FileFormatError


def load_vtk_volume(file_path, scalars_name: str = "Scalars_") -> Volume:
    """Load the point scalars ``scalars_name`` of a VTK image file (XML
    ``.vti``, or legacy ``.vtk`` STRUCTURED_POINTS) as pyvr 0.4.1 did:
    float32 normalised to [0, 1] (zeros when the range is below 1e-9),
    normals computed, bounds centred at the origin with the physical
    extent's proportions (``n * spacing`` per axis, the longest side spanning
    [-1, 1]), origin ignored, name ``"{file name}({scalars_name})"``.

    Fixed from pyvr 0.4.1: VTK's x axis is world x (axis 0 of ``data``);
    pyvr mirrored x and z and applied the bounds in the other order. No VTK
    install is needed.
    """
    path = Path(file_path)
    if not path.exists():
        raise FileNotFoundError(f"VTK file not found: {path}")
    if path.suffix.lower() == ".vtk":
        from .legacy_vtk import load_legacy_vtk as reader
    else:
        from .vti import load_vti as reader
    try:
        image = reader(path, array=scalars_name)
    except FileFormatError as e:
        if e.available_arrays is not None:  # pyvr 0.4.1's message
            raise ValueError(f"Scalar array '{scalars_name}' not found in {file_path}. "
                             f"Available arrays: {e.available_arrays}") from None
        raise
    spacing = image.spacing
    if np.any(spacing <= 0):
        raise ValueError(f"Invalid spacing (must be positive): {tuple(spacing)}")
    data = image.data.astype(np.float32)
    lo, hi = float(np.min(data)), float(np.max(data))
    data = np.zeros_like(data) if hi - lo < 1e-9 else (data - lo) / (hi - lo)
    dims = np.array(data.shape, np.float64) * spacing
    scale = 2.0 / dims.max()
    volume = Volume(
        data=data.astype(np.float32),
        min_bounds=(-dims * scale / 2).astype(np.float32),
        max_bounds=(dims * scale / 2).astype(np.float32),
        name=f"{path.name}({scalars_name})",
    )
    volume.compute_normals()
    return volume
