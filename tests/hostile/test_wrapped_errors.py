"""Errors from the libraries under the readers reach the user as
FileFormatError naming the file, the library's error kept as its cause;
pyvr's own argument errors pass unchanged."""

import glob
import os

import numpy as np
import pytest

import pyvr
from pyvr.dataloaders import FileFormatError

DATA = np.arange(8 * 8 * 8, dtype=np.float32).reshape(8, 8, 8)


def test_corrupt_zarr_chunks_name_the_store(tmp_path):
    zarr = pytest.importorskip("zarr")
    store = tmp_path / "c.zarr"
    z = zarr.open(str(store), mode="w", shape=(8, 8, 8), chunks=(4, 4, 4), dtype="f4")
    z[:] = DATA
    chunks = [f for f in glob.glob(f"{store}/**", recursive=True)
              if os.path.isfile(f) and not os.path.basename(f).startswith(".") and not f.endswith(".json")]
    assert chunks
    for f in chunks:
        with open(f, "wb") as out:
            out.write(b"\x00garbage" * 3)
    # numcodecs' RuntimeError reached the user, without the store's name.
    with pytest.raises(FileFormatError, match=r"c\.zarr: not a readable zarr file \(RuntimeError: ") as info:
        pyvr.load(store)
    assert isinstance(info.value.__cause__, RuntimeError)


@pytest.mark.parametrize("cut", ["truncated", "garbage"])
def test_broken_npz_names_the_file(tmp_path, cut):
    good = tmp_path / "a.npz"
    np.savez_compressed(good, v=DATA)
    bad = tmp_path / "b.npz"
    body = good.read_bytes()
    bad.write_bytes(body[:-40] if cut == "truncated" else b"PK\x03\x04" + bytes(100))
    # zipfile's BadZipFile reached the user unwrapped.
    with pytest.raises(FileFormatError, match=r"b\.npz: not a readable npy file \(BadZipFile: "):
        pyvr.load(bad)


def test_pyvrs_own_argument_errors_pass_unchanged(tmp_path):
    path = tmp_path / "a.npz"
    np.savez_compressed(path, v=DATA)
    with pytest.raises(ValueError, match="value_range must be 'data', None or"):
        pyvr.load(path, value_range="x")
    with pytest.raises(ValueError, match="has no array 'nope'"):
        pyvr.load(path, key="nope")


def test_a_huge_nifti_header_extension_is_refused_before_it_is_read(tmp_path):
    # nibabel reads extensions whole: a 1 MB .nii.gz declaring 1 GiB of them
    # took 10 s and 1.1 GiB, then loaded. Here 96 MiB of zeros (about 100 KB
    # compressed) against the 64 MiB default.
    import gzip
    import time

    nib = pytest.importorskip("nibabel")
    plain = tmp_path / "a.nii"
    nib.save(nib.Nifti1Image(DATA, np.eye(4)), plain)
    header = bytearray(plain.read_bytes()[:352])
    extension = 96 << 20
    header[108:112] = np.float32(352 + extension).tobytes()
    header[348:352] = b"\x01\x00\x00\x00"  # "extensions follow"
    path = tmp_path / "big.nii.gz"
    with gzip.open(path, "wb", compresslevel=1) as f:
        f.write(header)
        # One comment extension: its size (a multiple of 16) and code, then text.
        f.write(np.array([extension, 6], "<i4").tobytes())
        f.write(bytes(extension - 8))
        f.write(DATA.tobytes())
    start = time.perf_counter()
    with pytest.raises(FileFormatError, match=r"declares 100663296 bytes of extensions .* max_extension_bytes"):
        pyvr.load(path)
    assert time.perf_counter() - start < 1.0
    # Widened, the same file loads.
    vol = pyvr.load(path, max_extension_bytes=128 << 20)
    assert vol.shape == DATA.shape


def test_a_zarr_chunk_corrupted_after_loading_names_the_store_at_render(tmp_path):
    # Read brick by brick, a bad chunk surfaced at render time as numcodecs'
    # bare RuntimeError.
    zarr = pytest.importorskip("zarr")
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    store = tmp_path / "c.zarr"
    z = zarr.open(str(store), mode="w", shape=(48, 40, 36), chunks=(16, 16, 16), dtype="f4")
    z[:] = np.random.default_rng(0).random((48, 40, 36), np.float32)
    r = VolumeRenderer(32, 32, brick_shape=(16, 16, 16), memory_budget=1 << 18)
    r.load_volume(Volume(zarr.open(str(store), mode="r")))
    assert r.render()[..., 3].max() > 0 and not r.bricks["resident"]
    for f in glob.glob(f"{store}/**", recursive=True):
        if os.path.isfile(f) and not os.path.basename(f).startswith(".") and not f.endswith(".json"):
            with open(f, "wb") as out:
                out.write(b"\x00garbage" * 3)
    with pytest.raises(FileFormatError, match=r"reading voxels .* of Array .*c\.zarr.* failed \(RuntimeError: ") as info:
        r.render()
    assert isinstance(info.value.__cause__, RuntimeError)


def test_a_corrupt_gzip_nifti_names_the_file_through_load_nifti_too(tmp_path):
    # The extension-size check read the gzip stream before nibabel did, and
    # zlib.error escaped load_nifti (pyvr.load wrapped it).
    pytest.importorskip("nibabel")
    from pyvr.dataloaders import load_nifti

    path = tmp_path / "bad.nii.gz"
    path.write_bytes(b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03garbage-not-deflate")
    with pytest.raises(FileFormatError, match=r"bad\.nii\.gz: not a readable NIfTI file"):
        load_nifti(path)
