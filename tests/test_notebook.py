"""The notebook view (jupyter_rfb) and the example notebook run top to
bottom in a real kernel, its images checked."""

import base64
import io
import os
import re
import sys

import numpy as np
import pytest

from conftest import SHARED_DATA
from pyvr import VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import create_sample_volume
from pyvr.lighting import Light
from pyvr.notebook import NOTEBOOK_BACKGROUND, VolumeView
from pyvr.volume import Volume

EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "examples", "notebook.ipynb")


@pytest.fixture
def renderer():
    r = VolumeRenderer(96, 80)
    r.load_volume(Volume(create_sample_volume(32, "double_sphere")))
    r.set_camera(Camera.isometric_view())
    return r


def test_view_drag_is_cheap_then_full(renderer):
    view = VolumeView(renderer)
    view.drag_quality.target_fps = 1e5  # no frame meets the budget: coarsest drag frames
    first = view.draw()
    az0 = view.camera.azimuth
    view.handle_event({"type": "pointer_down", "x": 40, "y": 40, "button": 1})
    view.handle_event({"type": "pointer_move", "x": 70, "y": 40, "button": 1})
    during = view.draw()
    assert view.camera.azimuth < az0 - 0.1
    assert during.shape[0] < 80
    view.handle_event({"type": "pointer_up", "x": 70, "y": 40, "button": 1})
    after = view.draw()
    assert after.shape == (80, 96, 4)
    assert np.abs(after.astype(int) - first.astype(int)).max() > 20
    assert len(view.drag_latencies) == 1 and len(view.release_latencies) == 1
    assert np.array_equal(view.snapshot().data, after)
    # The renderer shows the view's camera now.
    assert renderer.get_camera() is view.camera


def test_drag_sensitivity_follows_the_shown_size(renderer):
    """The same drag across the same fraction of the view turns the camera
    as much, whatever size the browser shows the view at."""
    turns = []
    for width, dx in ((96, 30), (192, 60)):
        view = VolumeView(renderer)
        view.handle_event({"type": "resize", "width": width, "height": width * 80 // 96, "pixel_ratio": 1.0})
        az0 = view.camera.azimuth
        view.handle_event({"type": "pointer_down", "x": 10, "y": 10, "button": 1})
        view.handle_event({"type": "pointer_move", "x": 10 + dx, "y": 10, "button": 1})
        turns.append(view.camera.azimuth - az0)
    assert turns[0] == pytest.approx(turns[1], rel=1e-6) and abs(turns[0]) > 0.1


def test_view_wheel_zooms_and_linked_light_follows(renderer):
    renderer.set_light(Light.camera_linked())
    view = VolumeView(renderer)
    d0 = view.camera.distance
    view.handle_event({"type": "wheel", "dx": 0, "dy": -100, "x": 10, "y": 10})
    assert view.camera.distance == pytest.approx(0.9 * d0)
    view.draw()
    pos, _ = view.camera.get_camera_vectors()
    np.testing.assert_allclose(renderer.get_light().position, pos, atol=1e-5)
    view._scroll_settled()  # what the 0.5 s timer calls
    assert view.draw().shape == (80, 96, 4)


def test_the_o_key_switches_the_views_projection(renderer):
    view = VolumeView(renderer)
    perspective = view.draw()
    view.handle_event({"type": "key_down", "key": "o", "modifiers": []})
    assert view.camera.projection == "orthographic"
    ortho = view.draw()
    assert np.abs(ortho.astype(int) - perspective.astype(int)).max() > 10
    assert np.array_equal(ortho, renderer.render(origin="upper", background=NOTEBOOK_BACKGROUND))
    view.handle_event({"type": "key_down", "key": "o", "modifiers": []})
    assert np.array_equal(view.draw(), perspective)


def test_a_double_click_turns_the_view_about_the_point_under_it(renderer):
    view = VolumeView(renderer)
    view.draw()
    view.handle_event({"type": "resize", "width": 96, "height": 80, "pixel_ratio": 1.0})
    offset = view.camera.get_camera_vectors()[0] - view.camera.target
    picked = renderer.pick(48, 40)  # the middle of the view, rows from the bottom
    assert picked.hit
    view.handle_event({"type": "double_click", "x": 48.5, "y": 39.5, "button": 1, "modifiers": []})
    np.testing.assert_allclose(view.camera.target, picked.position, atol=1e-5)
    np.testing.assert_allclose(view.camera.get_camera_vectors()[0] - view.camera.target, offset, atol=1e-4)
    view.handle_event({"type": "double_click", "x": 1, "y": 1, "button": 1, "modifiers": []})  # nothing there
    np.testing.assert_allclose(view.camera.target, picked.position, atol=1e-5)


def test_view_rejects_bad_input():
    with pytest.raises(TypeError, match="Expected VolumeRenderer"):
        VolumeView("r")
    with pytest.raises(RuntimeError, match="no volume loaded"):
        VolumeView(VolumeRenderer(8, 8))


def test_a_view_that_fails_to_build_is_collected_quietly(renderer, monkeypatch):
    # Arguments checked once the widget object exists (the refinement
    # count, the widget's own traits) leave it half built; collecting it
    # closes it, which must not raise (Python would print the error after
    # the one the user was shown).
    import gc
    import sys

    from traitlets import TraitError

    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    for kwargs, error in [({"refine_frames": -1}, ValueError), ({"css_width": 5}, TraitError),
                          ({"target_fps": 0}, ValueError)]:
        with pytest.raises(error):
            VolumeView(renderer, **kwargs)
        gc.collect()
    assert [str(u.exc_value) for u in unraisable] == []


def _image(data: bytes):
    from PIL import Image

    img = Image.open(io.BytesIO(data))
    return img.size, np.array(img.convert("RGBA"))


def test_example_notebook_runs_in_a_kernel(tmp_path, monkeypatch):
    import nbformat
    from nbclient import NotebookClient

    monkeypatch.setenv("PYVR_DATA", SHARED_DATA)
    nb = nbformat.read(EXAMPLE, as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    pngs = [base64.b64decode(o.data["image/png"]) for o in outputs if "image/png" in o.get("data", {})]
    assert len(pngs) == 1  # the renderer, shown as its frame
    size, img = _image(pngs[0])
    assert size == (384, 384)
    assert (img[..., 3] > 0).mean() > 0.05 and img[..., :3].std() > 10  # not blank
    # The view's snapshot after the drag: an <img> holding the full-size frame.
    html = [o.data["text/html"] for o in outputs if "text/html" in o.get("data", {})]
    m = re.search(r"base64,([^']+)'", html[0])
    snap_size, snap = _image(base64.b64decode(m.group(1)))
    assert snap_size == (384, 384) and snap[..., :3].std() > 10
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "while dragging: (" in text and "after release: (384, 384, 4)" in text
    assert "24 frames" in text
    gifs = [o for o in outputs if "image/gif" in o.get("data", {})]
    assert len(gifs) == 1 and (tmp_path / "orbit.gif").stat().st_size > 1000
    assert os.path.exists(os.path.join(SHARED_DATA, "fuel.vti")) == ("fuel" in repr(nb.cells[1].outputs[0].data))


def test_view_refines_while_it_stands_still(renderer):
    # Narrow opacity peaks, where unbiased means beat the midpoint frame.
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    renderer.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                    OpacityTransferFunction.peaks([0.3, 0.6], opacity=0.5, eps=0.03))
    view = VolumeView(renderer, refine_frames=6)
    first = view.draw()
    assert np.array_equal(first, renderer.render(origin="upper", background="white"))
    shown = [view.draw() for _ in range(6)]
    # Refinement frames 1-3 keep the full frame on show; from 4 on, the
    # running mean, which is render(accumulate=k); after 6 nothing more is
    # rendered.
    assert all(np.array_equal(img, first) for img in shown[:3])
    for k, img in zip(range(4, 7), shown[3:]):
        assert np.array_equal(img, renderer.render(origin="upper", background="white", accumulate=k)), k
    assert not np.array_equal(shown[-1], first)
    frames_before = renderer.counters()["frames"]
    assert np.array_equal(view.draw(), shown[-1]) and view.refinement.count == 6
    assert renderer.counters()["frames"] == frames_before
    # A change of the scene starts over from a full frame.
    renderer.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                    OpacityTransferFunction.peaks([0.5], opacity=0.5, eps=0.03))
    again = view.draw()
    assert view.refinement.count == 0 and np.array_equal(again, renderer.render(origin="upper", background="white"))
    # So does a drag.
    for _ in range(4):
        view.draw()
    assert view.refinement.count == 4
    view.handle_event({"type": "pointer_down", "x": 40, "y": 40, "button": 1})
    view.handle_event({"type": "pointer_move", "x": 50, "y": 40, "button": 1})
    view.draw()
    view.handle_event({"type": "pointer_up", "x": 50, "y": 40, "button": 1})
    view.draw()
    assert view.refinement.count == 0
    with pytest.raises(ValueError, match="refine_frames"):
        VolumeView(renderer, refine_frames=-1)


def test_the_view_and_the_still_show_the_same_visible_picture(monkeypatch):
    # The notebook's first picture with the defaults (no transfer functions
    # set, no camera): the live view's frames lose their alpha on the way to
    # the browser, so both are composited over one background. Over black the
    # default grey ramp is near invisible (the spheres' pixels 6 levels from
    # the page on average, here); over white they are 106 levels from it.
    from PIL import Image

    r = VolumeRenderer(96, 80)
    r.load_volume(Volume(create_sample_volume(32, "double_sphere")))
    view = VolumeView(r)
    live = view.draw()
    still = np.array(Image.open(io.BytesIO(r._repr_png_())))
    assert np.array_equal(live, still)
    assert (live[..., 3] == 255).all()
    covered = r.render(origin="upper")[..., 3] > 0
    contrast = np.abs(live[..., :3].astype(int) - 255).mean(axis=-1)[covered].mean()
    over_black = r.render(origin="upper", background="black")[..., :3].astype(int).mean(axis=-1)[covered].mean()
    assert contrast > 80 and over_black < 10, (contrast, over_black)
    # Colour names need matplotlib; the default does not.
    with monkeypatch.context() as m:
        m.setitem(sys.modules, "matplotlib", None)
        assert np.array_equal(VolumeView(r).draw(), live)
        assert np.array_equal(np.array(Image.open(io.BytesIO(r._repr_png_()))), still)
    # Colours by name or RGB; no background at all is refused, naming why.
    assert VolumeView(r, background=(0, 0, 0)).draw()[..., :3].max() < 255
    for bad in (None, "none"):
        with pytest.raises(ValueError, match="without alpha"):
            VolumeView(r, background=bad)
    with pytest.raises(ValueError, match="not a colour name"):
        VolumeView(r, background="no-such-colour")
