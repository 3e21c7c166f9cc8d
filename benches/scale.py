"""Volumes past one texture, host memory and one process: time per frame and
peak memory per process for one texture, resident bricks, out-of-core
streaming from a memmapped file, and a dask.distributed LocalCluster (1 and
2 worker processes) reading a zarr store, on synthetic float32 volumes of
256^3 to 1024^3 (and optionally one larger file, out-of-core only).

Every case runs in a fresh process (peak RSS is per process; a cluster
case reports its largest worker, the client's own peak beside it). Frames
are 512^2 at the balanced preset, timed warm: one frame first, then the
median of three.

    .venv/bin/python benches/scale.py [--sizes 256,512,1024] [--largest 2048] [--dir DIR]

Writes out/scale.json (tools/docs_tables.py puts it into docs/scale.md).
"""

import argparse
import functools
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

SIZE = (512, 512)
BRICK = (256, 256, 256)
BOX = (np.array([-1, -1, -1], np.float32), np.array([1, 1, 1], np.float32))


@functools.lru_cache(maxsize=1)
def plane(n: int):
    c = ((np.arange(n) + 0.5) / n * 2 - 1).astype(np.float32)
    return np.meshgrid(c, c, indexing="ij")


def field_slab(n: int, i: int) -> np.ndarray:
    """Slab i of the synthetic field: a torus and a ball with a soft shell,
    zero around them (so bricks can be skipped)."""
    x = np.float32((i + 0.5) / n * 2 - 1)
    y, z = plane(n)
    ring = np.sqrt(x * x + y * y) - 0.55
    torus = np.maximum(0, 1 - np.sqrt(ring * ring + z * z) / 0.25)
    ball = np.maximum(0, 1 - np.sqrt((x - 0.2) ** 2 + (y + 0.1) ** 2 + (z - 0.3) ** 2) / 0.3)
    return (0.8 * torus + ball * (0.6 + 0.4 * np.cos(12 * z))).astype(np.float32)


def make_data(folder: str, n: int, zarr_too: bool) -> dict:
    # Written and read with plain file calls, never through a mapping: a
    # case's process starts from this one, and Linux keeps a process's peak
    # resident size across exec, so mapped pages here would count in every
    # case's peak (a 1024^3 file written through a memmap made the next
    # out-of-core case report 4.3 GiB for its 0.4).
    raw = os.path.join(folder, f"field_{n}.raw")
    if not os.path.exists(raw):
        with open(raw + ".part", "wb") as f:
            for i in range(n):
                f.write(field_slab(n, i).tobytes())
        os.rename(raw + ".part", raw)
    out = {"raw": raw}
    if zarr_too:
        import zarr

        store = os.path.join(folder, f"field_{n}.zarr")
        if not os.path.exists(store):
            # Uncompressed: the benchmark times reading and rendering, not zstd.
            if hasattr(zarr, "create_array"):
                z = zarr.create_array(store + ".part", shape=(n, n, n), chunks=BRICK, dtype="f4", compressors=None)
            else:
                z = zarr.open_array(store + ".part", mode="w", shape=(n, n, n), chunks=BRICK, dtype="f4",
                                    compressor=None)
            step = BRICK[0]
            for i in range(0, n, step):
                slab = np.fromfile(raw, dtype=np.float32, count=step * n * n, offset=i * n * n * 4)
                z[i:i + step] = slab.reshape(step, n, n)
            os.rename(store + ".part", store)
        out["zarr"] = store
    return out


def renderer(**kw):
    from pyvr import RenderConfig, VolumeRenderer
    from pyvr.camera import Camera
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    r = VolumeRenderer(*SIZE, config=RenderConfig.balanced(), **kw)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                             OpacityTransferFunction.linear(0.05, 0.6))
    r.set_camera(Camera.from_spherical(np.zeros(3), 0.6, 0.45, 0.0, 3.2))
    return r


def timed(frame, repeats: int = 3) -> dict:
    t = time.perf_counter()
    frame()
    first = time.perf_counter() - t
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        frame()
        times.append(time.perf_counter() - t)
    return {"first_ms": first * 1e3, "frame_ms": statistics.median(times) * 1e3}


def peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def case(mode: str, n: int, raw: str, store: str, workers: int) -> dict:
    from pyvr.volume import Volume

    shape = (n, n, n)
    if mode in ("single", "bricked"):
        data = np.fromfile(raw, dtype=np.float32).reshape(shape)
        # Resident bricks: a budget that holds them all.
        r = renderer(**({"brick_shape": BRICK, "memory_budget": 2 * data.nbytes} if mode == "bricked" else {}))
        r.load_volume(Volume(data, min_bounds=BOX[0], max_bounds=BOX[1]))
        res = timed(r.render)
        res["bricks"] = 0 if r.bricks is None else r.bricks["count"]
        assert mode == "single" or r.bricks["resident"]
    elif mode == "out_of_core":
        mm = np.memmap(raw, dtype=np.float32, mode="r", shape=shape)
        budget = n ** 3  # a quarter of the volume's float32 bytes
        r = renderer(brick_shape=BRICK, memory_budget=budget)
        r.load_volume(Volume(mm, min_bounds=BOX[0], max_bounds=BOX[1]))
        # A file larger than memory is timed once after its first frame.
        res = timed(r.render, 3 if n <= 1024 else 1)
        assert not r.bricks["resident"]
        res["bricks"] = r.bricks["count"]
        res["budget_mib"] = budget / 2**20
    else:
        import dask.array as da
        import distributed

        import pyvr.distributed

        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                           dashboard_address=None, memory_limit=0)
        client = distributed.Client(cluster)
        try:
            r = renderer(brick_shape=BRICK)
            vol = Volume(da.from_zarr(store), min_bounds=BOX[0], max_bounds=BOX[1])
            res = timed(lambda: pyvr.distributed.render(r, vol, client))
            res["worker_peak_mib"] = max(client.run(peak_mib).values())
            res["bricks"] = int(np.prod([-(-n // b) for b in BRICK]))
        finally:
            client.close()
            cluster.close()
    res["peak_mib"] = peak_mib()
    return res


def run_case(mode, n, data, workers=0) -> dict:
    args = [sys.executable, __file__, "--case", mode, str(n), data["raw"], data.get("zarr", ""), str(workers)]
    p = subprocess.run(args, capture_output=True, text=True)
    line = [l for l in p.stdout.splitlines() if l.startswith("RESULT ")]
    if p.returncode != 0 or not line:
        return {"error": (p.stderr.strip().splitlines() or ["died"])[-1][:200]}
    return json.loads(line[0][7:])


def label_of(mode: str, workers: int) -> str:
    return mode if mode != "cluster" else f"LocalCluster, {workers} worker{'s' if workers > 1 else ''}"


def models(results: list, cores: int) -> dict:
    """Predicted frame times, (n, mode, workers) -> ms, from two models:

    - size: T(N) = a + b N^3 per path (rendering at a fixed step costs the
      same at any N; reading, converting and uploading scale with the
      voxels), fitted on the two smallest sizes and predicting the rest;
    - workers: T(P) = T_dev + T_host / min(P, C). The device's part (the
      ray marching, which lavapipe spreads over all C cores, so workers on
      one machine share it) is the resident-bricks frame of the same size;
      the rest of the one-worker frame (reading chunks, ghost slabs,
      uploads, combines, scheduling) runs on one core per worker.
    """
    ok = {(r["n"], r["mode"], r["workers"]): r["res"]["frame_ms"] for r in results if "frame_ms" in r["res"]}
    pred = {}
    for mode, workers in {(m, w) for _, m, w in ok}:
        sizes = sorted(n for n, m, w in ok if (m, w) == (mode, workers))
        if len(sizes) >= 3:
            (n0, n1) = sizes[:2]
            t0, t1 = ok[(n0, mode, workers)], ok[(n1, mode, workers)]
            b = (t1 - t0) / (n1 ** 3 - n0 ** 3)
            for n in sizes[2:]:
                pred[(n, mode, workers)] = ("size", t0 + b * (n ** 3 - n0 ** 3))
    for (n, mode, workers), _t in ok.items():
        one, dev = ok.get((n, "cluster", 1)), ok.get((n, "bricked", 0))
        if mode == "cluster" and workers > 1 and one is not None and dev is not None:
            pred[(n, mode, workers)] = ("workers", dev + max(one - dev, 0.0) / min(workers, cores))
    return pred


def table(results: list, command: str) -> None:
    from _report import write_table

    pred = models(results, os.cpu_count() or 1)
    rows = []
    for r in results:
        n, mode, workers, res = r["n"], r["mode"], r["workers"], r["res"]
        label = label_of(mode, workers)
        gib = n ** 3 * 4 / 2**30
        if "error" in res:
            rows.append([f"{n}^3", f"{gib:.3g}", label, "-", "-", "-", "-", "-", res["error"]])
            continue
        count = res.get("bricks", 0)
        note = f"{count} brick{'s' if count != 1 else ''}" if count else "one texture"
        if "budget_mib" in res:
            note += f", device budget {res['budget_mib']:.0f} MiB"
        if "worker_peak_mib" in res:
            note += f", client process {res['peak_mib']:.0f} MiB"
        peak = res.get("worker_peak_mib", res["peak_mib"])
        model = pred.get((n, mode, workers))
        rows.append([f"{n}^3", f"{gib:.3g}", label, round(res["first_ms"]), round(res["frame_ms"]),
                     "-" if model is None else f"{model[1]:.0f} ({model[0]})",
                     round(n ** 3 / (res["frame_ms"] / 1e3) / 1e6), round(peak), note])
    write_table(
        "scale", command,
        ["volume", "GiB (float32)", "path", "first frame (ms)", "frame (ms, warm median)", "model (ms)",
         "Mvoxels/s", "peak RSS per process (MiB)", "notes"],
        rows,
        note="512^2, balanced preset, synthetic torus + ball in [-1, 1]^3; bricks of 256^3 (+ ghosts). "
             "Out-of-core reads a raw memmapped file under a device budget of a quarter of the volume; "
             "the cluster reads an uncompressed zarr store (chunks 256^3) on this machine's cores. Frames: one, "
             "then the median of three (of one past 1024^3). Model: see docs/scale.md (size: fitted on the two "
             "smallest sizes of the same path; workers: from the one-worker and resident-bricks rows).",
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="256,512,1024")
    ap.add_argument("--largest", type=int, default=0, help="one more size, out-of-core only")
    ap.add_argument("--dir", default=os.path.join(tempfile.gettempdir(), "pyvr_scale"))
    ap.add_argument("--table-only", action="store_true", help="rebuild out/scale.json from out/scale_raw.json")
    ap.add_argument("--case", nargs=5)
    a = ap.parse_args()
    if a.case:
        mode, n, raw, store, workers = a.case
        print("RESULT " + json.dumps(case(mode, int(n), raw, store, int(workers))), flush=True)
        return
    from _report import OUT
    from pyvr.renderer import device_limits

    command = "benches/scale.py" + (f" --sizes {a.sizes}" if a.sizes != "256,512,1024" else "") \
        + (f" --largest {a.largest}" if a.largest else "")
    raw_path = os.path.join(OUT, "scale_raw.json")
    if a.table_only:
        with open(raw_path) as f:
            saved = json.load(f)
        table(saved["results"], saved["command"])
        return
    os.makedirs(a.dir, exist_ok=True)
    limits = device_limits()
    sizes = [int(s) for s in a.sizes.split(",")]
    plan = [(n, m, w) for n in sizes for m, w in
            (("single", 0), ("bricked", 0), ("out_of_core", 0), ("cluster", 1), ("cluster", 2))]
    if a.largest:
        plan.append((a.largest, "out_of_core", 0))
    results = []
    for n, mode, workers in plan:
        data = make_data(a.dir, n, zarr_too=mode == "cluster")
        if mode == "single" and (n ** 3 * 4 > limits["max_buffer_size"] or n > limits["max_texture_dimension_3d"]):
            res = {"error": f"over the device's {limits['max_buffer_size'] >> 20} MiB upload limit"}
        else:
            res = run_case(mode, n, data, workers)
        print(n, label_of(mode, workers), res, flush=True)
        results.append({"n": n, "mode": mode, "workers": workers, "res": res})
        os.makedirs(OUT, exist_ok=True)
        with open(raw_path, "w") as f:
            json.dump({"command": command, "results": results}, f, indent=1)
    table(results, command)


if __name__ == "__main__":
    main()
