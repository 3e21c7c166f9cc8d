"""A short slice of the DICOM series fuzzer: the seed series loads, and
mutated series (slices missing or repeated, positions, orientations,
spacing, sizes, rescale and pixel data changed) load consistently or are
refused naming the series or a slice."""

import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("pydicom")

from dicom_fuzz import SHAPE, check_one, mutate, write_series  # noqa: E402
from pyvr.dataloaders import load_dicom_series  # noqa: E402
from test_loaders import SPACING  # noqa: E402


def test_the_seed_series_loads(tmp_path):
    write_series(tmp_path / "series")
    image = load_dicom_series(tmp_path / "series")
    assert image.data.shape == SHAPE
    assert np.allclose(image.spacing, SPACING)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(salt=st.integers(0, 2**32 - 1))
def test_mutated_series_load_consistently_or_are_refused(tmp_path_factory, salt):
    folder = tmp_path_factory.mktemp("fuzz") / "series"
    write_series(folder)
    mutate(folder, random.Random(salt))
    check_one(folder)
