"""A short slice of the .vti fuzzer (the 10-minute run is
benches/fuzz_vti.py): seeds read back exactly, and mutated files either
read consistently or raise FileFormatError naming the file."""

import random

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyvr.dataloaders import load_vti
from vti_fuzz import SHAPE, _values, check_one, mutate, seeds


def test_every_seed_reads_back(tmp_path):
    for i, s in enumerate(seeds()):
        p = tmp_path / f"seed{i}.vti"
        p.write_bytes(s)
        im = load_vti(p)
        assert im.data.shape == SHAPE
        assert np.array_equal(im.data, _values().transpose(2, 1, 0))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 4), salt=st.integers(0, 2**32 - 1))
def test_mutated_files_read_consistently_or_are_refused(tmp_path, seed, salt):
    p = tmp_path / "m.vti"
    p.write_bytes(mutate(seeds()[seed], random.Random(salt)))
    check_one(p)
