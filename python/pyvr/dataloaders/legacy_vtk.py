"""Reader for legacy VTK files (``.vtk``) holding STRUCTURED_POINTS, ASCII
or BINARY (big-endian, as the format defines), which simulation codes still
write. Point scalars only; other point arrays are skipped."""

from pathlib import Path
from typing import Optional

import numpy as np

from .image import GridImage, Malformed, check_shape, check_spacing, names_file

_TYPES = {
    "unsigned_char": "u1", "char": "i1", "short": "i2", "unsigned_short": "u2", "int": "i4",
    "unsigned_int": "u4", "long": "i8", "unsigned_long": "u8", "float": "f4", "double": "f8",
    "vtktypeint8": "i1", "vtktypeuint8": "u1", "vtktypeint16": "i2", "vtktypeuint16": "u2",
    "vtktypeint32": "i4", "vtktypeuint32": "u4", "vtktypeint64": "i8", "vtktypeuint64": "u8",
    "vtktypefloat32": "f4", "vtktypefloat64": "f8",
}



class _Cursor:
    """The unread rest of the file: keywords are whitespace-separated
    tokens; binary arrays start after the newline ending their header line."""

    def __init__(self, buf: bytes):
        self.buf = memoryview(buf)
        self.pos = 0

    def line(self) -> str:
        end = bytes(self.buf[self.pos:self.pos + 4096]).find(b"\n")
        if end < 0:
            end = min(len(self.buf) - self.pos, 4096)
        text = bytes(self.buf[self.pos:self.pos + end])
        self.pos += end + 1
        return text.decode("latin-1").strip()

    def token(self) -> Optional[str]:
        n = len(self.buf)
        while self.pos < n and self.buf[self.pos] in b" \t\r\n":
            self.pos += 1
        start = self.pos
        while self.pos < n and self.buf[self.pos] not in b" \t\r\n":
            self.pos += 1
        return bytes(self.buf[start:self.pos]).decode("latin-1") if self.pos > start else None

    def need(self, what: str) -> str:
        t = self.token()
        if t is None:
            raise Malformed(f"the file ends where {what} should be")
        return t

    def numbers(self, n: int, what: str, kind=float):
        vals = []
        for _ in range(n):
            t = self.need(what)
            try:
                vals.append(kind(t))
            except ValueError:
                raise Malformed(f"{what}: {t!r} is not a number") from None
        return vals

    def binary(self, nbytes: int, what: str) -> memoryview:
        # The data starts after the newline that ends the header line.
        nl = bytes(self.buf[self.pos:self.pos + 4096]).find(b"\n")
        if nl >= 0:
            self.pos += nl + 1
        if len(self.buf) - self.pos < nbytes:
            raise Malformed(f"{what} is cut short: {len(self.buf) - self.pos} of {nbytes} bytes")
        out = self.buf[self.pos:self.pos + nbytes]
        self.pos += nbytes
        return out

    def ascii_values(self, n: int, dtype, what: str) -> np.ndarray:
        vals = self.numbers(n, what, float if dtype.kind == "f" else int)
        try:
            return np.array(vals, dtype=dtype)
        except OverflowError:
            raise Malformed(f"{what} holds values outside {dtype.name}") from None


def load_legacy_vtk(path, array: Optional[str] = None) -> GridImage:
    """Reads the point scalars named ``array`` (default: the first) of a
    legacy ``.vtk`` STRUCTURED_POINTS file. ``data[i, j, k]`` lies at
    ``origin + (i, j, k) * spacing``, axis 0 along VTK's x."""
    path = str(path)
    with names_file(path):
        return _read(path, array)


def _read(path: str, array: Optional[str]) -> GridImage:
    with open(path, "rb") as f:
        cur = _Cursor(f.read())
    if not cur.line().lower().startswith("# vtk datafile"):
        raise Malformed("not a legacy VTK file (no '# vtk DataFile' line)")
    cur.line()  # title
    encoding = cur.line().upper()
    if encoding not in ("ASCII", "BINARY"):
        raise Malformed(f"the third line must be ASCII or BINARY, got {encoding!r}")
    dims = spacing = None
    origin = [0.0, 0.0, 0.0]
    npoints = None
    found = None
    seen = []
    while True:
        key = cur.token()
        if key is None:
            break
        key = key.upper()
        if key == "DATASET":
            kind = cur.need("the dataset type").upper()
            if kind != "STRUCTURED_POINTS":
                raise Malformed(f"DATASET {kind} is not supported (only STRUCTURED_POINTS)")
        elif key == "DIMENSIONS":
            dims = cur.numbers(3, "DIMENSIONS", int)
        elif key in ("SPACING", "ASPECT_RATIO"):
            spacing = cur.numbers(3, key)
        elif key == "ORIGIN":
            origin = cur.numbers(3, "ORIGIN")
        elif key == "POINT_DATA":
            (npoints,) = cur.numbers(1, "POINT_DATA", int)
        elif key in ("SCALARS", "VECTORS", "NORMALS"):
            if dims is None or npoints is None:
                raise Malformed(f"{key} comes before DIMENSIONS and POINT_DATA")
            name = cur.need(f"the {key} name")
            vtype = cur.need(f"the type of {name!r}").lower()
            if vtype not in _TYPES:
                raise Malformed(f"data type {vtype!r} of {name!r} is not one of {sorted(set(_TYPES))}")
            comps = 3
            if key == "SCALARS":
                save = cur.pos
                t = cur.token()
                comps = 1
                if t is not None and t.isdigit():
                    comps = int(t)
                else:
                    cur.pos = save
                save = cur.pos
                if (cur.token() or "").upper() == "LOOKUP_TABLE":
                    cur.token()
                else:
                    cur.pos = save
            dtype = np.dtype(_TYPES[vtype]).newbyteorder(">")
            shape = check_shape(path, dims, dtype)
            count = npoints * comps
            if npoints != shape[0] * shape[1] * shape[2]:
                raise Malformed(f"POINT_DATA {npoints} disagrees with DIMENSIONS {dims}")
            check_shape(path, (count, 1, 1), dtype)
            want = key == "SCALARS" and comps == 1 and (array is None or name == array) and found is None
            seen.append(name)
            if encoding == "BINARY":
                raw = cur.binary(count * dtype.itemsize, f"array {name!r}")
                values = np.frombuffer(raw, dtype) if want else None
            else:
                values = cur.ascii_values(count, np.dtype(dtype.newbyteorder("=")), f"array {name!r}")
            if want:
                found = (name, values, shape)
        elif key in ("CELL_DATA", "FIELD", "LOOKUP_TABLE", "COLOR_SCALARS", "TEXTURE_COORDINATES", "TENSORS"):
            if found is not None:
                break
            raise Malformed(f"section {key} is not supported before the point scalars")
        else:
            raise Malformed(f"unexpected keyword {key!r}")
        if found is not None and array is None:
            break
    if dims is None:
        raise Malformed("no DIMENSIONS")
    if found is None:
        raise Malformed(f"no point scalars named {array!r}; arrays: {seen}" if array else "no point scalars",
                        available_arrays=list(seen) if array else None)
    name, values, shape = found
    # x fastest in the file: a transposed view (Fortran order), converted
    # to native byte order in the one copy the file's buffer needs anyway.
    data = values.reshape(shape[::-1]).transpose(2, 1, 0)
    data = data.astype(data.dtype.newbyteorder("="), copy=not data.flags.owndata)
    sp = check_spacing(path, spacing if spacing is not None else [1.0, 1.0, 1.0])
    org = np.asarray(origin, np.float64)
    if not np.all(np.isfinite(org)):
        raise Malformed(f"ORIGIN {origin} is not finite")
    return GridImage(data, sp, org, Path(path).stem, "vtk", extra={"array": name})
