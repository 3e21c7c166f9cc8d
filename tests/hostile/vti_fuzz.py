"""The .vti fuzzer's pieces, shared by the short test (test_vti_fuzz.py)
and the long run (benches/fuzz_vti.py): valid seed files in each encoding,
mutations of their bytes and of the numbers their headers state, and the
one check every outcome must pass."""

import base64
import os
import random
import re
import struct
import zlib

import numpy as np

from pyvr.dataloaders import FileFormatError, load_vti

SHAPE = (5, 4, 3)


def _values():
    return np.arange(np.prod(SHAPE), dtype=np.float32).reshape(SHAPE[::-1]) * 0.5


def _blocks(raw, block):
    comp = [zlib.compress(raw[i:i + block]) for i in range(0, len(raw), block)]
    return struct.pack(f"<{3 + len(comp)}I", len(comp), block, len(raw) % block, *(len(c) for c in comp)) + b"".join(comp)


def _file(array_attrs, inline=b"", appended=None, compressor=False):
    ext = f"0 {SHAPE[0] - 1} 0 {SHAPE[1] - 1} 0 {SHAPE[2] - 1}"
    comp = ' compressor="vtkZLibDataCompressor"' if compressor else ""
    head = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
            f'header_type="UInt32"{comp}>\n<ImageData WholeExtent="{ext}" Origin="0 0 0" Spacing="1 1 1">\n'
            f'<Piece Extent="{ext}"><PointData Scalars="s"><DataArray type="Float32" Name="s" {array_attrs}>')
    body = head.encode() + inline + b"</DataArray></PointData></Piece></ImageData>"
    if appended is not None:
        body += b'<AppendedData encoding="raw">_' + appended + b"</AppendedData>"
    return body + b"</VTKFile>\n"


def seeds():
    """Valid files: ascii, inline base64, inline base64 zlib, appended raw, appended raw zlib."""
    raw = _values().tobytes()
    words = " ".join(str(v) for v in _values().ravel()).encode()
    return [
        _file('format="ascii"', words),
        _file('format="binary"', base64.b64encode(struct.pack("<I", len(raw)) + raw)),
        _file('format="binary"', base64.b64encode(_blocks(raw, 64)), compressor=True),
        _file('format="appended" offset="0"', b"", struct.pack("<I", len(raw)) + raw),
        _file('format="appended" offset="0"', b"", _blocks(raw, 32), compressor=True),
    ]


_NUMBERS = [0, 1, 2, 3, 7, 255, 2**16, 2**31 - 1, 2**32 - 1, 2**63 - 1, -1, -2**31, 10**12]


def mutate(data: bytes, rnd: random.Random) -> bytes:
    """One to four mutations: byte flips, cuts, repeats, a header word or an
    attribute number replaced by an extreme, a zlib bomb spliced in."""
    b = bytearray(data)
    for _ in range(rnd.randint(1, 4)):
        kind = rnd.randrange(7)
        if kind == 0 and b:
            b[rnd.randrange(len(b))] = rnd.randrange(256)
        elif kind == 1 and b:
            del b[rnd.randrange(len(b)):]
        elif kind == 2 and b:
            i, j = sorted(rnd.randrange(len(b)) for _ in range(2))
            b[j:j] = b[i:j] * rnd.randint(1, 3)
        elif kind == 3 and len(b) > 8:
            # A 32-bit word anywhere (block counts, sizes) set to an extreme.
            i = rnd.randrange(len(b) - 4)
            b[i:i + 4] = struct.pack("<I", rnd.choice(_NUMBERS) & 0xFFFFFFFF)
        elif kind == 4:
            # A number in the XML (extent, offset, spacing) set to an extreme.
            digits = [k for k in range(len(b)) if 48 <= b[k] <= 57]
            if digits:
                k = rnd.choice(digits)
                b[k:k + 1] = str(rnd.choice(_NUMBERS)).encode()
        elif kind == 5:
            # A block that inflates to 16 MiB, claimed as a small one.
            bomb = zlib.compress(bytes(16 << 20), 9)
            at = rnd.randrange(len(b) + 1)
            b[at:at] = struct.pack("<4I", 1, 64, 0, len(bomb)) + bomb
        else:
            for name in (b"ascii", b"binary", b"appended", b"Float32", b"UInt32", b"raw"):
                if name in b and rnd.random() < 0.3:
                    b = bytearray(bytes(b).replace(name, rnd.choice([b"UInt64", b"Int8", b"Float64", b"base64", b"x"]), 1))
    return bytes(b)


def check_one(path) -> str:
    """Reads ``path``: a result must match its stated extent and hold finite
    spacing; a failure must be FileFormatError (a ValueError) naming the
    file. Anything else (another exception type, a crash) fails the fuzz.
    Returns "ok" or "refused"."""
    try:
        im = load_vti(path)
    except FileFormatError as e:
        assert os.path.basename(str(path)) in str(e), f"error does not name the file: {e}"
        return "refused"
    assert im.data.ndim == 3 and all(d >= 1 for d in im.data.shape), im.data.shape
    assert np.all(np.isfinite(im.spacing)) and np.all(im.spacing > 0), im.spacing
    with open(path, "rb") as f:
        stated = re.search(rb'WholeExtent="([^"]*)"', f.read())
    if stated is not None:
        e = [int(v) for v in stated.group(1).split()]
        assert im.data.shape == (e[1] - e[0] + 1, e[3] - e[2] + 1, e[5] - e[4] + 1), (stated, im.data.shape)
    # Files of a few KiB (bombs included) never yield more: nothing is
    # inflated beyond what the extent needs, and data must match the extent.
    assert im.data.nbytes <= 64 << 20, im.data.shape
    return "ok"
