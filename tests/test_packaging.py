"""What the installed distribution carries: its name and one version, the
licence, the type marker, the shipped example volume, and errors that name
the extra to install."""

import importlib.metadata
import os
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import pyvr

ROOT = Path(__file__).resolve().parents[1]
SHARED_FUEL = ROOT.parent / "shared" / "data" / "fuel.vti"


def test_one_version_from_cargo_toml_under_the_distribution_name():
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())["package"]["version"]
    assert pyvr.__version__ == cargo
    assert importlib.metadata.version("pyvr-rs") == cargo


def test_the_distribution_carries_licence_type_marker_and_data():
    files = {str(f) for f in importlib.metadata.files("pyvr-rs")}
    assert any(f.endswith("LICENSE") for f in files), sorted(f for f in files if "dist-info" in f)
    assert "pyvr/py.typed" in files
    assert "pyvr/datasets/data/fuel.vti" in files
    meta = importlib.metadata.metadata("pyvr-rs")
    assert meta["Requires-Python"] == ">=3.11"
    assert sorted(r for r in meta.get_all("Requires-Dist") if "extra ==" not in r) == ["numpy>=1.24", "scipy>=1.10"]


def test_fuel_is_the_example_volume():
    vol = pyvr.datasets.fuel()
    assert vol.shape == (64, 64, 64)
    assert vol.data.dtype == np.float32
    assert vol.value_range == (0.0, 255.0)
    assert os.path.getsize(pyvr.datasets.fuel_path()) == 20423
    if SHARED_FUEL.exists():
        assert Path(pyvr.datasets.fuel_path()).read_bytes() == SHARED_FUEL.read_bytes()


def test_render_to_pil_without_pillow_names_the_extra(monkeypatch):
    from scenes import make_renderer

    r = make_renderer(pyvr.volume.Volume(pyvr.datasets.create_sample_volume(16, "sphere")))
    for name in [m for m in sys.modules if m == "PIL" or m.startswith("PIL.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "PIL", None)
    with pytest.raises(ImportError, match=r"render_to_pil needs the optional package 'PIL': pip install 'pyvr-rs\[plot\]'"):
        r.render_to_pil()
