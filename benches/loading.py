"""Load time and peak memory of pyvr.load for a 256^3 volume in every
format it reads.

Each file is written first (with the format's own library, or by the
project's writer where the format is simple), then loaded in a fresh
process that has already imported pyvr and the format's library, so the
figures are the read alone: wall time of ``pyvr.load(path)`` (best of 3
runs) and the rise of the process's peak RSS during them (Linux's VmHWM,
reset before the first). The volume is the
Shepp–Logan phantom in Hounsfield-like int16 (-1000..1000; 32 MiB) except
where a format is float by nature (npy, zarr, vti: float32, 64 MiB).

Run: .venv/bin/python benches/loading.py [--size 256] [--json out/loading.json]
Table for docs/: .venv/bin/python tools/loading_table.py out/loading.json > docs/loading-benchmark.md
"""

import argparse
import json
import os
import platform
import struct
import subprocess
import sys
import tempfile
import zlib

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "examples"))
from _common import out_path  # noqa: E402

from pyvr.dataloaders import save_raw  # noqa: E402
from pyvr.datasets import shepp_logan_3d  # noqa: E402


def write_vti(path, data):
    raw = np.ascontiguousarray(data.transpose(2, 1, 0)).tobytes()
    block = 1 << 15
    comp = [zlib.compress(raw[i:i + block], 6) for i in range(0, len(raw), block)]
    head = struct.pack(f"<{3 + len(comp)}Q", len(comp), block, len(raw) % block, *(len(c) for c in comp))
    nx, ny, nz = data.shape
    ext = f"0 {nx - 1} 0 {ny - 1} 0 {nz - 1}"
    with open(path, "wb") as f:
        f.write((f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
                 f'header_type="UInt64" compressor="vtkZLibDataCompressor">\n<ImageData WholeExtent="{ext}" '
                 f'Origin="0 0 0" Spacing="0.5 0.5 0.8">\n<Piece Extent="{ext}"><PointData Scalars="d">'
                 f'<DataArray type="Float32" Name="d" format="appended" offset="0"/></PointData></Piece>\n'
                 f'</ImageData>\n<AppendedData encoding="raw">\n_').encode())
        f.write(head)
        for c in comp:
            f.write(c)
        f.write(b"\n</AppendedData>\n</VTKFile>\n")


def write_legacy_vtk(path, data):
    nx, ny, nz = data.shape
    with open(path, "wb") as f:
        f.write((f"# vtk DataFile Version 3.0\nphantom\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS {nx} {ny} {nz}\n"
                 f"SPACING 0.5 0.5 0.8\nORIGIN 0 0 0\nPOINT_DATA {data.size}\nSCALARS d short 1\n"
                 "LOOKUP_TABLE default\n").encode())
        f.write(np.ascontiguousarray(data.transpose(2, 1, 0)).astype(">i2").tobytes())
        f.write(b"\n")


def write_dicom(folder, data):
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    os.makedirs(folder)
    series = generate_uid()
    stored = (data.astype(np.int32) + 1024).astype(np.uint16)
    for k in range(data.shape[2]):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(os.path.join(folder, f"{k:04d}.dcm"), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.Modality, ds.SeriesInstanceUID, ds.SOPInstanceUID = "CT", series, meta.MediaStorageSOPInstanceUID
        ds.Rows, ds.Columns = data.shape[1], data.shape[0]
        ds.PixelSpacing = [0.5, 0.5]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [0, 0, 0.8 * k]
        ds.RescaleSlope, ds.RescaleIntercept = 1, -1024
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 0
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.PixelData = np.ascontiguousarray(stored[:, :, k].T).tobytes()
        ds.save_as(os.path.join(folder, f"{k:04d}.dcm"), enforce_file_format=True)


def write_all(folder, size):
    hu = (shepp_logan_3d(size) * 2000 - 1000).clip(-1000, 1000).astype(np.int16)
    f32 = hu.astype(np.float32)
    aff = np.diag([0.5, 0.5, 0.8, 1.0])
    files = {}

    def add(name, path, library=None):
        files[name] = {"path": path, "library": library, "bytes_on_disk": disk_size(path)}

    import nibabel as nib
    import nrrd
    import tifffile
    import zarr

    p = os.path.join(folder, "v.vti"); write_vti(p, f32); add("vti (zlib)", p)
    p = os.path.join(folder, "v.vtk"); write_legacy_vtk(p, hu); add("legacy vtk (binary)", p)
    p = os.path.join(folder, "v.raw"); save_raw(p, hu, spacing=(0.5, 0.5, 0.8), units="mm"); add("raw + .raw.info", p)
    p = os.path.join(folder, "v.npy"); np.save(p, f32); add("npy", p)
    p = os.path.join(folder, "v.nii"); nib.save(nib.Nifti1Image(hu, aff), p); add("NIfTI (.nii)", p, "nibabel")
    p = os.path.join(folder, "v.nii.gz"); nib.save(nib.Nifti1Image(hu, aff), p); add("NIfTI (.nii.gz)", p, "nibabel")
    p = os.path.join(folder, "v.nrrd")
    nrrd.write(p, hu, {"space directions": np.diag([0.5, 0.5, 0.8]), "encoding": "raw"}, index_order="F")
    add("NRRD (raw)", p, "nrrd")
    p = os.path.join(folder, "g.nrrd")
    nrrd.write(p, hu, {"space directions": np.diag([0.5, 0.5, 0.8]), "encoding": "gzip"}, index_order="F")
    add("NRRD (gzip)", p, "nrrd")
    p = os.path.join(folder, "dicom"); write_dicom(p, hu); add(f"DICOM ({size} slices)", p, "pydicom")
    p = os.path.join(folder, "v.tif")
    tifffile.imwrite(p, np.ascontiguousarray(hu.transpose(2, 1, 0)), imagej=True, metadata={"spacing": 0.8})
    add("TIFF stack", p, "tifffile")
    p = os.path.join(folder, "v.zarr")
    z = zarr.create_array(store=p, shape=f32.shape, chunks=(64, 64, 64), dtype="float32")
    z[...] = f32
    add("zarr (64^3 chunks)", p, "zarr")
    return files


def disk_size(path):
    if os.path.isdir(path):
        return sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(path) for f in fs)
    return os.path.getsize(path) + (os.path.getsize(path + ".info") if os.path.exists(path + ".info") else 0)


CHILD = r"""
import json, sys, time
import pyvr
lib = sys.argv[2]
if lib != "None":
    __import__(lib)
def status(key):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(key))
# ru_maxrss survives exec (it would report the parent's peak): reset the
# kernel's high-water mark instead and read VmHWM.
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")
base = status("VmRSS:")
times = []
for _ in range(3):
    t = time.perf_counter()
    v = pyvr.load(sys.argv[1])
    times.append(time.perf_counter() - t)
    shape, dtype, nbytes = v.data.shape, str(v.data.dtype), v.data.nbytes
    del v
peak = status("VmHWM:")
print(json.dumps({"seconds": min(times), "peak_rss_rise_mib": (peak - base) / 1024, "shape": shape,
                  "dtype": dtype, "array_mib": nbytes / 2**20}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--json", default=out_path("loading.json"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        files = write_all(folder, args.size)
        rows = []
        print(f"{'format':24s} {'on disk MiB':>11s} {'array':>16s} {'load s':>8s} {'peak RSS rise MiB':>18s}")
        for name, f in files.items():
            out = subprocess.run([sys.executable, "-c", CHILD, f["path"], str(f["library"])],
                                 capture_output=True, text=True, check=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            r.update(format=name, disk_mib=f["bytes_on_disk"] / 2**20)
            rows.append(r)
            print(f"{name:24s} {r['disk_mib']:11.1f} {r['dtype'] + ' ' + str(r['array_mib']) + ' MiB':>16s} "
                  f"{r['seconds']:8.3f} {r['peak_rss_rise_mib']:18.0f}")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=os.path.dirname(__file__)).stdout.strip()
    result = {"size": args.size, "machine": f"{platform.node()} ({os.cpu_count()} cores, {platform.machine()})",
              "commit": commit, "date": __import__("datetime").date.today().isoformat(), "rows": rows}
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)
    print(f"\njson: {os.path.normpath(args.json)}")


if __name__ == "__main__":
    main()
