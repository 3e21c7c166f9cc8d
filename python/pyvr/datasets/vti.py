"""Reader for VTK XML image data (``.vti``): one scalar point array, raw,
base64 or zlib-compressed, inline or appended; enough for the data VTK and
ParaView write by default. No VTK install needed."""

import base64
import struct
import xml.etree.ElementTree as ET
import zlib
from typing import NamedTuple, Optional

import numpy as np

_TYPES = {
    "Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
    "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8",
}


class VtiImage(NamedTuple):
    """``data`` is indexed [x, y, z] (pyvr's axis order: axis 0 along world x)."""

    data: np.ndarray
    origin: np.ndarray
    spacing: np.ndarray
    name: str

    def bounds(self):
        """(min_bounds, max_bounds) of the box the voxels fill, cell-centred:
        each point owns a cell of one spacing around it."""
        shape = np.array(self.data.shape, np.float64)
        lo = self.origin - 0.5 * self.spacing
        return lo.astype(np.float32), (lo + shape * self.spacing).astype(np.float32)


def _decode(blob: bytes, header: str, compressed: bool, binary: bool) -> bytes:
    """Undo VTK's base64 and zlib block encoding of one array."""
    hdr = "<" + ("Q" if header == "UInt64" else "I")
    size = struct.calcsize(hdr)
    if not compressed:
        raw = base64.b64decode(blob) if not binary else blob
        (n,) = struct.unpack(hdr, raw[:size])
        return raw[size:size + n]
    if binary:
        head = blob
    else:
        # The block header is base64-encoded on its own, then the blocks.
        first = base64.b64decode(blob[: 4 * ((3 * size + 2) // 3)])
        nblocks = struct.unpack(hdr, first[:size])[0]
        head_len = (3 + nblocks) * size
        head_chars = 4 * ((head_len + 2) // 3)
        head = base64.b64decode(blob[:head_chars]) + base64.b64decode(blob[head_chars:])
    nblocks = struct.unpack(hdr, head[:size])[0]
    sizes = struct.unpack("<" + hdr[1] * nblocks, head[3 * size:(3 + nblocks) * size])
    pos = (3 + nblocks) * size
    out = []
    for s in sizes:
        out.append(zlib.decompress(head[pos:pos + s]))
        pos += s
    return b"".join(out)


def load_vti(path: str, array: Optional[str] = None) -> VtiImage:
    """Reads a ``.vti`` file's point scalars (the active ones, or ``array``).

    Raises ValueError for files this reader does not handle (several pieces,
    vector arrays, raw appended data with a different byte order).
    """
    with open(path, "rb") as f:
        text = f.read()
    cut = text.find(b"<AppendedData")
    appended = b""
    raw_appended = False
    if cut >= 0:
        raw_appended = b'encoding="raw"' in text[cut:text.index(b">", cut)]
        start = text.index(b"_", text.index(b">", cut)) + 1
        end = text.rindex(b"</AppendedData>")
        appended = text[start:end]
        text = text[:cut] + b"</VTKFile>"
    root = ET.fromstring(text)
    if root.get("type") != "ImageData":
        raise ValueError(f"{path}: not VTK ImageData (type={root.get('type')!r})")
    if root.get("byte_order", "LittleEndian") != "LittleEndian":
        raise ValueError(f"{path}: big-endian files are not supported")
    header = root.get("header_type", "UInt32")
    compressed = root.get("compressor") is not None
    image = root.find("ImageData")
    pieces = image.findall("Piece")
    if len(pieces) != 1:
        raise ValueError(f"{path}: {len(pieces)} pieces; only single-piece files are supported")
    x0, x1, y0, y1, z0, z1 = (int(v) for v in image.get("WholeExtent").split())
    shape = (x1 - x0 + 1, y1 - y0 + 1, z1 - z0 + 1)
    pd = pieces[0].find("PointData")
    arrays = pd.findall("DataArray") if pd is not None else []
    name = array or (pd.get("Scalars") if pd is not None else None)
    chosen = next((a for a in arrays if a.get("Name") == name), arrays[0] if arrays and array is None else None)
    if chosen is None:
        raise ValueError(f"{path}: no point array named {name!r}")
    if int(chosen.get("NumberOfComponents", "1")) != 1:
        raise ValueError(f"{path}: array {chosen.get('Name')!r} is not scalar")
    dtype = np.dtype(_TYPES[chosen.get("type")]).newbyteorder("<")
    fmt = chosen.get("format", "ascii")
    if fmt == "ascii":
        values = np.array(chosen.text.split(), dtype=dtype)
    elif fmt == "binary":
        values = np.frombuffer(_decode(chosen.text.strip().encode(), header, compressed, False), dtype)
    else:
        blob = appended[int(chosen.get("offset", "0")):]
        if not raw_appended:
            blob = blob.strip()
        values = np.frombuffer(_decode(blob, header, compressed, raw_appended), dtype)
    count = shape[0] * shape[1] * shape[2]
    if values.size < count:
        raise ValueError(f"{path}: {values.size} values for extent {shape}")
    # VTK stores x fastest: reshape (z, y, x), then put x on axis 0.
    data = np.ascontiguousarray(values[:count].reshape(shape[::-1]).transpose(2, 1, 0))
    origin = np.array([float(v) for v in image.get("Origin", "0 0 0").split()])
    spacing = np.array([float(v) for v in image.get("Spacing", "1 1 1").split()])
    return VtiImage(data, origin, spacing, chosen.get("Name", ""))
