"""Runs one hostile case in a fresh process (the tests start it with limits,
signals or start methods of their own) and prints one line:
``OK <detail>`` or ``RAISED <ExceptionType>: <message>``. Dying any other
way (abort, segfault, hang) is what the tests look for."""

import os
import signal
import sys
import threading
import time
import warnings
from typing import Optional

import numpy as np

warnings.simplefilter("ignore")



def _status_kib(field: str) -> Optional[int]:
    """A memory field of /proc/self/status in KiB (None where there is none)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def peak_rss_mib() -> float:
    """This process's peak resident memory since it started this program.
    Linux carries ru_maxrss across exec, so a child forked from a large
    test process would report its parent's size; VmHWM is this image's own."""
    hwm = _status_kib("VmHWM")
    if hwm is not None:
        return hwm / 1024
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

def renderer(size=(32, 32)):
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    r = VolumeRenderer(*size)
    r.load_volume(Volume(np.random.RandomState(0).rand(24, 24, 24).astype(np.float32)))
    r.render()
    return r


def interrupted(work, after=1.0):
    """Runs ``work`` with a SIGINT sent ``after`` seconds in; prints how long
    past the signal it took to stop, or how long it took to finish."""
    # As at a terminal, whatever disposition the test runner passed down.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(after, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t = time.time()
    try:
        work()
        timer.cancel()
        print(f"OK finished {time.time() - t:.2f}")
    except KeyboardInterrupt:
        print(f"OK interrupted {time.time() - t - after:.2f}")
    return True


def case_lut_1e9():
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    renderer().set_transfer_functions(ColorTransferFunction(lut_size=10**9), OpacityTransferFunction())


def case_otf_2_40():
    from pyvr.transferfunctions import OpacityTransferFunction

    OpacityTransferFunction(lut_size=2**40).to_lut()


def case_size_2_40():
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    renderer().set_transfer_functions(ColorTransferFunction(), OpacityTransferFunction(), size=2**40)


def case_float64_20000():
    renderer().render_float64(size=(20000, 20000))


def case_core_float64_20000():
    # The core's own check, without the Python layer's.
    from pyvr import _core
    from pyvr._scene import _camera_tuple, _light_tuple
    from pyvr.camera import Camera
    from pyvr.lighting import Light
    from pyvr.config import RenderConfig

    lut = np.ones((4, 4), np.float32)
    _core.integrate_reference(np.zeros((4, 4, 4), np.float32), None, (-1, -1, -1), (1, 1, 1), lut,
                              _camera_tuple(Camera.front_view()), _light_tuple(Light.default()),
                              RenderConfig(), 20000, 20000)


def case_float16_4gib():
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    data = np.zeros((1024, 1024, 1024), np.float32)  # 4 GiB, pages untouched
    r = VolumeRenderer(16, 16)
    r.load_volume(Volume(data), precision="float16")
    return f"bricks {r.bricks['count']}"


def case_float16_3_75gib():
    # Under the device's upload limit as float16 (1.9 GiB), over what an
    # 8 GiB address space leaves once the 3.75 GiB array is mapped.
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    data = np.zeros((960, 1024, 1024), np.float32)
    VolumeRenderer(16, 16).load_volume(Volume(data), precision="float16")


def case_vti_bomb():
    # A 1 MiB file whose one zlib block inflates to 1 GiB, its header
    # claiming the 256 bytes the extent needs.
    import struct
    import tempfile
    import zlib

    from pyvr.dataloaders import load_vti

    bomb = zlib.compress(bytes(1 << 30), 9)
    path = os.path.join(tempfile.mkdtemp(), "bomb.vti")
    with open(path, "wb") as f:
        f.write(b'<?xml version="1.0"?><VTKFile type="ImageData" byte_order="LittleEndian" header_type="UInt32" '
                b'compressor="vtkZLibDataCompressor"><ImageData WholeExtent="0 3 0 3 0 3" Origin="0 0 0" '
                b'Spacing="1 1 1"><Piece Extent="0 3 0 3 0 3"><PointData Scalars="s"><DataArray type="Float32" '
                b'Name="s" format="appended" offset="0"/></PointData></Piece></ImageData>'
                b'<AppendedData encoding="raw">_' + struct.pack("<4I", 1, 256, 0, len(bomb)) + bomb
                + b"</AppendedData></VTKFile>")
    del bomb
    load_vti(path)


def case_broadcast_4096():
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    data = np.broadcast_to(np.float32(0.5), (4096, 4096, 4096))
    r = VolumeRenderer(16, 16)
    r.load_volume(Volume(data))
    return f"bricks {r.bricks['count']}"


def case_4096_4096_33():
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    r = VolumeRenderer(16, 16)
    r.load_volume(Volume(np.zeros((4096, 4096, 33), np.float32)))
    return f"bricks {r.bricks['count']}"


def case_sigint_gpu():
    from pyvr.config import RenderConfig

    r = renderer((64, 64))
    interrupted(lambda: r.render(config=RenderConfig(step_size=1e-7, max_steps=2**31 - 1, early_ray_termination=False)))
    r.render()  # still usable
    return True


def case_sigint_native():
    # max_steps within the native march's limit: on a CPU adapter this frame is the native march's.
    from pyvr.config import RenderConfig

    r = renderer((64, 64))
    interrupted(lambda: r.render(config=RenderConfig(step_size=1e-7, max_steps=2**30, early_ray_termination=False)))
    r.render()
    return True


def case_sigint_shadow_rays():
    # Each sample's shadow ray takes up to ~29000 samples (the renderer's
    # limit is 30000): minutes of work that Ctrl-C stops (on a CPU adapter
    # the native march's).
    from pyvr.config import RenderConfig
    from pyvr.lighting import Light
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    r = renderer((64, 64))
    # Faint: no shadow ray stops early at optical depth 16.
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.01))
    r.set_light(Light.directional([0.6, -0.3, 0.7], ambient=0.2, diffuse=0.8))
    cfg = RenderConfig.balanced().replace(model="single_scattering")
    r.render(config=cfg)
    engine = r.last_frame_stats["engine"]
    interrupted(lambda: r.render(config=cfg.replace(shadow_step_size=6e-5)))
    r.render(config=cfg)
    assert r.last_frame_stats["engine"] == engine
    return True


def case_sigint_float64():
    # With the progress bar (tqdm is installed with the test extras): the
    # KeyboardInterrupt may surface in the bar's update.
    r = renderer()
    return interrupted(lambda: r.render_float64(size=(6000, 6000), progress=True))


def case_sigint_float64_quiet():
    r = renderer()
    return interrupted(lambda: r.render_float64(size=(6000, 6000), progress=False))


def case_sigint_adaptive():
    r = renderer()
    return interrupted(lambda: r.render_float64(size=(48, 48), adaptive_tolerance=1e-12))


def case_fork_child_renders():
    r = renderer()
    ref = r.render()
    pid = os.fork()
    if pid == 0:
        from pyvr import VolumeRenderer

        same = int(np.abs(r.render().astype(int) - ref).max())
        fresh = VolumeRenderer(32, 32)
        fresh.load_volume(r.volume)
        other = int(np.abs(fresh.render().astype(int) - ref).max())
        os.write(1, f"OK child {same} {other}\n".encode())
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status) == 0 or print(f"RAISED ChildDied: {status}")


def _pool_job(i):
    return int(_GLOBAL.render().astype(int).sum())


def case_pool(method):
    import multiprocessing as mp

    global _GLOBAL
    _GLOBAL = renderer()
    ref = int(_GLOBAL.render().astype(int).sum())
    with mp.get_context(method).Pool(2, initializer=_init_worker) as pool:
        sums = pool.map(_pool_job, range(4))
    print(f"OK {method} {sorted(set(s - ref for s in sums))}")
    return True


def _init_worker():
    global _GLOBAL
    if "_GLOBAL" not in globals():  # spawn and forkserver start from nothing
        _GLOBAL = renderer()


def gl_scenes():
    """Frames of a few shader paths: lit emission-absorption with skipping,
    MIP, isosurface, float16 with normals."""
    from pyvr import RenderConfig
    from pyvr.lighting import Light
    from pyvr.volume import Volume

    from scenes import blob, frame, make_renderer

    data = blob((24, 20, 16), width=0.5)
    vol = Volume(data)
    vol.compute_normals()
    out = {}
    out["lit"] = frame(make_renderer(Volume(data), light=Light.directional([1, -1, 0.5])))
    out["mip"] = frame(make_renderer(Volume(data), config=RenderConfig().replace(model="mip")))
    out["iso"] = frame(make_renderer(Volume(data), config=RenderConfig().replace(model="isosurface", iso_value=0.4)))
    out["half"] = frame(make_renderer(vol, precision="float16", light=Light.directional([0, -1, -1])))
    return out


def case_gl_frames(path):
    os.environ["PYVR_BACKEND"] = "gl"
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
    frames = gl_scenes()
    from pyvr import _core

    np.savez(path, device=_core.device_info(), **frames)
    print("OK saved")
    return True


def case_memmap_stream(path, shape, budget_mib):
    """Peak memory of streaming a memmapped volume through a small budget,
    against the same process after a small frame (driver, pipelines)."""
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    # The same shader variants first (the driver's compiler takes memory of
    # its own the first time): bricks with and without empty cells.
    warm = np.random.RandomState(0).rand(32, 32, 32).astype(np.float32)
    warm[:16] = 0
    small = VolumeRenderer(128, 128, brick_shape=(16, 16, 16))
    small.load_volume(Volume(warm))
    small.render()
    base = peak_rss_mib()
    shape = tuple(int(v) for v in shape.split("x"))
    mm = np.memmap(path, dtype=np.float32, mode="r", shape=shape)
    r = VolumeRenderer(128, 128, brick_shape=(64, 64, 64), memory_budget=int(budget_mib) << 20)
    r.load_volume(Volume(mm))
    for _ in range(2):
        img = r.render()
    assert not r.bricks["resident"] and img[..., 3].max() > 0
    return f"base {base:.0f} bricks {r.bricks['count']} device {r.bricks['device_bytes'] >> 20}"


def case_fork_bricked():
    """A forked child renders with its parent's bricked renderer."""
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    data = np.random.RandomState(1).rand(30, 26, 22).astype(np.float32)
    r = VolumeRenderer(32, 32, brick_shape=(8, 8, 8))
    r.load_volume(Volume(data))
    want = r.render(dtype=np.float32)
    pid = os.fork()
    if pid == 0:
        got = r.render(dtype=np.float32)
        os._exit(0 if np.abs(got - want).max() < 1e-4 else 3)
    _, status = os.waitpid(pid, 0)
    return f"child {os.waitstatus_to_exitcode(status)}"


def case_xdg():
    os.environ.pop("XDG_RUNTIME_DIR", None)
    renderer()
    print("OK rendered")
    return True


def case_truncated_memmap(layout, path):
    """A memmap ("C", "F", or "view": every other slice of a C one) whose
    file is cut short after it was mapped, rendered in bricks: a clear
    error, never SIGBUS."""
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    shape, order = (48, 40, 36), "F" if layout == "F" else "C"
    mm = np.memmap(path, dtype=np.float32, mode="w+", shape=shape, order=order)
    mm[:] = np.random.RandomState(1).rand(*shape)
    mm.flush()
    del mm
    data = np.memmap(path, dtype=np.float32, mode="r", shape=shape, order=order)
    r = VolumeRenderer(32, 32, brick_shape=(16, 16, 16))
    r.load_volume(Volume(data[::2] if layout == "view" else data))
    os.truncate(path, 4096)
    r.render()
    return "rendered"


def case_replaced_memmap(path):
    """A memmap's file saved over (a new file renamed onto its path) after
    loading: frames keep showing the mapped volume, not the new file."""
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    shape = (96, 80, 72)
    np.random.RandomState(1).rand(*shape).astype(np.float32).tofile(path)
    data = np.memmap(path, dtype=np.float32, mode="r", shape=shape)
    # Over the budget: bricks are read again for every frame.
    r = VolumeRenderer(32, 32, brick_shape=(16, 16, 16), memory_budget=1 << 20)
    r.load_volume(Volume(data))
    before = r.render()
    assert not r.bricks["resident"]
    np.zeros(shape, np.float32).tofile(path + ".new")
    os.replace(path + ".new", path)
    after = r.render()
    return "the same frame" if np.array_equal(before, after) else "a different frame"


def _nrrd_header(sizes="4 4 4", encoding="raw", extra=""):
    return (f"NRRD0004\ntype: float\ndimension: 3\nsizes: {sizes}\nencoding: {encoding}\n"
            f"endian: little\n{extra}\n").encode()


def case_nrrd(kind, folder):
    """A hostile NRRD of ``kind`` written in ``folder``, then loaded."""
    from pyvr.dataloaders import load_nrrd

    os.makedirs(os.path.join(folder, "scan"), exist_ok=True)
    header = os.path.join(folder, "scan", "h.nhdr")
    values = np.arange(64, dtype="<f4")
    secret = os.path.join(folder, "secret.raw")
    values.tofile(secret)
    options = {}
    if kind in ("parent", "parent_allowed"):
        body = _nrrd_header(extra="data file: ../secret.raw\n")
        options = {"data_outside_folder": True} if kind == "parent_allowed" else {}
    elif kind == "absolute":
        body = _nrrd_header(extra=f"data file: {secret}\n")
    elif kind == "tail_of_any_file":
        body = _nrrd_header(sizes="2 2 2", extra="data file: /etc/passwd\nbyte skip: -1\n")
    elif kind == "same_folder":
        values.tofile(os.path.join(folder, "scan", "d.raw"))
        body = _nrrd_header(extra="data file: d.raw\n")
    elif kind == "line_skip":
        header = os.path.join(folder, "scan", "h.nrrd")
        body = _nrrd_header(extra="line skip: 99999999999\n") + b"\x00" * 40
    elif kind == "gzip_bomb":  # about 1 MB of gzip inflating to 1 GiB, for 1000 voxels
        import zlib

        header = os.path.join(folder, "scan", "h.nrrd")
        deflate = zlib.compressobj(9, zlib.DEFLATED, zlib.MAX_WBITS | 16)
        zeros = bytes(1 << 24)
        bomb = b"".join(deflate.compress(zeros) for _ in range(64)) + deflate.flush()
        body = _nrrd_header(sizes="10 10 10", encoding="gzip") + bomb
    elif kind == "raw_short":
        header = os.path.join(folder, "scan", "h.nrrd")
        body = _nrrd_header(sizes="400 400 400") + bytes(1000)
    elif kind == "nan_directions":
        header = os.path.join(folder, "scan", "h.nrrd")
        body = (_nrrd_header(extra="space: right-anterior-superior\n"
                             "space directions: (nan,0,0) (0,1,0) (0,0,1)\n") + values.tobytes())
    else:
        raise ValueError(kind)
    with open(header, "wb") as f:
        f.write(body)
    image = load_nrrd(header, **options)
    return f"loaded {image.data.shape} sum {float(np.sum(image.data)):.0f}"


def _two_state_renderer():
    """A small renderer and two transfer-function states that give
    different frames."""
    from pyvr import RenderConfig, VolumeRenderer
    from pyvr.camera import Camera
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
    from pyvr.volume import Volume

    x = np.linspace(-1, 1, 24, dtype=np.float32)
    data = np.exp(-4 * (x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)).astype(np.float32)
    r = VolumeRenderer(40, 32, config=RenderConfig.fast())
    r.load_volume(Volume(data))
    r.set_camera(Camera.isometric_view())
    states = [(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.5)),
              (ColorTransferFunction.from_colormap("magma"), OpacityTransferFunction.linear(0.2, 1.0))]
    return r, states


def case_accumulate_race(rounds):
    """render(accumulate=n) in one thread while another switches transfer
    functions and cameras: every mean must be one state's mean."""
    from pyvr.camera import Camera

    r, states = _two_state_renderer()
    cams = [Camera.isometric_view(), Camera.front_view()]
    expected = []
    for tf in states:
        for cam in cams:
            r.set_transfer_functions(*tf)
            r.set_camera(cam)
            expected.append(r.render(accumulate=6))
    stop = threading.Event()

    def switch():
        k = 0
        while not stop.is_set():
            r.set_transfer_functions(*states[k % 2])
            r.set_camera(cams[(k // 2) % 2])
            k += 1

    t = threading.Thread(target=switch)
    t.start()
    try:
        means = [r.render(accumulate=6) for _ in range(int(rounds))]
    finally:
        stop.set()
        t.join(timeout=60)
    mixed = sum(not any(np.array_equal(m, e) for e in expected) for m in means)
    return f"{mixed} of {len(means)} means mixed states"


def case_interleaved_paths():
    """Two render_path generators advanced in turn: each frame is its own
    camera's, and between frames the renderer keeps the user's camera."""
    from pyvr.camera import Camera

    r, states = _two_state_renderer()
    r.set_transfer_functions(*states[0])
    own = Camera.isometric_view()
    r.set_camera(own)
    paths = ([Camera.front_view(), Camera.side_view(), Camera.top_view()],
             [Camera.from_spherical(np.zeros(3, np.float32), a, 0.3, 0.0, 3.0) for a in (0.5, 1.0, 1.5)])
    gens = [r.render_path(p, origin="lower", progress=False) for p in paths]
    frames = [[], []]
    for _ in range(3):
        for i, g in enumerate(gens):
            frames[i].append(next(g))
            if r.get_camera() is not own:
                return "the renderer's camera changed between frames"
    wrong = 0
    for cams, imgs in zip(paths, frames):
        for cam, img in zip(cams, imgs):
            r.set_camera(cam)
            wrong += not np.array_equal(img, r.render())
    r.set_camera(own)
    for g in gens:
        g.close()
    return f"{wrong} of 6 frames wrong, camera kept: {r.get_camera() is own}"


def case_growth(kind, calls):
    """Resident memory per call, after a warm-up, of what the interface does
    on every drag (a transfer-function change, then a frame) or of reloads."""
    import gc

    from pyvr import VolumeRenderer
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
    from pyvr.volume import Volume

    r = VolumeRenderer(48, 40)
    data = np.random.default_rng(0).random((24, 24, 24), np.float32)
    r.load_volume(Volume(data))
    ctf = ColorTransferFunction.from_colormap("viridis")

    def call(k):
        if kind == "tf":
            r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.1 + (k % 7) * 0.01))
            r.render()
        else:
            r.load_volume(Volume(data))
            r.set_transfer_functions(ctf, OpacityTransferFunction.linear(0.0, 0.1 + (k % 7) * 0.01))

    for k in range(300):
        call(k)
    gc.collect()
    before = _status_kib("VmRSS")
    n = int(calls)
    for k in range(n):
        call(k)
    gc.collect()
    return f"{(_status_kib('VmRSS') - before) / n:.2f} KiB per call"


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(__file__))
    try:
        done = globals()["case_" + sys.argv[1]](*sys.argv[2:])
        if isinstance(done, str):
            print(f"OK {done}")
        elif not done:
            print("OK returned")
    except BaseException as e:
        print(f"RAISED {type(e).__name__}: {str(e)[:300]}")
    print(f"PEAK_RSS_MIB {peak_rss_mib():.0f}")
