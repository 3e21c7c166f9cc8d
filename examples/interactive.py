"""Explore a volume in pyvr's matplotlib window: drag to rotate, scroll to
zoom, click the opacity curve to shape the transfer function.

Opens ../shared/data/fuel.vti (a real 64^3 simulation) when present, else a
synthetic 128^3 volume. Keys: r reset view, s save image, f frame rate,
h histogram, l light follows camera, q auto-quality (cheap frames while
dragging) on/off, t trackball/orbit, esc deselect, delete remove point;
close the window (or ctrl+w) to quit.

Run: .venv/bin/python examples/interactive.py [file] [--screenshot PNG]
With --screenshot nothing opens: the window is built headless, a drag and
an opacity edit are played on it, and the figure is saved.
"""

import argparse
import os

import numpy as np

FUEL = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "fuel.vti")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", default=FUEL if os.path.exists(FUEL) else None)
    ap.add_argument("--screenshot", help="save the window, made headless, to this PNG and exit")
    args = ap.parse_args()
    if args.screenshot:
        import matplotlib

        matplotlib.use("Agg")
    import pyvr
    from pyvr import RenderConfig
    from pyvr.camera import Camera
    from pyvr.datasets import compute_normal_volume, create_sample_volume
    from pyvr.interface import InteractiveVolumeRenderer
    from pyvr.volume import Volume

    if args.path:
        volume = pyvr.load(args.path)
    else:
        d = create_sample_volume(128, "double_sphere")
        volume = Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]),
                        max_bounds=np.array([1.0, 1, 1]))
    camera = Camera.fit(volume, azimuth=0.6, elevation=0.4)
    camera.distance *= 0.6
    ui = InteractiveVolumeRenderer(volume, width=512, height=512, config=RenderConfig.balanced(), camera=camera)
    ui.state.control_points = [(0.0, 0.0), (0.03, 0.0), (0.15, 0.5), (1.0, 1.0)]
    ui.state.set_colormap("turbo")
    if not args.screenshot:
        print(__doc__.split("\n\n")[1])
        ui.show()
        return
    from matplotlib.backend_bases import MouseEvent

    fig = ui._build_figure()
    fig.canvas.draw()
    ax = ui.image_display.ax
    x, y = ax.transAxes.transform((0.5, 0.5))
    for name, dx in (("button_press_event", 0), ("motion_notify_event", 40), ("button_release_event", 40)):
        fig.canvas.callbacks.process(name, MouseEvent(name, fig.canvas, x + dx, y, button=1))
    fig.savefig(args.screenshot, dpi=80)
    print(f"wrote {args.screenshot}")


if __name__ == "__main__":
    main()
