"""Reader for VTK XML image data (``.vti``): point arrays, raw, base64 or
zlib-compressed, inline or appended, either byte order; what VTK and
ParaView write by default. No VTK install needed.

Every size the file states is checked against the extent before anything
that large is allocated, and compressed blocks are inflated with a cap of
the size the extent needs, so a damaged or hostile file gives a
FileFormatError naming the file, never a huge allocation.
"""

import base64
import binascii
import re
import struct
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path
from typing import Optional

import numpy as np

from .image import GridImage, Malformed, check_shape, check_spacing, names_file

_TYPES = {
    "Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
    "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8",
}

#: Kept for code written against the first reader: the result type.
VtiImage = GridImage



def _b64(blob: bytes) -> bytes:
    try:
        return base64.b64decode(blob, validate=False)
    except (binascii.Error, ValueError) as e:
        raise Malformed(f"bad base64 data ({e})") from None


def _unpack(fmt: str, raw: bytes, what: str):
    need = struct.calcsize(fmt)
    if len(raw) < need:
        raise Malformed(f"the {what} is cut short ({len(raw)} of {need} bytes)")
    return struct.unpack(fmt, raw[:need])


def _decode(blob: bytes, order: str, header: str, compressed: bool, binary: bool, expect: int):
    """Undo VTK's base64 and zlib block encoding of one array of ``expect`` bytes."""
    h = order + ("Q" if header == "UInt64" else "I")
    size = struct.calcsize(h)
    if not compressed:
        raw = blob if binary else _b64(blob)
        (n,) = _unpack(h, raw, "array header")
        if n != expect:
            raise Malformed(f"the array header says {n} bytes, the extent needs {expect}")
        if len(raw) - size < n:
            raise Malformed(f"the data is cut short: {len(raw) - size} of {n} bytes")
        return raw[size:size + n]
    if binary:
        head = blob
    else:
        # The block header is base64-encoded on its own, then the blocks.
        first = _b64(blob[: 4 * ((3 * size + 2) // 3)])
        (nblocks,) = _unpack(h, first, "compression header")
        if nblocks > expect + 1:
            raise Malformed(f"{nblocks} compressed blocks for {expect} bytes")
        head_chars = 4 * (((3 + nblocks) * size + 2) // 3)
        head = _b64(blob[:head_chars]) + _b64(blob[head_chars:])
    (nblocks,) = _unpack(h, head, "compression header")
    if nblocks > expect + 1:
        raise Malformed(f"{nblocks} compressed blocks for {expect} bytes")
    fields = _unpack(order + h[1] * (3 + nblocks), head, "compression header")
    block, last = fields[1], fields[2]
    sizes = fields[3:]
    full = block * (nblocks - 1) + (last or block) if nblocks else 0
    if full != expect:
        raise Malformed(f"the compressed blocks hold {full} bytes, the extent needs {expect}")
    pos = (3 + nblocks) * size
    out = bytearray()  # returned as it is: np.frombuffer reads it without a copy
    for i, s in enumerate(sizes):
        want = block if (i < nblocks - 1 or last == 0) else last
        chunk = head[pos:pos + s]
        if len(chunk) < s:
            raise Malformed(f"compressed block {i} is cut short ({len(chunk)} of {s} bytes)")
        d = zlib.decompressobj()
        try:
            # Never inflate past what the header promised for this block.
            piece = d.decompress(chunk, want)
        except zlib.error as e:
            raise Malformed(f"compressed block {i} is damaged ({e})") from None
        if len(piece) != want or d.unconsumed_tail:
            raise Malformed(f"compressed block {i} inflates to {'more' if d.unconsumed_tail else len(piece)} "
                       f"bytes, the header says {want}")
        out += piece
        pos += s
    return out


def _ints(text, n, what):
    try:
        vals = [int(v) for v in (text or "").split()]
    except ValueError:
        raise Malformed(f"{what} {text!r} is not {n} integers") from None
    if len(vals) != n:
        raise Malformed(f"{what} {text!r} is not {n} integers")
    return vals


def _floats(text, n, what):
    try:
        vals = np.array([float(v) for v in text.split()], np.float64)
    except ValueError:
        raise Malformed(f"{what} {text!r} is not {n} numbers") from None
    if vals.shape != (n,) or not np.all(np.isfinite(vals)):
        raise Malformed(f"{what} {text!r} is not {n} finite numbers")
    return vals


def load_vti(path, array: Optional[str] = None) -> GridImage:
    """Reads a ``.vti`` file's scalar point array (the active one, or the one
    named ``array``) as a GridImage: ``data[i, j, k]`` at
    ``origin + (i, j, k) * spacing``, axis 0 along VTK's x.

    Raises FileFormatError (a ValueError) for damaged files and for what this
    reader does not handle (several pieces, vector arrays), OSError when the
    file cannot be opened.
    """
    path = str(path)
    with names_file(path):
        return _read(path, array)


def _read(path: str, array: Optional[str]) -> GridImage:
    with open(path, "rb") as f:
        text = f.read()
    cut = text.find(b"<AppendedData")
    appended = b""
    raw_appended = False
    if cut >= 0:
        close = text.find(b">", cut)
        start = text.find(b"_", close)
        end = text.rfind(b"</AppendedData>")
        if close < 0 or start < 0 or end < start:
            raise Malformed("the AppendedData section is malformed or cut short")
        raw_appended = re.search(rb'encoding\s*=\s*"raw"', text[cut:close]) is not None
        appended = text[start + 1:end]
        text = text[:cut] + b"</VTKFile>"
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise Malformed(f"not well-formed XML ({e})") from None
    if root.tag != "VTKFile" or root.get("type") != "ImageData":
        raise Malformed(f"not VTK ImageData (root <{root.tag}> type={root.get('type')!r})")
    byte_order = root.get("byte_order", "LittleEndian")
    if byte_order not in ("LittleEndian", "BigEndian"):
        raise Malformed(f"unknown byte_order {byte_order!r}")
    order = "<" if byte_order == "LittleEndian" else ">"
    header = root.get("header_type", "UInt32")
    if header not in ("UInt32", "UInt64"):
        raise Malformed(f"unknown header_type {header!r} (UInt32 or UInt64)")
    compressor = root.get("compressor")
    if compressor not in (None, "vtkZLibDataCompressor"):
        raise Malformed(f"compressor {compressor!r} is not supported (only vtkZLibDataCompressor)")
    image = root.find("ImageData")
    if image is None:
        raise Malformed("no <ImageData> element")
    pieces = image.findall("Piece")
    if len(pieces) != 1:
        raise Malformed(f"{len(pieces)} pieces; only single-piece files are supported")
    whole = _ints(image.get("WholeExtent"), 6, "WholeExtent")
    piece_ext = pieces[0].get("Extent")
    if piece_ext is not None and _ints(piece_ext, 6, "Piece Extent") != whole:
        raise Malformed(f"the piece's Extent {piece_ext!r} differs from WholeExtent {image.get('WholeExtent')!r}")
    x0, x1, y0, y1, z0, z1 = whole
    pd = pieces[0].find("PointData")
    arrays = pd.findall("DataArray") if pd is not None else []
    names = [a.get("Name", "") for a in arrays]
    name = array if array is not None else (pd.get("Scalars") if pd is not None else None)
    chosen = next((a for a in arrays if a.get("Name") == name), None)
    if chosen is None and array is None and arrays:
        chosen = arrays[0]
    if chosen is None:
        raise Malformed(f"no point array named {name!r}; available arrays: {names}", available_arrays=names)
    if chosen.get("NumberOfComponents", "1") != "1":
        raise Malformed(f"Multi-component scalars not supported. Array '{chosen.get('Name')}' has "
                        f"{chosen.get('NumberOfComponents')} components, expected 1.")
    vtype = chosen.get("type")
    if vtype not in _TYPES:
        raise Malformed(f"array type {vtype!r} is not one of {sorted(_TYPES)}")
    dtype = np.dtype(_TYPES[vtype]).newbyteorder(order)
    shape = check_shape(path, (x1 - x0 + 1, y1 - y0 + 1, z1 - z0 + 1), dtype)
    count = shape[0] * shape[1] * shape[2]
    expect = count * dtype.itemsize
    fmt = chosen.get("format", "ascii")
    if fmt == "ascii":
        words = (chosen.text or "").split()
        if len(words) != count:
            raise Malformed(f"{len(words)} values for extent {shape} ({count} points)")
        try:
            values = np.array(words, dtype=np.float64 if dtype.kind == "f" else np.int64).astype(dtype)
        except (ValueError, OverflowError):
            raise Malformed(f"array {chosen.get('Name')!r} holds text that is not {vtype}") from None
    elif fmt == "binary":
        raw = _decode((chosen.text or "").strip().encode(), order, header, compressor is not None, False, expect)
        values = np.frombuffer(raw, dtype)
    elif fmt == "appended":
        try:
            offset = int(chosen.get("offset", "0"))
        except ValueError:
            raise Malformed(f"offset {chosen.get('offset')!r} is not an integer") from None
        if not 0 <= offset <= len(appended):
            raise Malformed(f"offset {offset} lies outside the {len(appended)} appended bytes")
        blob = appended[offset:]
        if not raw_appended:
            blob = blob.strip()
        values = np.frombuffer(_decode(blob, order, header, compressor is not None, raw_appended, expect), dtype)
    else:
        raise Malformed(f"array format {fmt!r} is not ascii, binary or appended")
    # VTK stores x fastest: reshape (z, y, x), then put x on axis 0. The
    # transposed view (Fortran order) is kept: the upload copies anyway.
    data = values.reshape(shape[::-1]).transpose(2, 1, 0)
    if not data.dtype.isnative:
        data = data.astype(data.dtype.newbyteorder("="))
    origin = _floats(image.get("Origin", "0 0 0"), 3, "Origin")
    spacing = check_spacing(path, _floats(image.get("Spacing", "1 1 1"), 3, "Spacing"))
    # Extents need not start at 0: the first point sits at index x0, y0, z0.
    origin = origin + np.array([x0, y0, z0], np.float64) * spacing
    return GridImage(data, spacing, origin, Path(path).stem, "vti", extra={"array": chosen.get("Name", "")})
