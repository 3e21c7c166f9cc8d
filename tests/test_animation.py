"""Camera paths, render_path, save_animation, lights that follow the
camera, a renderer's notebook image, and the drag-quality policy."""

import io

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, save_animation
from pyvr.camera import Camera, CameraPath
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.interaction import SCALES, DragQuality
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

W, H = 48, 40


@pytest.fixture(scope="module")
def volume():
    d = create_sample_volume(32, "double_sphere")
    return Volume(d, compute_normal_volume(d), min_bounds=np.array([-1.0, -1, -1]), max_bounds=np.array([1.0, 1, 1]))


@pytest.fixture
def renderer(volume):
    r = VolumeRenderer(W, H, config=RenderConfig.fast().with_max_steps(200))
    r.load_volume(volume)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.3))
    r.set_camera(Camera.isometric_view())
    return r


def single(renderer, camera, **kw):
    renderer.set_camera(camera)
    return renderer.render(**kw)


# -- camera paths ----------------------------------------------------------------
def test_full_turn_keyframes_turn_a_full_circle():
    a = Camera(azimuth=0.0)
    b = Camera(azimuth=2 * np.pi)
    path = CameraPath([a, b])
    quarter = path.interpolate(0.25)
    assert quarter.azimuth == pytest.approx(np.pi / 2)
    p0, _ = a.get_camera_vectors()
    pq, _ = quarter.get_camera_vectors()
    assert np.linalg.norm(pq - p0) > 3.0  # a quarter turn at distance 3 moves the camera 3*sqrt(2)
    azs = [c.azimuth for c in path.generate_frames(5)]
    assert azs == pytest.approx([0, np.pi / 2, np.pi, 3 * np.pi / 2, 2 * np.pi])


def test_orbit_path_and_endpoint():
    start = Camera.isometric_view()
    path = CameraPath.orbit(start, turns=-0.5, keyframes=3)
    assert [k.azimuth for k in path.keyframes] == pytest.approx([np.pi / 4, -np.pi / 4, -3 * np.pi / 4])
    cams = path.cameras(4, endpoint=False)
    assert [c.azimuth for c in cams] == pytest.approx(np.pi / 4 - np.pi * np.arange(4) / 4)
    assert all(c.elevation == pytest.approx(np.pi / 6) for c in cams)
    with pytest.raises(ValueError, match="turns must be a finite non-zero number"):
        CameraPath.orbit(start, turns=0)
    with pytest.raises(TypeError, match="n_frames must be an integer"):
        path.cameras(2.5)


# -- render_path -----------------------------------------------------------------
def test_render_path_frames_match_single_renders(renderer):
    first, last = Camera.isometric_view(), Camera(azimuth=2.0, elevation=-0.3, distance=2.5)
    path = CameraPath([first, last])
    frames = list(renderer.render_path(path, 5, progress=False))
    assert len(frames) == 5 and all(f.shape == (H, W, 4) and f.dtype == np.uint8 for f in frames)
    assert np.array_equal(frames[0], single(renderer, first, origin="upper"))
    assert np.array_equal(frames[-1], single(renderer, last, origin="upper"))
    assert np.abs(frames[2].astype(int) - frames[0].astype(int)).max() > 20  # the middle differs


def test_render_path_restores_camera_and_light(renderer):
    own = Camera(azimuth=0.3)
    renderer.set_camera(own)
    renderer.set_light(Light.camera_linked())
    pos0 = renderer.get_light().position.copy()
    gen = renderer.render_path(CameraPath.orbit(own), 4, progress=False)
    next(gen)
    next(gen)
    gen.close()  # stopped half way (a break, or Ctrl-C)
    assert renderer.get_camera() is own
    np.testing.assert_allclose(renderer.get_light().position, pos0)
    assert np.array_equal(renderer.render(), single(renderer, own))


def test_render_path_linked_light_follows_each_frame(renderer):
    renderer.set_light(Light.camera_linked())
    cams = [Camera(azimuth=a) for a in (0.0, 1.5)]
    frames = list(renderer.render_path(cams, progress=False, origin="lower"))
    for cam, frame in zip(cams, frames):
        fixed = VolumeRenderer(W, H, config=renderer.get_config())
        fixed.load_volume(renderer.get_volume())
        fixed.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"),
                                     OpacityTransferFunction.linear(0.0, 0.3))
        pos, _ = cam.get_camera_vectors()
        fixed.set_light(Light(position=pos.astype(np.float32), target=cam.target))  # a headlight by hand
        fixed.set_camera(cam)
        assert np.array_equal(frame, fixed.render())


def test_render_path_checks_arguments_at_the_call(renderer):
    path = CameraPath([Camera(), Camera(azimuth=1.0)])
    with pytest.raises(TypeError, match="needs n_frames"):
        renderer.render_path(path)
    with pytest.raises(TypeError, match="path item 1 must be a Camera"):
        renderer.render_path([Camera(), "x"])
    with pytest.raises(TypeError, match="n_frames is for a CameraPath"):
        renderer.render_path([Camera()], 3)
    with pytest.raises(ValueError, match="n_frames must be at least 1"):
        renderer.render_path(path, 0)
    with pytest.raises(RuntimeError, match="no volume loaded"):
        VolumeRenderer(8, 8).render_path(path, 2)
    with pytest.raises(ValueError, match="origin must be"):
        renderer.render_path(path, 2, origin="left")
    with pytest.raises(ValueError, match="background must be three numbers"):
        renderer.render_path(path, 2, background=(2, 0, 0))


def test_render_path_progress_bar(renderer, capsys):
    list(renderer.render_path(CameraPath.orbit(Camera()), 3, progress=True))
    assert "3/3" in capsys.readouterr().err


# -- files -----------------------------------------------------------------------
def test_save_gif_and_mp4(renderer, tmp_path):
    import imageio.v2 as iio2
    import imageio.v3 as iio

    path = CameraPath.orbit(Camera.isometric_view())
    n = save_animation(renderer.render_path(path, 6, endpoint=False, progress=False), tmp_path / "o.gif", fps=10)
    gif = iio.imread(tmp_path / "o.gif", index=None)
    assert n == 6 and gif.shape == (6, H, W, 3)
    frames = list(renderer.render_path(path, 6, endpoint=False, progress=False))
    # GIF stores a palette; the first frame's colours stay near the render over black.
    ref = (frames[0][..., :3].astype(float) * frames[0][..., 3:4] / 255.0)
    assert np.abs(gif[0].astype(float) - ref).mean() < 6
    n = save_animation(iter(frames), tmp_path / "o.mp4", fps=np.float32(10))  # numpy numbers are numbers
    with iio2.get_reader(tmp_path / "o.mp4") as r:
        video = [f for f in r]
    assert n == 6 and len(video) == 6 and video[0].shape == (H, W, 3)  # even sizes pass unpadded
    assert np.abs(video[0].astype(float) - ref).mean() < 8  # lossy, but the same picture
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.gif", "o.mp4"]  # no partial files left


def test_save_animation_errors_leave_no_file(tmp_path):
    frames = [np.zeros((4, 4, 4), np.uint8), np.zeros((4, 6, 4), np.uint8)]
    with pytest.raises(ValueError, match="frame 1 has shape"):
        save_animation(frames, tmp_path / "bad.gif")
    with pytest.raises(ValueError, match="writes .gif, .mp4 files"):
        save_animation(frames, tmp_path / "bad.avi")
    with pytest.raises(ValueError, match="got no frames"):
        save_animation([], tmp_path / "empty.gif")
    for bad, exc, message in ((True, TypeError, "fps must be a number, got bool"),
                              (1e-300, ValueError, "fps must be from 0.001526 to 1000 frames per second"),
                              (float("nan"), ValueError, "fps must be from"), (0, ValueError, "fps must be from")):
        with pytest.raises(exc, match=message):
            save_animation(frames, tmp_path / "fps.gif", fps=bad)
    with pytest.raises(ValueError, match="loop must be at most 65535, got 100000"):
        save_animation(frames, tmp_path / "loop.gif", loop=100000)
    with pytest.raises(TypeError, match="loop must be an integer, got bool"):
        save_animation(frames, tmp_path / "loop.gif", loop=True)
    with pytest.raises(ValueError, match="uint8"):
        save_animation([np.zeros((4, 4, 4))], tmp_path / "f.gif")
    assert list(tmp_path.iterdir()) == []


def test_saves_to_one_path_from_two_threads_do_not_mix(tmp_path):
    """Each save writes its own temporary file: both succeed with their own
    frames, and the file is one of them whole."""
    import threading

    target = tmp_path / "same.gif"
    results = {}
    both_writing = threading.Barrier(2, timeout=30)
    partial_files = []

    def frame(value):
        f = np.full((16, 16, 4), value, np.uint8)
        f[..., 3] = 255  # opaque: the GIF holds the value itself
        return f

    def frames(level):
        for i in range(30):
            if i == 29:  # both saves are under way: each has a file of its own
                both_writing.wait()
                partial_files.append(len(list(tmp_path.glob(".same.gif.*partial.gif"))))
                both_writing.wait()  # both have counted before either finishes
            yield frame(level + i)

    def save(level):
        results[level] = save_animation(frames(level), target, fps=20)

    threads = [threading.Thread(target=save, args=(level,)) for level in (40, 220)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    import imageio.v3 as iio

    gif = iio.imread(target, index=None)
    assert partial_files == [2, 2]
    assert results == {40: 30, 220: 30} and gif.shape[0] == 30
    shown = gif[:, 0, 0, 0].astype(int)
    assert any(np.array_equal(shown, level + np.arange(30)) for level in (40, 220)), shown
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.gif"]


# -- lights that follow the camera -------------------------------------------------
def test_set_camera_moves_a_linked_light_with_its_offsets(renderer):
    light = Light.camera_linked(azimuth_offset=np.pi / 2, elevation_offset=0.2, distance_offset=1.0)
    renderer.set_light(light)
    cam = Camera(azimuth=0.4, elevation=0.1, distance=2.0)
    renderer.set_camera(cam)
    want = Camera(azimuth=0.4 + np.pi / 2, elevation=0.3, distance=3.0).get_camera_vectors()[0]
    np.testing.assert_allclose(light.position, want, atol=1e-5)
    np.testing.assert_allclose(light.target, cam.target)
    lit = renderer.render()
    light.unlink_from_camera()
    renderer.set_camera(Camera(azimuth=2.0))
    np.testing.assert_allclose(light.position, want, atol=1e-5)  # unlinked: stays
    assert renderer.render().tobytes() != lit.tobytes()


def test_linked_light_follows_the_default_camera(volume):
    r = VolumeRenderer(W, H)
    r.load_volume(volume)
    r.set_light(Light.camera_linked())
    r.render()
    pos, _ = Camera.fit(volume, aspect=W / H).get_camera_vectors()
    np.testing.assert_allclose(r.get_light().position, pos, atol=1e-5)


# -- notebooks: a renderer is an image ------------------------------------------------
def test_repr_png_is_the_current_frame(renderer):
    from PIL import Image

    png = renderer._repr_png_()
    img = np.array(Image.open(io.BytesIO(png)))
    assert img.shape == (H, W, 4)
    # Over white, as the notebook view shows it (tests/test_notebook.py).
    assert np.array_equal(img, renderer.render(origin="upper", background="white"))
    assert VolumeRenderer(8, 8)._repr_png_() is None  # nothing loaded: text repr


def test_render_size_and_config_leave_the_renderer_as_it_was(renderer):
    full = renderer.render()
    small = renderer.render(size=(24, 20), config=RenderConfig.preview().with_max_steps(100))
    assert small.shape == (20, 24, 4)
    assert np.array_equal(renderer.render(), full)
    assert renderer.get_config().step_size == 0.02
    with pytest.raises(ValueError, match="size width must be at least 1"):
        renderer.render(size=(0, 4))
    with pytest.raises(TypeError, match="size must be \\(width, height\\)"):
        renderer.render(size=5)


# -- the drag-quality policy ------------------------------------------------------------
def test_drag_quality_goes_coarser_over_budget_and_finer_under_it(renderer):
    q = DragQuality(renderer, target_fps=1e5)  # no frame meets 8 microseconds
    for _ in range(len(SCALES)):
        q.render_drag()
        q.record(q.last_render_seconds)
    assert q.level == len(SCALES) - 1 and q.size() == (round(W * SCALES[-1]), round(H * SCALES[-1]))
    q.target_fps = 1e-3  # any frame meets 800 seconds
    for _ in range(len(SCALES)):
        q.render_drag()
        q.record(q.last_render_seconds)
    assert q.level == 0 and q.size() == (W, H)
    cfg = q.config()
    # The drag step: the box diagonal over 96 samples, rays still crossing it.
    assert cfg.step_size == pytest.approx(2 * np.sqrt(3) / 96)
    assert cfg.max_steps * cfg.step_size >= 2 * np.sqrt(3)
    assert cfg.model == renderer.get_config().model


def test_drag_quality_start_predicts_from_measured_cost(renderer):
    q = DragQuality(renderer, target_fps=10)
    q._per_pixel = 0.08 / (W * H) / 0.25 * 1.01  # a full-size frame would take just over 4 budgets
    q.start()
    assert SCALES[q.level] == 0.375  # 0.5 of each side would take 1.01 budgets; 0.375 fits
    with pytest.raises(ValueError, match="target_fps must be a positive number"):
        DragQuality(renderer, target_fps=0)


def test_a_long_path_streams_its_cameras(renderer):
    """A billion-frame path starts at once: cameras are made as frames are
    rendered (building them all first would take hours and gigabytes)."""
    import time

    t = time.perf_counter()
    frames = renderer.render_path(CameraPath.orbit(Camera.isometric_view()), 10**9, progress=False)
    first = next(frames)
    frames.close()
    assert time.perf_counter() - t < 5.0
    assert np.array_equal(first, single(renderer, Camera.isometric_view(), origin="upper"))
