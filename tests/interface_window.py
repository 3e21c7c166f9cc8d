"""Run by test_interface.py under Xvfb: the interface in a real Tk window,
with matplotlib's own timers. Drags, scrolls, waits for the scroll to
settle, closes the window and prints what it saw as JSON."""

import json
import sys
import time

import matplotlib

matplotlib.use("TkAgg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backend_bases import MouseEvent  # noqa: E402

from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.interface import InteractiveVolumeRenderer  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

d = create_sample_volume(48, "double_sphere")
ui = InteractiveVolumeRenderer(Volume(d, compute_normal_volume(d)), width=128, height=128)
ui._min_render_interval = 0.0
ui.drag_quality.target_fps = 1e5  # coarsest drag frames, whatever the machine
seen = {}


def play():
    c = ui.fig.canvas
    x, y = ui.image_display.ax.transAxes.transform((0.5, 0.5))
    c.callbacks.process("button_press_event", MouseEvent("button_press_event", c, x, y, button=1))
    for i in range(4):
        c.callbacks.process("motion_notify_event", MouseEvent("motion_notify_event", c, x + 20 * (i + 1), y, button=1))
        c.flush_events()
    seen["drag_frame"] = list(ui.image_display.image.get_array().shape)
    c.callbacks.process("button_release_event", MouseEvent("button_release_event", c, x + 80, y, button=1))
    seen["release_frame"] = list(ui.image_display.image.get_array().shape)
    c.callbacks.process("scroll_event", MouseEvent("scroll_event", c, x, y, button="up", step=1))
    seen["scroll_frame"] = list(ui.image_display.image.get_array().shape)
    seen["scrolled_at"] = time.perf_counter()
    done = c.new_timer(interval=1500)  # the interface settles 500 ms after the scroll
    done.single_shot = True
    done.add_callback(finish)
    done.start()


def finish():
    seen["settled_frame"] = list(ui.image_display.image.get_array().shape)
    seen["drawn"] = ui._drawn
    seen["azimuth"] = float(ui.camera_controller.params.azimuth)
    plt.close(ui.fig)


ui._build_figure()
start = ui.fig.canvas.new_timer(interval=300)
start.single_shot = True
start.add_callback(play)
start.start()
plt.show()
print(json.dumps(seen))
sys.exit(0)
