"""
The interactive window
======================

Explore a volume in pyvr's matplotlib window: drag to rotate, scroll to
zoom, click the opacity curve to shape the transfer function.

Opens fuel.vti (a real 64^3 simulation, shipped with pyvr) or the file given. Keys: r reset view, s save image, f frame rate,
h histogram, l light follows camera, q auto-quality (cheap frames while
dragging) on/off, t trackball/orbit, esc deselect, delete remove point;
close the window (or ctrl+w) to quit.

Run: .venv/bin/python examples/interactive.py [file] [--screenshot PNG]
With --screenshot nothing opens: the window is built headless, a drag and
an opacity edit are played on it, and the figure is saved.
"""

import argparse




KEYS = """Drag to rotate, scroll to zoom, click the opacity curve to edit it. Keys: r reset view, s save image,
f frame rate, h histogram, l light follows camera, q auto-quality, t trackball/orbit, esc deselect,
delete remove point; close the window (or ctrl+w) to quit."""


def main():
    ap = argparse.ArgumentParser(description="Explore a volume in pyvr's matplotlib window.")
    ap.add_argument("path", nargs="?", help="a volume file for pyvr.load (default: fuel.vti)")
    ap.add_argument("--screenshot", help="save the window, made headless, to this PNG and exit")
    args = ap.parse_args()
    import matplotlib

    if args.screenshot:
        matplotlib.use("Agg")
    else:
        import matplotlib.pyplot  # noqa: F401  (resolves the automatic backend)

        if matplotlib.get_backend().lower() in ("agg", "cairo", "pdf", "pgf", "ps", "svg", "template"):
            # No display (an SSH session, a container): show() would return at once and nothing appear.
            raise SystemExit(f"no window can open here (matplotlib's backend is {matplotlib.get_backend()!r}: "
                             "no display). Run with --screenshot out/interface.png to save the window as a "
                             "picture, use pyvr.notebook.VolumeView in Jupyter, or set DISPLAY.")
    import pyvr
    from pyvr import RenderConfig
    from pyvr.camera import Camera
    from pyvr.interface import InteractiveVolumeRenderer

    volume = pyvr.load(args.path) if args.path else pyvr.datasets.fuel()
    camera = Camera.fit(volume, azimuth=0.6, elevation=0.4)
    camera.distance *= 0.6
    ui = InteractiveVolumeRenderer(volume, width=512, height=512, config=RenderConfig.balanced(), camera=camera)
    ui.state.control_points = [(0.0, 0.0), (0.03, 0.0), (0.15, 0.5), (1.0, 1.0)]
    ui.state.set_colormap("turbo")
    if not args.screenshot:
        print(KEYS)
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
