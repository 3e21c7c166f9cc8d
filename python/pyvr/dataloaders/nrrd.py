"""NRRD (``.nrrd``, and ``.nhdr`` with its detached data, raw or gzip)
through pynrrd (``pip install 'pyvr-rs[nrrd]'``).

pynrrd parses the header; the data is read here, so that a header that
lies cannot make the reader hang, inflate more than it declares, or read
files it should not:

- a detached header's ``data file`` must lie in the header's folder (or
  below it); ``data_outside_folder=True`` allows any path, for headers
  you trust;
- ``line skip`` stops at the end of the file, and ``byte skip`` must stay
  inside it;
- compressed data is inflated up to the declared size and no further;
- raw data must hold exactly the declared number of bytes.
"""

import bz2
import re
import zlib
from pathlib import Path

import numpy as np

from .._extras import require
from .image import FileFormatError, GridImage, check_shape, check_spacing

_COMPRESSED = {"gzip": "gzip", "gz": "gzip", "bzip2": "bzip2", "bz2": "bzip2"}
_TEXT = ("ascii", "text", "txt")
_CHUNK = 1 << 20


def load_nrrd(path, *, data_outside_folder: bool = False) -> GridImage:
    """Reads a 3-D NRRD with axis 0 the file's fastest axis (x). Spacing
    comes from ``space directions`` (column lengths) or ``spacings``, origin
    from ``space origin``, units from ``space units``. A detached header's
    data file must be in the header's folder unless
    ``data_outside_folder=True``."""
    nrrd = require("nrrd", "nrrd", "Reading NRRD")
    path = str(path)
    try:
        # pynrrd casts fields with numpy, which warns on NaN in an integer
        # field; the checks below say what is wrong with such a header.
        with open(path, "rb") as fh, np.errstate(invalid="ignore"):
            header = nrrd.read_header(fh)
            data_start = fh.tell()
    except FileNotFoundError:
        raise
    except Exception as e:
        raise FileFormatError(f"{path}: not a readable NRRD header ({type(e).__name__}: {e})") from None
    sizes = header.get("sizes")
    if sizes is None or len(sizes) != 3:
        raise FileFormatError(f"{path}: a volume needs 3 axes, the header says sizes={sizes}")
    try:
        dtype = np.dtype(nrrd.reader._determine_datatype(header))
    except Exception as e:
        raise FileFormatError(f"{path}: no usable type or endian in the header ({e})") from None
    dims = check_shape(path, sizes, dtype)
    data = _read_data(path, header, data_start, dims, dtype, data_outside_folder)
    return GridImage(data, check_spacing(path, _spacing(path, header)), _origin(path, header),
                     Path(path).name.split(".")[0], "nrrd", units=_unit(header))


def _read_data(path, header, data_start, dims, dtype, data_outside_folder) -> np.ndarray:
    """The voxels, (x, y, z) in Fortran order, read as the header says."""
    encoding = str(header.get("encoding", "")).lower()
    if encoding != "raw" and encoding not in _COMPRESSED and encoding not in _TEXT:
        raise FileFormatError(f"{path}: encoding {header.get('encoding')!r} is not one of raw, gzip, bzip2, ascii")
    line_skip = int(header.get("line skip", header.get("lineskip", 0)))
    byte_skip = int(header.get("byte skip", header.get("byteskip", 0)))
    if line_skip < 0:
        raise FileFormatError(f"{path}: line skip must be at least 0, got {line_skip}")
    if byte_skip < -1 or (byte_skip == -1 and encoding != "raw"):
        raise FileFormatError(f"{path}: byte skip must be at least 0 (or -1 for raw data), got {byte_skip}")
    source = header.get("data file", header.get("datafile"))
    file, start = (_data_file(path, source, data_outside_folder), 0) if source is not None else (Path(path), data_start)
    count = int(np.prod(dims))
    declared = count * dtype.itemsize
    with open(file, "rb") as fh:
        size = fh.seek(0, 2)
        fh.seek(start)
        for _ in range(line_skip):
            if not fh.readline():
                raise FileFormatError(f"{path}: line skip {line_skip} passes the end of {file.name}")
        if encoding == "raw":
            raw = _raw(path, fh, size, byte_skip, declared)
            values = np.frombuffer(raw, dtype)
        elif encoding in _TEXT:
            words = fh.read().split()[: count + 1]  # no more text than the file holds
            try:
                values = np.array(words, dtype=np.float64).astype(dtype)
            except ValueError as e:
                raise FileFormatError(f"{path}: the ascii data holds a word that is not a number ({e})") from None
        else:
            raw = _inflate(path, fh, _COMPRESSED[encoding], byte_skip, declared)
            values = np.frombuffer(raw, dtype)
    if values.size != count:
        raise FileFormatError(f"{path}: the data holds {values.size} values, the header declares {count}")
    return values.reshape(dims, order="F")


def _data_file(path, name, data_outside_folder) -> Path:
    """The detached data file, confined to the header's folder."""
    # The format's two multi-file forms: "LIST [dim]" and "<printf pattern> <min> <max> <step> [dim]".
    if not isinstance(name, str) or re.fullmatch(r"LIST(\s+\d+)?|\S*%\S*(\s+-?\d+){3,4}", name.strip()):
        raise FileFormatError(f"{path}: data file {name!r}: only a single data file is supported")
    folder = Path(path).resolve().parent
    file = (folder / name).resolve()  # an absolute name stays absolute
    if not data_outside_folder and not file.is_relative_to(folder):
        raise FileFormatError(
            f"{path}: its data file {name!r} is outside the header's folder {folder}; "
            "pass data_outside_folder=True if you trust this header")
    if not file.is_file():
        raise FileFormatError(f"{path}: its data file {name!r} does not exist ({file})")
    return file


def _raw(path, fh, size, byte_skip, declared) -> bytes:
    """Exactly ``declared`` bytes after the skips (byte skip -1: the last
    ``declared`` bytes of the file)."""
    if byte_skip == -1:
        if declared > size:
            raise FileFormatError(f"{path}: the data file holds {size} bytes, the header declares {declared}")
        fh.seek(size - declared)
    else:
        fh.seek(byte_skip, 1)
    left = size - fh.tell()
    if left != declared:
        raise FileFormatError(f"{path}: {max(left, 0)} bytes of data after the skips, the header declares {declared}")
    return fh.read(declared)


def _inflate(path, fh, kind, byte_skip, declared) -> bytes:
    """The decompressed data after ``byte_skip`` bytes, inflating no more
    than the header declares (one byte more tells that there is more)."""
    inflate = zlib.decompressobj(zlib.MAX_WBITS | 16) if kind == "gzip" else bz2.BZ2Decompressor()
    want = byte_skip + declared + 1
    out = bytearray()
    pending = b""
    try:
        while len(out) < want and not inflate.eof:
            if kind == "gzip":
                chunk = pending or fh.read(_CHUNK)
                if not chunk:
                    break
                out += inflate.decompress(chunk, want - len(out))
                pending = inflate.unconsumed_tail
            else:  # bz2 keeps what it has not yet given out; it asks for input when it needs it
                chunk = fh.read(_CHUNK) if inflate.needs_input else b""
                if inflate.needs_input and not chunk:
                    break
                out += inflate.decompress(chunk, want - len(out))
    except (zlib.error, OSError, EOFError, ValueError) as e:
        raise FileFormatError(f"{path}: the {kind} data is damaged ({e})") from None
    if len(out) > byte_skip + declared:
        raise FileFormatError(f"{path}: the {kind} data holds more than the {declared} bytes the header declares")
    if len(out) < byte_skip + declared:
        raise FileFormatError(f"{path}: the {kind} data holds {max(len(out) - byte_skip, 0)} bytes, "
                              f"the header declares {declared}")
    return bytes(out[byte_skip:])


def _spacing(path, header) -> np.ndarray:
    directions = header.get("space directions")
    if directions is not None:
        d = np.asarray(directions, dtype=np.float64)
        if d.shape != (3, 3) or not np.all(np.isfinite(d)):
            raise FileFormatError(f"{path}: space directions must be three finite vectors, got {directions!r}")
        return np.sqrt((d ** 2).sum(axis=1))
    if header.get("spacings") is not None:
        return np.asarray(header["spacings"], np.float64)
    return np.ones(3)


def _origin(path, header) -> np.ndarray:
    origin = np.asarray(header.get("space origin", np.zeros(3)), np.float64).reshape(-1)
    if origin.shape != (3,) or not np.all(np.isfinite(origin)):
        raise FileFormatError(f"{path}: space origin must be three finite numbers, got {header.get('space origin')!r}")
    return origin


def _unit(header):
    units = header.get("space units")
    return str(units[0]) if units is not None and len(units) else None
