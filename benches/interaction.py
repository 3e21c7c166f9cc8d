"""Event-to-pixels latency of the interactive views while dragging and
after release, for 128^3 and 256^3 volumes in a 512x512 view.

The matplotlib interface runs on Agg with synthesized events on the real
figure: each mouse-move event is timed from its dispatch until its frame
is in the figure's pixels (render, then a blit of the image axes); the
release from dispatch until the full-quality frame and a full figure
redraw are done. Every event renders (the interface's 0.05 s throttle is
off), so frames per second while dragging is 1 / mean drag latency.

The drag frame's cost in accuracy is its difference from the full frame
at the same camera (over black, stretched to the view as displayed), in
8-bit levels over the pixels either frame covers: mean and 99th percentile.

The notebook view (jupyter_rfb) is timed from the event to the frame
compressed as jupyter_rfb sends it (JPEG while dragging, PNG after
release); the trip to the browser is not included.

Run: .venv/bin/python benches/interaction.py [--moves 30] [--json out/interaction.json]
Table for docs/: .venv/bin/python tools/interaction_table.py out/interaction.json > docs/interaction-benchmark.md
"""

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
import warnings

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.backend_bases import MouseEvent  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "examples"))
from _common import out_path  # noqa: E402

from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.interface import InteractiveVolumeRenderer  # noqa: E402
from pyvr.interface.matplotlib_interface import _crossing  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

VIEW = 512
# Opacity control points: the interface's default ramp (translucent: every
# ray crosses the whole box) and one that shows two solid-looking spheres
# (rays end early).
TFS = {"ramp": [(0.0, 0.0), (1.0, 1.0)], "solid": [(0.0, 0.0), (0.2, 0.0), (0.5, 0.6), (1.0, 0.9)]}


def scene(n):
    d = create_sample_volume(n, "double_sphere")
    return Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]), max_bounds=np.array([1.0, 1, 1]))


def ms(v):
    return 1e3 * float(v)


def dispatch(canvas, name, x, y):
    ev = MouseEvent(name, canvas, x, y, button=1)
    t = time.perf_counter()
    canvas.callbacks.process(name, ev)
    return time.perf_counter() - t


def drag_error(small, full):
    """How far a drag frame, stretched to the view as the display does
    (bilinear), is from the full-quality frame: 8-bit levels over RGB."""
    from PIL import Image

    h, w = full.shape[:2]
    big = np.asarray(Image.fromarray(small[..., :3]).resize((w, h), Image.BILINEAR), np.float64)
    ref = full[..., :3].astype(np.float64)
    covered = (ref.max(axis=2) > 0) | (big.max(axis=2) > 0)  # the volume's pixels, not the empty background
    d = np.abs(big - ref)[covered]
    return dict(drag_error_mean=float(d.mean()), drag_error_p99=float(np.percentile(d, 99)))


def matplotlib_row(volume, preset, tf, moves):
    config = _crossing(getattr(RenderConfig, preset)(), volume)
    ui = InteractiveVolumeRenderer(volume, width=VIEW, height=VIEW, config=config)
    ui._min_render_interval = 0.0
    ui.state.control_points = list(TFS[tf])
    ui.state.set_colormap("plasma")
    fig = ui._build_figure()
    fig.canvas.draw()
    ax = ui.image_display.ax
    cx, cy = ax.transAxes.transform((0.5, 0.5))
    canvas = fig.canvas

    def drag(n):
        dispatch(canvas, "button_press_event", cx, cy)
        lat = [dispatch(canvas, "motion_notify_event", cx + 4 * (i + 1), cy) for i in range(n)]
        frame = ui.image_display.image.get_array().shape
        release = dispatch(canvas, "button_release_event", cx + 4 * n, cy)
        return lat, frame, release

    drag(8)  # warm-up: pipelines, and the policy settles on a scale
    lat, frame, _ = drag(moves)
    releases = [drag(2)[2] for _ in range(3)]
    t = time.perf_counter()
    ref = ui.renderer.render(origin="upper", background=(0, 0, 0))
    full = time.perf_counter() - t
    err = drag_error(ui.drag_quality.render_drag(origin="upper", background=(0, 0, 0)), ref)
    row = dict(view="matplotlib", preset=preset, drag_ms_median=ms(np.median(lat)), drag_ms_p90=ms(np.percentile(lat, 90)),
               drag_fps=1.0 / float(np.mean(lat)), drag_frame=f"{frame[1]}x{frame[0]}",
               drag_step=ui.drag_quality.config().step_size, release_ms_median=ms(np.median(releases)),
               full_render_ms=ms(full), step=config.step_size, **err)
    matplotlib.pyplot.close(fig)
    return row


def notebook_row(volume, preset, tf, moves):
    from jupyter_rfb._utils import array2compressed

    from pyvr.notebook import VolumeView

    r = VolumeRenderer(VIEW, VIEW, config=_crossing(getattr(RenderConfig, preset)(), volume))
    r.load_volume(volume)
    r.set_camera(Camera.isometric_view())
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction(control_points=TFS[tf]))
    view = VolumeView(r)

    def event(e, quality):
        t = time.perf_counter()
        view.handle_event(e)
        array2compressed(view.get_frame(), quality)
        return time.perf_counter() - t

    def drag(n):
        view.handle_event({"type": "pointer_down", "x": 256, "y": 256, "button": 1})
        lat = [event({"type": "pointer_move", "x": 256 + 4 * (i + 1), "y": 256, "button": 1}, view.quality)
               for i in range(n)]
        frame = view.drag_quality.size()
        release = event({"type": "pointer_up", "x": 256 + 4 * n, "y": 256, "button": 1}, 100)
        return lat, frame, release

    drag(8)
    lat, frame, _ = drag(moves)
    releases = [drag(2)[2] for _ in range(3)]
    view.close()
    return dict(view="notebook", preset=preset, drag_ms_median=ms(np.median(lat)), drag_ms_p90=ms(np.percentile(lat, 90)),
                drag_fps=1.0 / float(np.mean(lat)), drag_frame=f"{frame[0]}x{frame[1]}",
                drag_step=view.drag_quality.config().step_size, release_ms_median=ms(np.median(releases)),
                full_render_ms=float("nan"), step=r.get_config().step_size)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=30)
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--json", default=out_path("interaction.json"))
    args = ap.parse_args()
    warnings.simplefilter("ignore", UserWarning)
    rows = []
    device = VolumeRenderer(8, 8).device
    print(f"device: {device}; view {VIEW}x{VIEW}; latencies in ms (median, 90th percentile)")
    print(f"{'volume':>7} {'tf':>5} {'view':>10} {'preset':>8} | {'drag':>6} {'p90':>6} {'fps':>5} {'drag frame':>10} "
          f"{'step':>6} | {'release':>7} {'full render':>11}")
    for n in args.sizes:
        volume = scene(n)
        for tf, fn, preset in (("ramp", matplotlib_row, "fast"), ("ramp", matplotlib_row, "balanced"),
                               ("ramp", notebook_row, "fast"), ("solid", matplotlib_row, "balanced"),
                               ("solid", notebook_row, "fast")):
            row = dict(volume=n, tf=tf, **fn(volume, preset, tf, args.moves))
            rows.append(row)
            print(f"{n:>6}^3 {tf:>5} {row['view']:>10} {preset:>8} | {row['drag_ms_median']:6.1f} {row['drag_ms_p90']:6.1f} "
                  f"{row['drag_fps']:5.1f} {row['drag_frame']:>10} {row['drag_step']:6.4f} | "
                  f"{row['release_ms_median']:7.1f} {row['full_render_ms']:11.1f}"
                  + (f" | error {row['drag_error_mean']:.1f} / {row['drag_error_p99']:.0f}" if "drag_error_mean" in row else ""))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=os.path.dirname(__file__)).stdout.strip()
    result = {"view": VIEW, "moves": args.moves, "device": device,
              "machine": f"{platform.node()} ({os.cpu_count()} cores, {platform.machine()})",
              "commit": commit, "date": datetime.date.today().isoformat(), "rows": rows}
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)
    print(f"\njson: {os.path.normpath(args.json)}")


if __name__ == "__main__":
    main()
