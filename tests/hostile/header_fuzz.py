"""The header fuzzer's pieces for the formats whose headers pyvr parses or
checks itself (NRRD attached and detached, NIfTI-1, raw + .raw.info),
shared by the short test (test_header_fuzz.py) and the long run
(benches/fuzz_headers.py): valid seed files, mutations of the header's
bytes and numbers, and the one check every outcome must pass."""

import gzip
import os
import random
import signal
from pathlib import Path

import numpy as np

from pyvr.dataloaders import FileFormatError, read
from vti_fuzz import mutate as mutate_bytes

SHAPE = (5, 4, 3)
VALUES = np.arange(np.prod(SHAPE), dtype="<f4").reshape(SHAPE)


def _nrrd(encoding: str, data_file: str = "") -> bytes:
    head = (f"NRRD0004\ntype: float\ndimension: 3\nsizes: {SHAPE[0]} {SHAPE[1]} {SHAPE[2]}\n"
            f"encoding: {encoding}\nendian: little\nspace dimension: 3\n"
            "space directions: (1,0,0) (0,2,0) (0,0,0.5)\nspace origin: (0,0,0)\n")
    if data_file:
        return (head + f"data file: {data_file}\n\n").encode()
    body = VALUES.ravel(order="F").tobytes()
    return head.encode() + b"\n" + (gzip.compress(body) if encoding == "gzip" else body)


def _nifti() -> bytes:
    import nibabel as nib

    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "v.nii")
        nib.save(nib.Nifti1Image(VALUES, np.diag([1.0, 2.0, 0.5, 1.0])), path)
        with open(path, "rb") as f:
            return f.read()


def _raw_info() -> bytes:
    return (f"dimensions: {SHAPE[0]} {SHAPE[1]} {SHAPE[2]}\ntype: float32\nspacing: 1 2 0.5\n"
            "origin: 0 0 0\nendian: little\n").encode()


#: name -> (file name the mutated bytes go to, the seed's bytes)
FORMATS = {
    "nrrd_raw": ("v.nrrd", lambda: _nrrd("raw")),
    "nrrd_gzip": ("v.nrrd", lambda: _nrrd("gzip")),
    "nhdr": ("v.nhdr", lambda: _nrrd("raw", "v.raw")),
    "nifti": ("v.nii", _nifti),
    "raw_info": ("v.raw.info", _raw_info),
}


def write_case(folder, fmt: str, body: bytes) -> Path:
    """Writes one case into ``folder``: the (mutated) header file, and the
    intact data file a detached header or .raw.info points to. Returns
    the path to read."""
    folder = Path(folder)
    name = FORMATS[fmt][0]
    (folder / name).write_bytes(body)
    if fmt in ("nhdr", "raw_info"):
        # Detached data: Fortran order for NRRD (x fastest), C order for raw (axis 0 along x, x fastest too).
        (folder / "v.raw").write_bytes(VALUES.ravel(order="F").tobytes())
    return folder / ("v.raw" if fmt == "raw_info" else name)


def mutate(body: bytes, rnd: random.Random) -> bytes:
    """The .vti fuzzer's byte and number mutations, plus header lines
    repeated, dropped or given extreme values."""
    if rnd.random() < 0.5:
        return mutate_bytes(body, rnd)
    text = body.split(b"\n")
    header_lines = [i for i, line in enumerate(text[:14]) if b":" in line]
    if not header_lines:
        return mutate_bytes(body, rnd)
    i = rnd.choice(header_lines)
    key = text[i].split(b":", 1)[0]
    choice = rnd.randrange(4)
    if choice == 0:
        del text[i]
    elif choice == 1:
        text.insert(i, text[i])
    else:
        extreme = rnd.choice([b"-1", b"0", b"nan", b"inf", b"1e308", b"99999999999", b"18446744073709551617",
                              b"(nan,0,0) (0,1,0) (0,0,1)", b"../v.raw", b"/etc/hostname", b"", b"x y z"])
        text[i] = key + b": " + extreme
    return b"\n".join(text)


class Hung(Exception):
    pass


def _alarm(signum, frame):
    raise Hung("a read took more than 10 s")


def check_one(path) -> str:
    """Reads ``path``: a result must be a 3-D image of at most the seed's
    bytes times the mutations' reach (64 MiB) with finite positive spacing;
    a failure must be FileFormatError naming the file, or OSError /
    MemoryError (a missing data file, a size refused before allocating).
    A read past 10 s fails. Returns "ok" or "refused"."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(10)
    try:
        image = read(path)
    except FileFormatError as e:
        assert os.path.basename(str(path)).split(".")[0] in str(e), f"error does not name the file: {e}"
        return "refused"
    except (OSError, MemoryError):
        return "refused"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert image.data.ndim == 3 and all(d >= 1 for d in image.data.shape), image.data.shape
    assert image.data.nbytes <= 64 << 20, image.data.shape
    spacing = np.asarray(image.spacing, np.float64)
    assert np.all(np.isfinite(spacing)) and np.all(spacing > 0), spacing
    return "ok"
