"""The .vti reader moved to :mod:`pyvr.dataloaders.vti`; these names stay."""

from ..dataloaders.vti import VtiImage, load_vti

__all__ = ["load_vti", "VtiImage"]
