"""Raw binary volumes described by a text header: ``name.raw`` beside
``name.raw.info`` (the ray-casting project outline's format).

The header is one ``key: value`` (or ``key = value``) per line; keys are
case-insensitive, ``#`` starts a comment. Accepted keys:

============  ========================================================  =========
key           value                                                     default
============  ========================================================  =========
dimensions    three positive integers nx ny nz; x varies fastest        required
              in the file (also ``dims``, ``size``, ``resolution``)
type          uint8, int8, uint16, int16, uint32, int32, float32,       required
              float64 (also ``unsigned char``, ``UInt16``, ``float``,
              ``double``, ...; key also ``datatype``, ``format``)
spacing       three positive numbers (also ``ratio``, ``voxel_size``)   1 1 1
origin        three numbers: the first voxel's centre                   0 0 0
byte_order    little or big (also ``endian``, ``endianness``)           little
offset        bytes to skip before the data (also ``header_bytes``)     0
units         the spatial unit, e.g. mm                                 none
value_unit    the values' unit, e.g. HU                                 none
============  ========================================================  =========

The file must hold exactly ``offset + nx*ny*nz*itemsize`` bytes.
"""

import os
import re
from pathlib import Path

import numpy as np

from .image import FileFormatError, GridImage, check_shape, check_spacing

_KEYS = {
    "dimensions": "dimensions", "dims": "dimensions", "size": "dimensions", "resolution": "dimensions",
    "dimension": "dimensions",
    "type": "type", "datatype": "type", "data_type": "type", "format": "type", "dtype": "type",
    "spacing": "spacing", "ratio": "spacing", "voxel_size": "spacing", "voxelsize": "spacing",
    "origin": "origin",
    "byte_order": "byte_order", "byteorder": "byte_order", "endian": "byte_order", "endianness": "byte_order",
    "offset": "offset", "header_bytes": "offset", "header_size": "offset",
    "units": "units", "unit": "units",
    "value_unit": "value_unit",
}

_TYPES = {
    "uint8": "u1", "unsigned char": "u1", "uchar": "u1", "ubyte": "u1",
    "int8": "i1", "char": "i1", "signed char": "i1", "byte": "i1",
    "uint16": "u2", "unsigned short": "u2", "ushort": "u2",
    "int16": "i2", "short": "i2",
    "uint32": "u4", "unsigned int": "u4", "uint": "u4",
    "int32": "i4", "int": "i4",
    "float32": "f4", "float": "f4",
    "float64": "f8", "double": "f8",
}


def info_path(path) -> Path:
    p = Path(path)
    return p if p.name.endswith(".info") else p.with_name(p.name + ".info")


def _key_and_value(line: str):
    """A ``key value`` line (no colon, as many tools write them): the
    longest run of leading words that is a known key, and the rest."""
    words = line.split()
    for i in range(len(words) - 1, 0, -1):
        if "_".join(words[:i]).lower() in _KEYS:
            return " ".join(words[:i]), " ".join(words[i:])
    return None, None


def parse_info(path) -> dict:
    """The header's fields, checked, as python values."""
    path = str(path)
    fields = {}
    with open(path, "r", encoding="utf-8", errors="replace") as f:
        text = f.read(1 << 16)
    for n, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        m = re.match(r"([A-Za-z_ ]+?)\s*[:=]\s*(.*)$", line)
        name, value = (m.group(1).strip(), m.group(2)) if m else _key_and_value(line)
        if name is None:
            raise FileFormatError(f"{path}, line {n}: expected 'key: value' or 'key value', got {line!r}")
        key = _KEYS.get(name.lower().replace(" ", "_"))
        if key is None:
            raise FileFormatError(f"{path}, line {n}: unknown key {name!r}; known: {sorted(set(_KEYS))}")
        fields[key] = value.strip()
    for key in ("dimensions", "type"):
        if key not in fields:
            raise FileFormatError(f"{path}: the header has no {key!r} line")
    tname = re.sub(r"\s+", " ", fields["type"].lower())
    if tname not in _TYPES:
        raise FileFormatError(f"{path}: unknown type {fields['type']!r}; known: {sorted(_TYPES)}")
    order = fields.get("byte_order", "little").lower()
    order = {"little": "<", "littleendian": "<", "little_endian": "<", "big": ">", "bigendian": ">",
             "big_endian": ">"}.get(order.replace("-", "_"))
    if order is None:
        raise FileFormatError(f"{path}: byte_order must be 'little' or 'big', got {fields['byte_order']!r}")
    dtype = np.dtype(_TYPES[tname]).newbyteorder(order)

    def numbers(key, n, default, kind=float):
        words = re.split(r"[\s,x×]+", fields.get(key, default).strip()) if key in fields else default.split()
        try:
            vals = [kind(w) for w in words if w]
        except ValueError:
            raise FileFormatError(f"{path}: {key} {fields[key]!r} is not {n} numbers") from None
        if len(vals) != n:
            raise FileFormatError(f"{path}: {key} {fields.get(key)!r} is not {n} numbers")
        return vals

    dims = check_shape(path, numbers("dimensions", 3, "", int), dtype)
    spacing = check_spacing(path, numbers("spacing", 3, "1 1 1"))
    origin = np.array(numbers("origin", 3, "0 0 0"), np.float64)
    if not np.all(np.isfinite(origin)):
        raise FileFormatError(f"{path}: origin must be finite")
    (offset,) = numbers("offset", 1, "0", int)
    if offset < 0:
        raise FileFormatError(f"{path}: offset must be >= 0, got {offset}")
    return {"dims": dims, "dtype": dtype, "spacing": spacing, "origin": origin, "offset": offset,
            "units": fields.get("units"), "value_unit": fields.get("value_unit")}


def load_raw(path, info=None, *, mmap: bool = False) -> GridImage:
    """Reads ``path`` (``name.raw``; its header is ``name.raw.info`` unless
    ``info`` names another) as a GridImage with axis 0 along x. ``mmap=True``
    maps the file instead of reading it (native byte order only)."""
    p = Path(path)
    if p.name.endswith(".info"):
        p = p.with_name(p.name[: -len(".info")])
    hdr = parse_info(info if info is not None else info_path(p))
    dims, dtype, offset = hdr["dims"], hdr["dtype"], hdr["offset"]
    nbytes = dims[0] * dims[1] * dims[2] * dtype.itemsize
    size = os.stat(p).st_size
    if size != offset + nbytes:
        raise FileFormatError(
            f"{p}: holds {size} bytes, but dimensions {dims} of {dtype.name} after an offset of {offset} "
            f"need exactly {offset + nbytes}"
        )
    if mmap and dtype.isnative:
        flat = np.memmap(p, dtype=dtype, mode="r", offset=offset, shape=(nbytes // dtype.itemsize,))
    else:
        with open(p, "rb") as f:
            f.seek(offset)
            flat = np.fromfile(f, dtype=dtype, count=nbytes // dtype.itemsize)
        if flat.size * dtype.itemsize != nbytes:
            raise FileFormatError(f"{p}: could read only {flat.size * dtype.itemsize} of {nbytes} bytes")
        if not dtype.isnative:
            flat = flat.astype(dtype.newbyteorder("="))
    # x fastest in the file: a transposed view (Fortran order), no copy.
    data = flat.reshape(dims[::-1]).transpose(2, 1, 0)
    return GridImage(data, hdr["spacing"], hdr["origin"], p.stem, "raw",
                     units=hdr["units"], value_unit=hdr["value_unit"])


def save_raw(path, data: np.ndarray, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), units=None) -> None:
    """Writes ``data`` (axis 0 along x) as ``path`` and ``path.info``."""
    a = np.asarray(data)
    if a.ndim != 3:
        raise ValueError(f"data must be 3-D, got shape {a.shape}")
    names = {"u1": "uint8", "i1": "int8", "u2": "uint16", "i2": "int16", "u4": "uint32", "i4": "int32",
             "f4": "float32", "f8": "float64"}
    key = a.dtype.kind + str(a.dtype.itemsize)
    if key not in names:
        raise ValueError(f"dtype {a.dtype} cannot be written as raw; use one of {sorted(names.values())}")
    p = Path(path)
    np.ascontiguousarray(a.transpose(2, 1, 0)).astype(a.dtype.newbyteorder("<")).tofile(p)
    lines = [f"dimensions: {a.shape[0]} {a.shape[1]} {a.shape[2]}", f"type: {names[key]}",
             "spacing: " + " ".join(repr(float(s)) for s in spacing), "origin: " + " ".join(repr(float(s)) for s in origin),
             "byte_order: little"]
    if units:
        lines.append(f"units: {units}")
    info_path(p).write_text("\n".join(lines) + "\n")
