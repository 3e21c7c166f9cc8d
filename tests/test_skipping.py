"""Empty-space skipping: only samples of opacity exactly 0 are skipped, so
images equal the unskipped ones (tolerance 1/255; measured far below), while
the samples taken per ray fall with the empty fraction."""

import numpy as np
import pytest

from scenes import make_renderer
from pyvr import RenderConfig
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume


def both(volume, otf, light=None, config=None, camera=None, native=True):
    out = []
    for skip in (False, True):
        r = make_renderer(volume, config=config, light=light, camera=camera or Camera.isometric_view(distance=2.5),
                          ctf=ColorTransferFunction.from_colormap("plasma"), otf=otf, skip=skip)
        r.native_march = r.native_march and native
        out.append((r.render(dtype=np.float32, premultiplied=True), r.last_frame_stats["samples"], r))
    return out


SCENES = {
    # sparse: a helix, opaque only above 0.5
    "sparse_one_step": (lambda: Volume(create_sample_volume(64, "helix")),
                        lambda: OpacityTransferFunction.one_step(0.5, 0.0, 0.6)),
    # narrow band: zero except a peak around 0.7
    "narrow_band": (lambda: Volume(create_sample_volume(64, "torus")),
                    lambda: OpacityTransferFunction.peaks([0.7], opacity=0.8, eps=0.02)),
    # dense: every cell visible, nothing to skip
    "dense": (lambda: Volume(np.random.default_rng(0).random((40, 40, 40), dtype=np.float32)),
              lambda: OpacityTransferFunction.linear(0.05, 0.3)),
    # sparse with normals and a non-cubic box
    "sparse_normals": (lambda: (lambda d: Volume(d, compute_normal_volume(d), np.array([-1, -0.5, -0.8], np.float32),
                                                 np.array([1, 0.5, 0.8], np.float32)))(
                           create_sample_volume(48, "double_sphere")[:, :, 8:40]),
                       lambda: OpacityTransferFunction([(0.0, 0.0), (0.3, 0.0), (0.6, 0.5), (1.0, 0.9)])),
    # cells cut short at the far faces (dims not multiples of 8), stretched voxels
    "odd_dims": (lambda: Volume(np.ascontiguousarray(create_sample_volume(64, "torus")[:61, 3:56, 10:55]), None,
                                np.array([-1.0, -0.4, -0.7], np.float32), np.array([1.0, 0.4, 0.7], np.float32)),
                 lambda: OpacityTransferFunction.peaks([0.5, 0.8], opacity=0.7, eps=0.03)),
}


@pytest.mark.parametrize("name", SCENES)
def test_skipping_does_not_change_the_image(name):
    vol_f, otf_f = SCENES[name]
    (plain, n_plain, _), (skipped, n_skip, r) = both(vol_f(), otf_f())
    assert plain[..., 3].max() > 0.3
    assert np.abs(plain - skipped).max() < 1 / 255
    print(f"{name}: empty cells {r.empty_fraction():.2f}, samples {n_plain} -> {n_skip}")
    if name == "dense":
        assert r.empty_fraction() == 0.0 and n_skip == n_plain
    else:
        assert r.empty_fraction() > 0.2 and n_skip < 0.8 * n_plain


@pytest.mark.parametrize("name", ["sparse_one_step", "narrow_band", "sparse_normals", "odd_dims"])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_pre_integration_skips_too_and_keeps_the_image(name, order):
    vol_f, otf_f = SCENES[name]
    cfg = RenderConfig.balanced().replace(pre_integrated=True, order=order)
    (plain, n_plain, _), (skipped, n_skip, r) = both(vol_f(), otf_f(), config=cfg)
    assert plain[..., 3].max() > 0.3
    assert np.abs(plain - skipped).max() < 1 / 255
    assert n_skip < 0.8 * n_plain, (n_plain, n_skip)


@pytest.mark.parametrize("native", [True, False])
def test_pre_integrated_frames_leap_from_cells_own_ranges(native):
    # Leaps over segments inside empty cubes whole, from the cells' own
    # ranges: at a step of 5 voxels of this 64^3 volume a pre-integrated
    # frame took 1.54x the samples of a plain one (632); with ranges widened
    # to whatever a segment centred in a cell could reach, 2.34x.
    vol_f, otf_f = SCENES["narrow_band"]
    cfg = RenderConfig.balanced().replace(step_size=0.08)
    (_, _, _), (plain, n_plain, _) = both(vol_f(), otf_f(), config=cfg, native=native)
    (_, _, _), (pre, n_pre, _) = both(vol_f(), otf_f(), config=cfg.replace(pre_integrated=True), native=native)
    assert pre[..., 3].max() > 0.3
    assert n_pre < 1.8 * n_plain, (n_plain, n_pre)


@pytest.mark.parametrize("start, step", [(41, 0.006), (41, 0.02), (41, 0.04), (44, 0.07), (41, 0.14)])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
def test_pre_integrated_leaps_keep_ramps_across_a_jump(start, step, order):
    # A cube of 1 in 0 with only 0.3 visible: cells holding one value are
    # empty, yet a pre-integrated segment that starts in one of them and
    # ends across the cube's face ramps through 0.3. Only segments inside
    # empty cells whole may be leapt over: one centred in an empty cell may
    # not (leaping over those made the frames differ by 54-77 levels). Faces
    # at voxel 41 sit 1.5 voxels past the last empty 8-voxel cell, at 44 4.5
    # voxels past it; the steps reach from under half a voxel of this 128^3
    # volume (0.006) to over a cell (0.14: 9 voxels).
    d = np.zeros((128, 128, 128), np.float32)
    d[start:87, start:87, start:87] = 1.0
    otf = OpacityTransferFunction.peaks([0.3], opacity=1.0, eps=0.05)
    cfg = RenderConfig(step_size=step, max_steps=400, pre_integrated=True, order=order,
                       early_ray_termination=order == "front_to_back")
    camera = Camera(target=np.zeros(3, np.float32), azimuth=0.3, elevation=0.2, distance=2.5)
    (plain, n_plain, _), (skipped, n_skip, r) = both(Volume(d), otf, config=cfg, light=Light.ambient_only(1.0),
                                                     camera=camera)
    assert plain[..., 3].max() > 0.4
    assert np.abs(plain - skipped).max() < 1 / 255
    # At 0.14 a ray takes a few samples, and a segment a cell long is
    # seldom inside an empty cube whole.
    assert n_skip < (0.85 if step > 0.1 else 0.7) * n_plain, (n_plain, n_skip)


@pytest.mark.parametrize("pre", [False, True])
@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_rays_march_only_where_they_cross_the_occupied_box(pre, order, side):
    # Visible voxels fill a corner: their cells' box touches three faces of
    # the volume. Seen from that corner rays enter through those faces, from
    # the opposite one they leave through them; with jitter the chord's first
    # and last segments are shorter, and may be centred in the box while
    # their nominal midpoints are not. Rays march from where they enter the
    # box to where they leave it, or not at all where they miss it. The box
    # is 3, 2 and 5 cells long along numpy's axes, so that one whose axes
    # were taken in the wrong order would cut the object.
    d = np.zeros((64, 64, 64), np.float32)
    d[:21, :11, :37] = np.linspace(0.2, 1.0, 37, dtype=np.float32)
    otf = OpacityTransferFunction.linear(0.0, 0.5)
    camera = Camera(target=np.zeros(3, np.float32), azimuth=0.6 + np.pi if side > 0 else 0.6,
                    elevation=-0.5 * side, distance=2.4)
    cfg = RenderConfig(step_size=0.023, max_steps=400, jitter=True, jitter_seed=7, pre_integrated=pre, order=order,
                       early_ray_termination=False)
    (plain, n_plain, _), (skipped, n_skip, r) = both(Volume(d), otf, config=cfg, camera=camera,
                                                     light=Light.ambient_only(1.0))
    assert plain[..., 3].max() > 0.3
    assert np.abs(plain - skipped).max() < 1 / 255
    # Measured 0.04-0.10 of the samples.
    assert n_skip < 0.2 * n_plain, (n_plain, n_skip)


def test_empty_transfer_function_takes_almost_no_samples():
    vol = Volume(create_sample_volume(64, "sphere"))
    (img_plain, n_plain, _), (img, n_skip, r) = both(vol, OpacityTransferFunction.linear(0.0, 0.0))
    assert not img.any() and not img_plain.any()
    assert r.empty_fraction() == 1.0
    # No cell is visible: no ray is marched at all.
    assert n_skip == 0 and r.last_frame_stats["passes"] == 0 and n_plain > 10_000


def test_leaps_cross_whole_empty_cubes():
    # Visible only in one corner: a ray in the rest of the box leaves the
    # whole empty cube around its cell (2r - 1 cells a side for empty radius
    # r) in one leap. Measured 0.066 of the unskipped samples; leaps over
    # single cells of 8-64 voxels (the mip pyramid this replaced) took 0.103.
    d = create_sample_volume(64, "sphere")
    d[:8, :8, :8] = 1.0
    (img_plain, n_plain, _), (img, n_skip, r) = both(Volume(d), OpacityTransferFunction.one_step(0.99, 0.0, 0.5))
    assert np.abs(img - img_plain).max() < 1 / 255 and img[..., 3].max() > 0.3
    assert r.empty_fraction() > 0.9
    assert n_skip < 0.08 * n_plain


@pytest.mark.shader
def test_skipping_with_multi_pass_rays_and_truncation():
    cfg = RenderConfig(step_size=2e-5, max_steps=40_000, early_ray_termination=False)
    vol = Volume(create_sample_volume(32, "helix"))
    otf = OpacityTransferFunction.one_step(0.5, 0.0, 0.01)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # Passes are the shader's (the native march needs none).
        (plain, n_plain, rp), (skipped, n_skip, r) = both(vol, otf, config=cfg, light=Light.ambient_only(1.0),
                                                          native=False)
    assert r.last_frame_stats["passes"] > 1
    assert np.abs(plain - skipped).max() < 1 / 255
    assert n_skip < n_plain


def test_skipping_is_left_off_where_few_cells_are_empty():
    # Leaps make every sample dearer (README: 25% on lavapipe with 19% of
    # cells empty), so under a quarter of empty cells the plain loop runs.
    d = np.random.default_rng(1).random((64, 64, 64), dtype=np.float32) * 0.9 + 0.1
    d[:40, :40, :40] = 0.0  # 4^3 of the 8^3 cells stay empty (their neighbours read into them)
    (plain, n_plain, _), (skipped, n_skip, r) = both(Volume(d), OpacityTransferFunction.linear(0.0, 0.3))
    assert 0.05 < r.empty_fraction() < 0.25
    assert n_skip == n_plain and np.array_equal(plain, skipped)


def test_grids_kept_for_alternating_frames_follow_every_change():
    # Plain and pre-integrated frames leap over grids of different ranges;
    # the renderer keeps both, so frames alternating between them upload
    # nothing but their uniforms. A new table, value range or volume makes
    # other cells visible: kept grids must then go, or frames would leap
    # over what now shows.
    data = create_sample_volume(64, "torus")
    cmap = ColorTransferFunction.from_colormap("plasma")
    otf = OpacityTransferFunction.peaks([0.5], opacity=0.8, eps=0.03)
    plain = RenderConfig(step_size=0.05, max_steps=100, early_ray_termination=False)
    pre = plain.replace(pre_integrated=True)

    def check(volume, table, value_range):
        f = make_renderer(Volume(volume), ctf=cmap, otf=table, value_range=value_range, light=Light.ambient_only(1.0))
        for cfg in (pre, plain, pre, plain):
            want = f.render(dtype=np.float32, premultiplied=True, config=cfg)
            got = r.render(dtype=np.float32, premultiplied=True, config=cfg)
            assert want[..., 3].max() > 0.2
            assert np.abs(got - want).max() < 1e-4, (value_range, cfg.pre_integrated)

    r = make_renderer(Volume(data), ctf=cmap, otf=otf, light=Light.ambient_only(1.0))
    check(data, otf, None)
    for cfg in (plain, pre, plain, pre):
        r.render(dtype=np.float32, premultiplied=True, config=cfg)
        assert r.last_frame_stats["uploaded_bytes"] < 512
    # A new table and value range.
    r.set_transfer_functions(cmap, otf, value_range=(0.0, 0.6))
    check(data, otf, (0.0, 0.6))
    # A new volume under the same table and value range.
    shifted = np.ascontiguousarray(np.roll(data, 5, axis=1))
    r.load_volume(Volume(shifted))
    check(shifted, otf, (0.0, 0.6))


@pytest.mark.shader
def test_preintegration_tables_kept_for_other_steps_follow_the_table():
    # Pre-integrated frames at another step need another table; the
    # renderer keeps the last few, so a session switching steps (a coarse
    # one while the view moves, a step search's pilots) swaps them back in
    # without rebuilding or uploading. They are the table's only while it
    # lasts: a new transfer function must rebuild, or frames would show
    # the old one's colours.
    data = create_sample_volume(48, "torus")
    cmap = ColorTransferFunction.from_colormap("plasma")
    first = OpacityTransferFunction.peaks([0.5], opacity=0.8, eps=0.03)
    r = make_renderer(Volume(data), ctf=cmap, otf=first, light=Light.ambient_only(1.0))
    # On the shader: the native march reads the table's texels, and its
    # frames upload no texture.
    r.native_march = False
    steps = [0.05, 0.03, 0.02, 0.07, 0.04]
    pre = {h: RenderConfig(step_size=h, max_steps=200, early_ray_termination=False, pre_integrated=True) for h in steps}

    def frame(h):
        img = r.render(dtype=np.float32, premultiplied=True, config=pre[h])
        return img, r.last_frame_stats["uploaded_bytes"]

    built = {h: frame(h) for h in steps[:2]}
    assert min(b for _, b in built.values()) > 100_000  # 256 x 259 texels
    for h in (0.05, 0.03, 0.05):
        img, uploaded = frame(h)
        assert uploaded < 512 and np.array_equal(img, built[h][0]), h
    # Three tables are kept besides the current one: after three more
    # steps the least recent (0.03) is rebuilt, the same as before.
    for h in steps[2:]:
        frame(h)
    img, uploaded = frame(0.03)
    assert uploaded > 100_000 and np.array_equal(img, built[0.03][0])
    # A new table: every step's table is rebuilt from it.
    second = OpacityTransferFunction.peaks([0.3], opacity=0.8, eps=0.03)
    r.set_transfer_functions(cmap, second)
    fresh = make_renderer(Volume(data), ctf=cmap, otf=second, light=Light.ambient_only(1.0))
    fresh.native_march = False
    for h in (0.04, 0.05):
        img, uploaded = frame(h)
        want = fresh.render(dtype=np.float32, premultiplied=True, config=pre[h])
        assert uploaded > 100_000 and np.abs(img - want).max() < 1e-6 and want[..., 3].max() > 0.2, h
    # A 4096-entry transfer function: the table stays 512 wide (its rows of
    # the transfer function wrapped, 4.4 MB of f32 texels where rows as
    # wide as the transfer function took 34), and is kept as well.
    long_ctf, long_otf = ColorTransferFunction.from_colormap("plasma"), second
    long_ctf.lut_size = long_otf.lut_size = 4096
    r.set_transfer_functions(long_ctf, long_otf)
    uploads = [frame(h)[1] for h in (0.04, 0.05, 0.04)]
    assert 1 << 20 < uploads[0] < 5 << 20 and uploads[2] < 512, uploads
    # The native march reads the texels: its frames build a new step's
    # table but upload no texture, which the shader's first frame then does.
    if not device_limits()["native_march"]:
        return
    pre[0.045] = pre[0.04].replace(step_size=0.045)
    r.native_march = True
    native, uploaded = frame(0.045)
    assert uploaded < 512 and r.last_frame_stats["engine"] == "native"
    r.native_march = False
    shader, uploaded = frame(0.045)
    assert uploaded > 1 << 20 and np.abs(native - shader).max() < 0.25 / 255 and shader[..., 3].max() > 0.2
