"""Real volumes shipped with pyvr, small enough to travel in the wheel."""

import os

_DATA = os.path.join(os.path.dirname(__file__), "data")


def fuel_path() -> str:
    """Path of ``fuel.vti``: a 64^3 float32 simulation of fuel injected into
    a combustion chamber (values 0..255), VTK XML image data. It is pyvr
    0.4.1's example volume and shares its licence (WTFPL)."""
    return os.path.join(_DATA, "fuel.vti")


def fuel(**load_options):
    """``fuel.vti`` loaded with :func:`pyvr.load` (``load_options`` are
    passed on): a :class:`~pyvr.volume.Volume` in a unit box whose
    ``value_range`` is the data range."""
    from ..dataloaders import load

    return load(fuel_path(), **load_options)
