"""A short slice of the header fuzzer (the long run is
benches/fuzz_headers.py): every seed reads back, and mutated NRRD, NIfTI
and raw headers either read consistently or are refused naming the file,
each read within 10 s."""

import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from header_fuzz import FORMATS, SHAPE, VALUES, check_one, mutate, write_case
from pyvr.dataloaders import read

pytest.importorskip("nrrd")
pytest.importorskip("nibabel")


@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_every_seed_reads_back(tmp_path, fmt):
    image = read(write_case(tmp_path, fmt, FORMATS[fmt][1]()))
    assert image.data.shape == SHAPE
    assert np.array_equal(np.asarray(image.data, np.float32), VALUES)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fmt=st.sampled_from(sorted(FORMATS)), salt=st.integers(0, 2**32 - 1))
def test_mutated_headers_read_consistently_or_are_refused(tmp_path, fmt, salt):
    rnd = random.Random(salt)
    path = write_case(tmp_path, fmt, mutate(FORMATS[fmt][1](), rnd))
    check_one(path)


@pytest.mark.parametrize("offset", [float("nan"), float("inf")])
def test_found_by_fuzzing_a_nifti_vox_offset_that_is_not_a_number(tmp_path, offset):
    # The extension-size check converted vox_offset to int first:
    # "ValueError: cannot convert float NaN to integer", naming no file.
    body = bytearray(FORMATS["nifti"][1]())
    body[108:112] = np.float32(offset).tobytes()
    assert check_one(write_case(tmp_path, "nifti", bytes(body))) == "refused"
