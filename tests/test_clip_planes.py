"""Clip planes: half-spaces at any angle that camera rays and shadow rays
march in, with the crop box.

A homogeneous box cut by planes has a closed form like the whole box's
(test_closed_form.py): every pixel's alpha is 1 - exp(-a L / ref) for its
ray's chord L through the box and the kept sides of the planes, which numpy
computes exactly. The cut segment counts with its length, as at the box's
faces, so the closed form holds at every preset's step; held to 0.5 level.
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer, _core
from pyvr.camera import Camera
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
from test_closed_form import A_TF, COLOR, PRESETS, H, W, cube_scene, float64_cube, rays

HALF_LEVEL = 0.5 / 255

PLANES = {
    "oblique": [((0.1, -0.05, 0.0), (1.0, 0.5, -0.3))],
    "wedge": [((0.0, 0.0, 0.0), (1.0, 1.0, 0.0)), ((0.0, 0.1, 0.0), (-0.2, 1.0, 0.4))],
    # Its normal points away from the camera: the cut face is what the eye sees.
    "facing_the_eye": [((0.05, 0.0, 0.0), (-0.98, -0.2, -0.15))],
    # Parallel to the x axis and to rays of the image's middle row.
    "along_an_axis": [((0.0, 0.2, 0.0), (0.0, -1.0, 0.0))],
    # Keeps nothing of the box.
    "beyond_the_box": [((0.0, 0.0, 0.9), (0.0, 0.0, 1.0))],
}


def clipped_chords(cam, bmin, bmax, planes):
    """Each pixel's chord length through the box and the planes' kept sides."""
    p, d, t0, t1 = rays(cam, bmin, bmax, W, H)
    for point, normal in planes:
        n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
        f0 = n @ (p - np.asarray(point, np.float64))
        slope = d @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            at = -f0 / slope
        t0 = np.where(slope > 0, np.maximum(t0, at), t0)
        t1 = np.where(slope < 0, np.minimum(t1, at), t1)
        t1 = np.where((slope == 0) & (f0 < 0), np.nan, t1)
    return np.nan_to_num(np.maximum(t1 - t0, 0.0))


def clipped_renderer(preset="balanced", planes=(), order="front_to_back", **kw):
    vol, ctf, otf, cam, light, cfg = cube_scene(preset)
    cfg = RenderConfig(step_size=cfg.step_size, max_steps=10_000, early_ray_termination=False,
                       opacity_threshold=1.0, order=order)
    r = VolumeRenderer(W, H, config=cfg, light=light, **kw)
    r.load_volume(vol)
    r.set_camera(cam)
    r.set_transfer_functions(ctf, otf)
    r.set_clip_planes(planes)
    return r, cam, cfg


def expected_alpha(cam, cfg, planes, lo=-0.5, hi=0.5):
    L = clipped_chords(cam, np.full(3, lo, np.float64), np.full(3, hi, np.float64), planes)
    return 1 - np.exp(-np.float64(np.float32(A_TF)) * L / cfg.reference_step_size)


@pytest.mark.parametrize("order", ["front_to_back", "back_to_front"])
@pytest.mark.parametrize("name", sorted(PLANES))
@pytest.mark.parametrize("preset", PRESETS)
def test_a_clipped_homogeneous_box_at_every_preset(preset, name, order):
    r, cam, cfg = clipped_renderer(preset, PLANES[name], order)
    img = r.render(dtype=np.float32)
    expect = expected_alpha(cam, cfg, PLANES[name])
    if name == "beyond_the_box":
        assert expect.max() == 0
    else:
        # Thick enough, and the cut visible: the whole box's alphas differ.
        whole = expected_alpha(cam, cfg, [])
        assert expect.max() > 0.2 and np.abs(whole - expect).max() > 0.1
    assert np.abs(img[..., 3] - expect).max() < HALF_LEVEL
    shown = expect > 0.01
    for c in range(3):
        assert np.all(np.abs(img[..., c][shown] - COLOR[c]) < HALF_LEVEL)


def test_planes_and_the_crop_box_combine():
    planes = PLANES["oblique"] + PLANES["along_an_axis"]
    r, cam, cfg = clipped_renderer("balanced", planes)
    r.set_crop_box((-0.4, -0.45, -0.3), (0.35, 0.5, 0.4))
    img = r.render(dtype=np.float32)
    L = clipped_chords(cam, np.array([-0.4, -0.45, -0.3]), np.array([0.35, 0.5, 0.4]), planes)
    expect = 1 - np.exp(-np.float64(np.float32(A_TF)) * L / cfg.reference_step_size)
    assert np.abs(img[..., 3] - expect).max() < HALF_LEVEL


@pytest.mark.parametrize("name", ["oblique", "wedge", "facing_the_eye"])
def test_the_float64_integrator_matches_the_closed_form(name):
    _, _, _, cam, _, cfg = cube_scene("fast")
    img, _ = float64_cube(cam, cfg, planes=[(q, tuple(np.asarray(n) / np.linalg.norm(n))) for q, n in PLANES[name]])
    assert np.abs(img[..., 3] - expected_alpha(cam, cfg, PLANES[name])).max() < 1e-6


def blob(n=40):
    z, y, x = np.mgrid[0:n, 0:n, 0:n] / (n - 1) - 0.5
    return (0.9 * np.exp(-(x * x + y * y + z * z) / 0.08)).astype(np.float32)


def scene(config, planes, camera=None, **kw):
    """A lit Gaussian blob, also the scene of test_orthographic.py."""
    r = VolumeRenderer(64, 56, config=config, light=Light.directional((-1.0, -0.3, 0.2), ambient=0.3, diffuse=0.7),
                       **kw)
    r.load_volume(Volume(blob()))
    r.set_camera(camera or Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.7, elevation=0.3,
                                                 roll=0.0, distance=2.2))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                             OpacityTransferFunction.linear(0.0, 0.25))
    r.set_clip_planes(planes)
    return r


def levels(a, b):
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).max() * 255)


CUT = [((0.05, 0.0, 0.0), (1.0, 0.2, 0.1))]


# One config per model (and test_orthographic.py's too).
MODELS = {
    "emission_absorption": RenderConfig.balanced(),
    "single_scattering": RenderConfig(step_size=0.01, model="single_scattering", shadow_step_size=0.02),
    "mip": RenderConfig(step_size=0.01, model="mip"),
    "isosurface": RenderConfig(step_size=0.01, model="isosurface", iso_value=0.5),
}


@pytest.mark.parametrize("config", [*MODELS.values(), RenderConfig(step_size=0.01, pre_integrated=True)],
                         ids=[*MODELS, "pre_integrated"])
def test_every_model_clips_as_the_float64_integrator_does(config):
    r = scene(config, CUT)
    img = r.render(dtype=np.float32)
    ref = r.render_float64()
    whole = scene(config, []).render(dtype=np.float32)
    assert levels(whole, img) > 20, "the cut changes the picture"
    # The engines' f32 rays against the integrator's f64 ones (pre-integrated
    # segments read a table, the integrator integrates them: 0.84 level
    # apart with or without planes).
    assert levels(img, ref) < (1.0 if config.pre_integrated else 0.05)


def test_shadow_rays_leave_through_the_planes():
    # Light travels along -x; the plane keeps x <= 0: the half that shadowed
    # the kept half is gone, so what is left is lit more than when the crop
    # box cuts away the same half (shadow rays stop at the crop box too).
    config = RenderConfig(step_size=0.01, model="single_scattering", shadow_step_size=0.01)
    cut = scene(config, [((0.0, 0.0, 0.0), (-1.0, 0.0, 0.0))])
    img = cut.render(dtype=np.float32)
    cropped = scene(config, [])
    cropped.set_crop_box((-0.5, -0.5, -0.5), (0.0, 0.5, 0.5))
    assert levels(img, cropped.render(dtype=np.float32)) < 0.05
    assert levels(img, cut.render_float64()) < 0.05


def test_bricked_volumes_clip_like_whole_ones():
    config = RenderConfig.balanced()
    whole = scene(config, CUT).render(dtype=np.float32)
    bricked = scene(config, CUT, brick_shape=(16, 16, 16))
    assert bricked.render(dtype=np.float32).shape == whole.shape
    assert levels(bricked.render(dtype=np.float32), whole) < 0.5


def test_planes_are_kept_as_unit_normals_and_removed_by_none():
    r, _, _ = clipped_renderer()
    r.set_clip_planes([((0, 0, 0), (0.0, 0.0, 1e-300))])
    assert r.clip_planes == (((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),)
    r.set_clip_planes(np.array([[[0, 0, 0], [3.0, 0, 4.0]]]))
    assert r.clip_planes == (((0.0, 0.0, 0.0), (0.6, 0.0, 0.8)),)
    r.set_clip_planes(((0, 0, 0), (1, 0, 0)))  # one pair on its own
    assert len(r.clip_planes) == 1
    for none in (None, []):
        r.set_clip_planes(none)
        assert r.clip_planes == ()
        whole = r.render(dtype=np.float32)
        assert whole[..., 3].max() > 0.3


@pytest.mark.parametrize(("planes", "exc", "message"), [
    ([((0, 0, 0), (0, 0, 0))], ValueError, r"clip plane 0: the normal must not be zero"),
    ([((0, 0, 0), (1, 0, 0)), ((np.nan, 0, 0), (1, 0, 0))], ValueError, r"clip plane 1: .* must be finite"),
    ([((0, 0, 0), (1, 0, 0))] * 17, ValueError, r"at most 16 clip planes, got 17"),
    ([((0, 0), (1, 0))], ValueError, r"\(N, 2, 3\) array, got shape \(1, 2, 2\)"),
    ([((True, False, True), (1, 0, 0))], TypeError, r"planes must be \(point, normal\) pairs"),
    ("x", TypeError, r"planes must be \(point, normal\) pairs"),
])
def test_bad_planes_are_refused_and_change_nothing(planes, exc, message):
    r, _, _ = clipped_renderer(planes=PLANES["oblique"])
    before = r.render(dtype=np.float32)
    kept = r.clip_planes
    with pytest.raises(exc, match=message):
        r.set_clip_planes(planes)
    assert r.clip_planes == kept
    assert np.array_equal(r.render(dtype=np.float32), before)


def test_the_core_refuses_more_planes_than_it_holds():
    engine = _core.Renderer(8, 8)
    engine.set_clip_planes([((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))] * 16)
    with pytest.raises(ValueError, match="at most 16 clip planes, got 17"):
        engine.set_clip_planes([((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))] * 17)


def test_caps_close_the_cut_with_the_volumes_colour():
    # The camera is on the cut-away side (+x): the plane x = 0.1 keeping
    # x <= 0.1 is where the kept volume begins. Capped, every ray crossing
    # that face inside the box shows the transfer function's colour there,
    # opaque (nothing is in front of it); the other rays are as uncapped.
    plane = [((0.1, 0.0, 0.0), (-1.0, 0.0, 0.0))]
    r, cam, _ = clipped_renderer("balanced", plane)
    open_cut = r.render(dtype=np.float32, premultiplied=True)
    r.set_clip_planes(plane, caps=True)
    capped = r.render(dtype=np.float32, premultiplied=True)
    o, d, t0, t1 = rays(cam, np.full(3, -0.5), np.full(3, 0.5), W, H)
    tp = (0.1 - o[0]) / d[..., 0]
    face = o + d * tp[..., None]
    on = (tp > 0) & np.all(np.abs(face[..., 1:]) < 0.5 - 1e-3, axis=-1)
    off = ~((tp > 0) & np.all(np.abs(face[..., 1:]) <= 0.5 + 1e-3, axis=-1))  # away from the face's edges
    assert 0.1 < on.mean() < 0.9
    assert np.abs(capped[on] - np.array([*COLOR, 1.0])).max() < HALF_LEVEL
    assert np.abs(capped[off] - open_cut[off]).max() < HALF_LEVEL
    assert np.abs(open_cut[on][..., 3] - 1).min() > 0.1  # uncapped, the cut was see-through
    assert r.render_slice(plane[0], values=True).shape == (H, W)
    with pytest.raises(TypeError, match="caps must be True or False"):
        r.set_clip_planes(plane, caps="yes")
