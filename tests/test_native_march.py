"""The native CPU march renders what the shader renders.

Where wgpu's only adapter is a CPU, the frames the native march covers
(src/cpu: emission-absorption, plain, pre-integrated or refined,
single scattering, absorption and emission, in either order and either opacity correction, unlit or lit from
the texels' normals or gradients or from normals stored apart, one texture; and the maximum, minimum and
average intensity projections) are its, not the shader's. Each case renders one frame both ways
(``native_march`` on and off) and compares the premultiplied images and
what the frames took. Both run the same rule in f32; they differ in the
order of sums, fused multiply-adds and the exponential (relative error
~2e-7), and a ray that reaches the early-termination threshold within
that rounding stops one sample apart: 0.11 level, measured, at one pixel
of the 512x512 benchmark frame. So the bound is 0.25 level at any pixel,
0.002 on average, and the sample counts agree to 1e-4 (the same segments
and leaps; one skipped or repeated cell of 8 voxels would cost whole
levels or change the counts by far more).
"""

import numpy as np
import pytest

from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.renderer import device_limits
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

pytestmark = [pytest.mark.skipif(not device_limits()["native_march"],
                                 reason="the native march runs only on x86-64 CPUs with AVX2, FMA and F16C"),
              pytest.mark.shader]

LEVEL = 1 / 255
BOX = (np.array([-1.0, -0.8, -0.6], np.float32), np.array([1.0, 0.8, 0.6], np.float32))


def sphere_pair(n=40):
    d = create_sample_volume(n, "double_sphere").astype(np.float32)
    return np.ascontiguousarray(d[:, : n - 6, : n - 10])


def scene(kind):
    """(volume, precision, light, opacity TF[, colour TF]) of each storage the march reads."""
    d = sphere_pair()
    ramp = OpacityTransferFunction.linear(0.0, 0.4)
    lit = Light.directional([-0.6, -0.3, -0.8], ambient=0.25, diffuse=0.75)
    if kind == "normals_fixed16":
        return Volume(d, compute_normal_volume(d), *BOX), "fixed16", lit, ramp
    if kind == "normals_float32":
        return Volume(d, compute_normal_volume(d), *BOX), "float32", lit, ramp
    if kind == "gradients":
        return Volume(d, None, *BOX), "float32", lit, ramp
    if kind == "values_float32":
        return Volume(d, None, *BOX), "float32", Light.ambient_only(0.9), ramp
    if kind == "values_fixed16":
        return Volume(d, None, *BOX), "fixed16", Light.ambient_only(0.9), ramp
    if kind == "normals_float16":
        return Volume(d, compute_normal_volume(d), *BOX), "float16", lit, ramp
    if kind == "values_float16":
        return Volume(d, None, *BOX), "float16", Light.ambient_only(0.9), ramp
    if kind == "values_uint8":
        return Volume(np.round(d * 255).astype(np.uint8), None, *BOX), "float32", Light.ambient_only(0.9), ramp
    if kind == "values_uint16":
        return Volume(np.round(d * 65535).astype(np.uint16), None, *BOX), "float32", Light.ambient_only(0.9), ramp
    # Integer codes and NaN-holding float32 values keep their normals apart
    # (an Rgba8Snorm texture; the native march a copy of it).
    if kind == "normals_uint8":
        return Volume(np.round(d * 255).astype(np.uint8), compute_normal_volume(d), *BOX), "float32", lit, ramp
    if kind == "normals_uint16":
        return Volume(np.round(d * 65535).astype(np.uint16), compute_normal_volume(d), *BOX), "float32", lit, ramp
    if kind == "normals_nan":
        holed = d.copy()
        holed[10:14, 12:15, 5:20] = np.nan
        return Volume(holed, compute_normal_volume(d), *BOX), "float32", lit, ramp
    if kind == "plateau":
        # Flat opacity above 0.45: cells whose values all lie there are
        # uniform, and unlit frames composite runs through them whole.
        x, y, z = np.meshgrid(*[np.linspace(-1, 1, 72)] * 3, indexing="ij")
        data = (0.6 + 0.4 * np.sin(3 * x) * np.sin(2 * y) * np.cos(2.5 * z)).astype(np.float32)
        flat = OpacityTransferFunction([(0.0, 0.0), (0.2, 0.0), (0.45, 0.2), (1.0, 0.2)])
        colour = ColorTransferFunction([(0.0, (0.0, 0.0, 1.0)), (0.45, (1.0, 0.5, 0.0)), (1.0, (1.0, 0.5, 0.0))])
        return Volume(data, None, *BOX), "float32", Light.ambient_only(0.9), flat, colour
    if kind == "nan":
        d = d.copy()
        d[10:14, 12:15, 5:20] = np.nan
        return Volume(d, None, *BOX), "float32", Light.ambient_only(0.9), ramp
    raise ValueError(kind)


KINDS = ["normals_fixed16", "normals_float32", "normals_float16", "gradients", "values_float32", "values_fixed16",
         "values_float16", "values_uint8", "values_uint16", "plateau", "nan", "normals_uint8", "normals_uint16",
         "normals_nan"]
OUTSIDE = Camera.from_spherical(np.zeros(3), 0.7, 0.4, 0.0, 3.0)
INSIDE = Camera(target=np.array([-0.6, 0.2, 0.1]), azimuth=0.3, elevation=0.2, roll=0.0, distance=0.5)


def renderer(kind, config=None, size=(72, 64)):
    vol, precision, light, otf, *ctf = scene(kind)
    r = VolumeRenderer(*size, config=config or RenderConfig.balanced(), light=light)
    r.load_volume(vol, precision=precision)
    r.set_transfer_functions(ctf[0] if ctf else ColorTransferFunction.from_colormap("viridis"), otf)
    r.set_camera(OUTSIDE)
    r.native_march = True  # whatever PYVR_NATIVE_MARCH says
    return r


def both(r, config=None):
    """The frame from the native march and from the shader, with their stats."""
    out = []
    for native in (True, False):
        r.native_march = native
        img = r.render(dtype=np.float32, premultiplied=True, config=config)
        out.append((img, dict(r.last_frame_stats)))
    r.native_march = True
    return out


def assert_same(native, shader, what, leaps=False):
    """The same image, truncation and samples. `leaps`: maximum and minimum
    projections leap cells whose bound their value so far passes; where the
    device's sampler filters 16-bit texels, its values round differently
    from the native march's, which moves the leaps of cells whose bound lies
    within that rounding of the value (measured: 1.2e-4 of the samples)."""
    (a, sa), (b, sb) = native, shader
    assert sa["engine"] == "native" and sb["engine"] == "gpu", what
    assert a.max() > 0.05, f"{what}: the scene must show something"
    diff = np.abs(a - b)
    assert diff.max() < 0.25 * LEVEL, f"{what}: max difference {diff.max() / LEVEL:.4f} levels"
    assert diff.mean() < 0.002 * LEVEL, f"{what}: mean difference {diff.mean() / LEVEL:.5f} levels"
    within = 1e-3 if leaps else 1e-4
    assert abs(sa["samples"] - sb["samples"]) <= within * sb["samples"] + 2, f"{what}: samples {sa} vs {sb}"
    assert sa["truncated_needed"] == sb["truncated_needed"], what


CONFIGS = {
    "balanced": {},
    "jitter": {"jitter": True, "jitter_seed": 7},
    "no_early_stop": {"early_ray_termination": False},
    "low_threshold": {"opacity_threshold": 0.3},
    "long_steps": {"step_size": 0.05},
    # max_steps cuts every ray short: the frame reports the steps they needed.
    "truncated": {"step_size": 0.01, "max_steps": 60},
    "pre_integrated": {"pre_integrated": True},
    # Jitter makes the first segment shorter: the midpoint rule there.
    "pre_integrated_jitter": {"pre_integrated": True, "jitter": True, "step_size": 0.03},
    # Segments that may cross an opacity change their ramp misses are taken as 8 samples.
    "refined": {"pre_integrated": True, "refine": 8, "step_size": 0.03},
    "absorption": {"model": "absorption"},
    "emission": {"model": "emission"},
    # Extinction -ln(1 - a) at each midpoint sample; the table holds it for full segments.
    "power": {"opacity_correction": "power"},
    "power_pre_integrated": {"opacity_correction": "power", "pre_integrated": True, "jitter": True, "step_size": 0.03},
    # Without early termination: the log's rounding (not the shader's) let one
    # ray of these reach the threshold a refined segment apart, 7.7 levels.
    "power_refined": {"opacity_correction": "power", "pre_integrated": True, "refine": 8, "step_size": 0.03,
                      "early_ray_termination": False},
    "power_absorption": {"opacity_correction": "power", "model": "absorption"},
    # Shadow rays from every sample with extinction (lit kinds; the others' light is ambient).
    "single_scattering": {"model": "single_scattering"},
    # The shader's volume read interpolated with f32 weights, as the native march's is: the same
    # samples, so the same shadow rays (see IMAGES_ONLY).
    "single_scattering_forward": {"model": "single_scattering", "anisotropy": 0.6, "shadow_step_size": 0.03,
                                  "opacity_correction": "power", "exact_filtering": True},
    # Marched front to back natively: the same sum (see test_back_to_front_matches_the_shader).
    "back_to_front": {"order": "back_to_front"},
    "back_to_front_pre_integrated": {"order": "back_to_front", "pre_integrated": True, "step_size": 0.03},
    # Ratio tracking: the same Poisson points from the same integer streams.
    # Without early termination, which is Russian roulette there: its number
    # is a hash of the point's offset, whose last bits the two engines'
    # logarithms round apart (test_native_roulette_keeps_the_mean).
    "unbiased": {"unbiased": True, "early_ray_termination": False},
    "unbiased_jitter": {"unbiased": True, "early_ray_termination": False, "jitter": True, "step_size": 0.03},
    "unbiased_power": {"unbiased": True, "early_ray_termination": False, "opacity_correction": "power"},
    "unbiased_absorption": {"unbiased": True, "early_ray_termination": False, "model": "absorption"},
    "unbiased_emission": {"unbiased": True, "model": "emission"},
    # Blocks and their points from the far end, composited back to front, as the shader's.
    "unbiased_back_to_front": {"unbiased": True, "order": "back_to_front"},
    "unbiased_back_to_front_jitter": {"unbiased": True, "order": "back_to_front", "jitter": True, "step_size": 0.03},
}
# Frames whose sample counts may differ, compared by their images: the
# shader marches back-to-front frames from the far end, where its leaps
# start from other cells and sample other empty segments
# (test_back_to_front_matches_the_shader); and a single-scattering shadow
# ray starts from every sample with extinction, where the sampler's
# weights in fixed point (float32 volumes, lavapipe) read a value of
# exactly 0 at some samples whose f32 trilinear value is a hair above it:
# 5-6% more shadow samples on the float32 kinds, the same images.
IMAGES_ONLY = {"back_to_front", "back_to_front_pre_integrated", "single_scattering"}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_native_march_matches_the_shader(kind, name):
    r = renderer(kind)
    cfg = RenderConfig.balanced().replace(**CONFIGS[name])
    for cam in (OUTSIDE, INSIDE):
        r.set_camera(cam)
        native, shader = both(r, cfg)
        if cam is OUTSIDE and name not in IMAGES_ONLY:
            assert_same(native, shader, f"{kind}, {name}, outside")
        else:
            (a, _), (b, _) = native, shader
            assert np.abs(a - b).max() < 0.25 * LEVEL, f"{kind}, {name}, inside"
    if name == "truncated" and kind != "plateau":  # the plateau's rays stop early
        assert shader[1]["truncated_needed"] > 60


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("model", ["mip", "minip", "average"])
def test_native_projections_match_the_shader(kind, model):
    # Opaque at every value, so that the minimum (0 outside the spheres)
    # shows too; the 'nan' kind's NaN values are passed over.
    r = renderer(kind)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("magma"), OpacityTransferFunction.linear(0.3, 0.9))
    for name, changes in {"balanced": {}, "jitter": {"jitter": True, "jitter_seed": 3, "step_size": 0.03},
                          "truncated": {"step_size": 0.01, "max_steps": 60}}.items():
        cfg = RenderConfig.balanced().replace(model=model, **changes)
        for cam in (OUTSIDE, INSIDE):
            r.set_camera(cam)
            native, shader = both(r, cfg)
            what = f"{kind}, {model}, {name}, {'outside' if cam is OUTSIDE else 'inside'}"
            assert_same(native, shader, what, leaps=model != "average")
        if name == "truncated":
            assert native[1]["truncated_needed"] > 60


def test_projection_leaps_follow_a_new_value_range():
    # The cells' bounds are kept with the volume for its value map: a new
    # value range must make new ones (bounds of the old map would leap cells
    # whose values now pass the maximum).
    n = 48
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32) / n
    data = (0.2 + 0.6 * np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) / 0.03)).astype(np.float32)
    r = VolumeRenderer(64, 56, light=Light.ambient_only(1.0))
    r.load_volume(Volume(data))
    r.set_camera(Camera.from_spherical(np.zeros(3), 0.2, 0.3, 0.0, 3.0))
    cfg = RenderConfig.balanced().replace(model="mip")
    for value_range in [(0.0, 1.0), (0.3, 0.5), (-2.0, 0.25)]:
        r.set_transfer_functions(ColorTransferFunction.from_colormap("magma"), OpacityTransferFunction.linear(0.0, 1.0),
                                 value_range=value_range)
        native, shader = both(r, cfg)
        assert_same(native, shader, f"value range {value_range}")


@pytest.mark.parametrize("model", ["mip", "minip"])
@pytest.mark.parametrize("dtype", ["float32", "uint8"])
@pytest.mark.parametrize("background", ["varying", "uniform"])
def test_projections_leap_cells_that_cannot_change_the_pixel(model, dtype, background):
    # A bright (for the minimum: dark) ball near the camera in a dim (bright)
    # field: once a ray has crossed the ball, no cell behind it can pass its
    # maximum (minimum), and the march leaps them; a uniform field's cells
    # are leapt once a ray has read the field's value.
    n = 64
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32) / n
    ball = np.exp(-((x - 0.8) ** 2 + (y - 0.7) ** 2 + (z - 0.5) ** 2) / 0.02)
    if background == "varying":
        field = 0.3 + 0.1 * np.sin(9 * x) * np.cos(7 * y) * np.sin(5 * z)
    else:
        field, ball = np.full_like(x, 0.25), np.where(ball > 0.05, ball, 0)
    data = field + 0.6 * ball if model == "mip" else field + 0.6 * (1 - ball) - 0.2
    data = np.clip(data, 0, 1)
    if dtype == "uint8":
        data = np.round(data * 255).astype(np.uint8)
    r = VolumeRenderer(96, 80, light=Light.ambient_only(1.0))
    r.load_volume(Volume(data))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("magma"), OpacityTransferFunction.linear(0.0, 1.0))
    r.set_camera(Camera.from_spherical(np.zeros(3), 0.2, 0.3, 0.0, 3.0))
    r.native_march = True
    cfg = RenderConfig.balanced().replace(model=model)
    native, shader = both(r, cfg)
    what = f"{model}, {dtype}, {background}"
    assert_same(native, shader, what)
    # Every segment read: the same image from more samples. Measured: the
    # leaps read 0.63-0.73 of them where rays that miss the ball cross a
    # field whose maximum grows along them, 0.17 in a uniform one.
    r.empty_space_skipping = False
    every, every_shader = both(r, cfg)
    assert_same(every, every_shader, f"{what}, every segment")
    most = 0.8 if background == "varying" else 0.25
    for leapt, read in ((native, every), (shader, every_shader)):
        assert np.abs(leapt[0] - read[0]).max() < 0.25 * LEVEL, what
        assert leapt[1]["samples"] < most * read[1]["samples"], (what, leapt[1], read[1])


@pytest.mark.parametrize("kind", KINDS)
def test_native_isosurface_matches_the_shader(kind):
    # The surface's colour and light, its hit distance, and the samples:
    # entry, midpoints, exit, a lower end re-read after a leap, bisections.
    r = renderer(kind)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.5))
    # Long steps meet the surface right after leaps, whose lower ends are read then.
    for name, changes in {"balanced": {}, "jitter": {"jitter": True, "jitter_seed": 3, "step_size": 0.03},
                          "long_steps": {"step_size": 0.2},
                          "truncated": {"step_size": 0.01, "max_steps": 60}}.items():
        cfg = RenderConfig.balanced().replace(model="isosurface", iso_value=0.45, **changes)
        for skip in (True, False):
            r.empty_space_skipping = skip
            for cam in (OUTSIDE, INSIDE):
                r.set_camera(cam)
                where = f"{kind}, {name}, skip={skip}, {'outside' if cam is OUTSIDE else 'inside'}"
                (a, sa), (b, sb) = both(r, cfg)
                assert sa["engine"] == "native" and sb["engine"] == "gpu", where
                r.native_march = True
                r.render(config=cfg)
                da = r.depth()
                r.native_march = False
                r.render(config=cfg)
                db = r.depth()
                r.native_march = True
                assert (np.isinf(da) == np.isinf(db)).mean() > 0.999, where
                both_hit = np.isfinite(da) & np.isfinite(db)
                assert both_hit.sum() > (10 if name == "truncated" else 50), where
                # A thousandth of a step (the bisections end within 1/256 of one).
                assert np.abs(da[both_hit] - db[both_hit]).max() < 1e-3 * cfg.step_size, where
                assert_same((a, sa), (b, sb), where)
                # The same points (measured: at most one apart, a test rounded the other way).
                assert abs(sa["samples"] - sb["samples"]) <= 2, where
                if name == "truncated" and cam is OUTSIDE:
                    assert sa["truncated_needed"] > 60, where


@pytest.mark.parametrize("kind", ["normals_fixed16", "values_float32"])
def test_skipping_crop_and_value_range_in_the_native_march(kind):
    r = renderer(kind)
    # Most cells empty: a narrow opacity band, so rays leap.
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"),
                             OpacityTransferFunction.peaks([0.6], opacity=0.7, eps=0.08))
    native, shader = both(r)
    assert_same(native, shader, "narrow band")
    assert r.empty_fraction() > 0.5
    # Pre-integrated segments prime their near value again after each leap.
    assert_same(*both(r, RenderConfig.balanced().replace(pre_integrated=True)), "narrow band, pre-integrated")
    r.empty_space_skipping = False
    unskipped, _ = both(r)
    r.empty_space_skipping = True
    assert np.abs(unskipped[0] - native[0]).max() < 0.25 * LEVEL
    assert native[1]["samples"] < 0.8 * unskipped[1]["samples"]
    r.set_crop_box([-0.5, -0.8, -0.2], [0.6, 0.3, 0.6])
    assert_same(*both(r), "cropped")
    r.set_crop_box()
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.5),
                             value_range=(0.2, 0.9))
    assert_same(*both(r), "value range")


def test_uniform_runs_in_the_native_march():
    r = renderer("plateau")
    native, shader = both(r)
    assert r.uniform_fraction() > 0.25
    assert_same(native, shader, "plateau")
    r.uniform_runs = False
    one_by_one, _ = both(r)
    assert np.abs(one_by_one[0] - native[0]).max() < 0.25 * LEVEL
    assert native[1]["samples"] < 0.7 * one_by_one[1]["samples"]


@pytest.mark.parametrize("kind", ["normals_fixed16", "values_float32"])
def test_back_to_front_matches_the_shader(kind):
    # The native march takes a back-to-front frame's segments front to back
    # without early termination: the same segments and the same sum as the
    # shader's march from the far end, whose leaps, started from other
    # cells, sample other empty segments (those add nothing).
    r = renderer(kind)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"),
                             OpacityTransferFunction.peaks([0.6], opacity=0.7, eps=0.08))
    for changes in ({}, {"pre_integrated": True, "step_size": 0.03}):
        cfg = RenderConfig.balanced().replace(order="back_to_front", **changes)
        native, shader = both(r, cfg)
        (a, sa), (b, sb) = native, shader
        assert sa["engine"] == "native" and sb["engine"] == "gpu"
        assert a[..., 3].max() > 0.5 and r.empty_fraction() > 0.5
        assert np.abs(a - b).max() < 0.25 * LEVEL, f"{kind}, {changes}: {np.abs(a - b).max() / LEVEL:.4f} levels"
        assert np.abs(a - b).mean() < 0.002 * LEVEL
        assert abs(sa["samples"] - sb["samples"]) < 0.05 * sb["samples"], (sa, sb)
        # The native frame is the front-to-back one without early termination.
        ftb = r.render(dtype=np.float32, premultiplied=True,
                       config=cfg.replace(order="front_to_back", early_ray_termination=False))
        assert np.array_equal(ftb, a) and r.last_frame_stats["samples"] == sa["samples"]


@pytest.mark.parametrize("dtype, code", [(np.uint8, 255), (np.uint16, 65535)])
def test_lit_integer_volumes_pack_their_gradients_for_the_native_march(dtype, code):
    # A lit integer volume without normals: the shader takes central
    # differences of the interpolated codes at each lit sample (seven
    # fetches); where the native march runs, the first lit frame stores
    # the codes' fractions with their gradients (src/gradients.rs), and the
    # native march reads one texel. The same rule, so the same image.
    d = np.round(sphere_pair() * code).astype(dtype)
    lit = Light.directional([-0.6, -0.3, -0.8], ambient=0.25, diffuse=0.75)
    out = []
    for native in (True, False):
        r = VolumeRenderer(72, 64, config=RenderConfig.balanced(), light=lit)
        r.native_march = native  # before the first frame: the shader's renderer never packs
        r.load_volume(Volume(d, None, *BOX))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                 OpacityTransferFunction.linear(0.0, 0.4))
        r.set_camera(OUTSIDE)
        out.append((r.render(dtype=np.float32, premultiplied=True), dict(r.last_frame_stats)))
        storage = r.counters()["volume_storage"]
        assert storage == ("rgba32float (value, gradient)" if native else f"r{8 * d.itemsize}unorm"), storage
    assert_same(*out, f"{dtype.__name__}, lit")
    # Lit: the same volume under ambient light alone differs by whole levels.
    r.set_light(Light.ambient_only(0.25))
    assert np.abs(r.render(dtype=np.float32, premultiplied=True) - out[0][0]).max() > 10 * LEVEL


@pytest.mark.parametrize("precision", ["fixed16", "float16", "float32"])
@pytest.mark.parametrize("light", ["directional", "point"])
def test_native_gradients_from_central_differences_match_the_shader(precision, light):
    # Values alone, lit, and not stored with their gradients (fixed16 and
    # float16 never are; float32 here because they would pass a small
    # memory budget): both engines take central differences of the
    # interpolated values at each lit sample, and at the isosurface's hit.
    # NaN voxels (float32 only) leave their neighbours' gradients zero
    # (ambient light).
    d = sphere_pair()
    if precision == "float32":
        d[10:12, 14:16, 3:9] = np.nan
    lights = {"directional": Light.directional([-0.6, -0.3, -0.8], ambient=0.25, diffuse=0.75),
              "point": Light.point_light([0.1, -0.2, 0.05], ambient=0.2, diffuse=0.8)}
    r = VolumeRenderer(72, 64, config=RenderConfig.balanced(), light=lights[light], memory_budget=1 << 20)
    r.load_volume(Volume(d, None, *BOX), precision=precision)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.4))
    for changes in ({}, {"pre_integrated": True, "step_size": 0.03}, {"model": "emission"},
                    {"model": "isosurface", "iso_value": 0.45}):
        for cam in (OUTSIDE, INSIDE):
            r.set_camera(cam)
            where = f"{precision}, {light}, {changes}, {'outside' if cam is OUTSIDE else 'inside'}"
            native, shader = both(r, RenderConfig.balanced().replace(**changes))
            assert_same(native, shader, where)
    assert "gradient" not in r.counters()["volume_storage"]
    # Lit: under ambient light alone the image differs by whole levels.
    r.set_light(Light.ambient_only(0.25))
    assert np.abs(r.render(dtype=np.float32, premultiplied=True) - native[0]).max() > 10 * LEVEL


@pytest.mark.parametrize("kind", ["normals_fixed16", "normals_float32"])
def test_native_single_scattering_matches_the_shader(kind):
    # Dense enough that shadow rays pass optical depths of several units
    # (the light a sample gets then hangs on each shadow sample), under a
    # directional light and a point light inside the box, isotropic and
    # forward scattering, at the step and at a coarser shadow step.
    r = renderer(kind)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 1.0))
    for light in (Light.directional([0.8, -0.5, 0.3], ambient=0.1, diffuse=0.9),
                  Light.point_light([0.05, 0.3, -0.1], ambient=0.1, diffuse=0.9)):
        r.set_light(light)
        for changes in ({}, {"anisotropy": -0.4, "shadow_step_size": 0.04}):
            cfg = RenderConfig.balanced().replace(model="single_scattering", exact_filtering=True, **changes)
            native, shader = both(r, cfg)
            assert_same(native, shader, f"{kind}, {light.kind if hasattr(light, 'kind') else light}, {changes}")
            # Shadows matter here: without them (ambient + diffuse) the image is far brighter.
            unshadowed = r.render(dtype=np.float32, premultiplied=True,
                                  config=cfg.replace(model="emission_absorption"))
            assert np.abs(unshadowed - native[0]).max() > 10 * LEVEL


@pytest.mark.parametrize("model", ["emission_absorption", "mip", "isosurface", "unbiased", "unbiased_back_to_front"])
def test_bricked_frames_run_on_the_native_march(model):
    # A volume in bricks takes several textures, which the native march
    # reads one after another for emission-absorption (unbiased too, whose
    # bricks come far to near back to front), the projections and the
    # isosurface (here lit from normals stored apart). Each matches the
    # single texture.
    d = sphere_pair()
    vol = Volume(np.round(d * 255).astype(np.uint8), compute_normal_volume(d), *BOX)
    lit = Light.directional([-0.6, -0.3, -0.8], ambient=0.25, diffuse=0.75)
    unbiased = model.startswith("unbiased")
    cfg = RenderConfig.balanced().replace(model="emission_absorption" if unbiased else model,
                                          unbiased=unbiased, iso_value=0.45,
                                          order="back_to_front" if model.endswith("back_to_front") else "front_to_back")
    frames = {}
    for bricks in ((9, 11, 7), None):
        r = VolumeRenderer(72, 64, light=lit, brick_shape=bricks, config=cfg)
        r.load_volume(vol, precision="float32")
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                 OpacityTransferFunction.linear(0.0, 0.4))
        r.native_march = True
        frames[bricks is None] = r.render(dtype=np.float32, premultiplied=True), r.last_frame_stats["engine"]
    assert frames[False][1] == "native" and frames[True][1] == "native"
    assert frames[True][0][..., 3].max() > 0.3
    assert np.abs(frames[False][0] - frames[True][0]).max() < 0.25 * LEVEL


@pytest.mark.parametrize("kind", ["normals_fixed16", "normals_float32", "normals_uint8", "gradients"])
@pytest.mark.parametrize("model", ["emission_absorption", "isosurface", "single_scattering", "unbiased"])
def test_native_point_light_matches_the_shader(kind, model):
    # A point light inside the box (every direction lights some sample;
    # one sample may sit on the light itself, where only ambient light
    # counts) and one outside it.
    r = renderer(kind)
    # Shadow rays from the same samples as the native march's (see IMAGES_ONLY).
    if model == "unbiased":
        cfg = RenderConfig.balanced().replace(unbiased=True, early_ray_termination=False)
    else:
        cfg = RenderConfig.balanced().replace(model=model, iso_value=0.45, exact_filtering=model == "single_scattering")
    for position in ([0.1, -0.2, 0.05], [2.0, 2.0, 2.0]):
        r.set_light(Light.point_light(position, ambient=0.2, diffuse=0.8))
        for cam in (INSIDE, OUTSIDE):
            r.set_camera(cam)
            native, shader = both(r, cfg)
            assert_same(native, shader, f"{kind}, {model}, light at {position}, {'outside' if cam is OUTSIDE else 'inside'}")
        # The point light's own shading, not a directional light's.
        r.set_light(Light.directional([-0.6, -0.3, -0.8], ambient=0.2, diffuse=0.8))
        directional, _ = both(r, cfg)
        assert np.abs(directional[0] - native[0]).max() > 5 * LEVEL


@pytest.mark.parametrize("kind", ["normals_float32", "gradients", "values_uint8"])
def test_native_unbiased_cell_rates_match_the_shader(kind):
    # An opaque shell (power form: extinction up to 1e30) lifts the frame's
    # rate to 16 points a step, and each block takes its own cell's
    # majorant instead: more points where the shell is, a point a step
    # elsewhere. With and without leaps over empty cells.
    r = renderer(kind)
    shell = OpacityTransferFunction([(0.0, 0.0), (0.3, 0.0), (0.35, 1.0), (1.0, 1.0)])
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), shell)
    cfg = RenderConfig.balanced().replace(unbiased=True, early_ray_termination=False, opacity_correction="power")
    counts = []
    for skip in (True, False):
        r.empty_space_skipping = skip
        native, shader = both(r, cfg)
        assert_same(native, shader, f"{kind}, skipping {skip}")
        counts.append(native[1]["samples"])
        # Points drawn from the far end, composited back to front.
        native, shader = both(r, cfg.replace(order="back_to_front"))
        assert_same(native, shader, f"{kind}, skipping {skip}, back to front")
    # Leaps pass the empty cells' points; between 1 and 16 points a step.
    steps = both(r, cfg.replace(unbiased=False))[0][1]["samples"]
    assert counts[0] < counts[1] and 1.5 * steps < counts[1] < 16 * steps, (counts, steps)


def test_native_roulette_keeps_the_mean():
    # With early termination, rays below the threshold go on by Russian
    # roulette, whose number hashes the point's offset: where the engines'
    # logarithms round an offset apart, a ray's outcome differs. Each engine
    # is unbiased (tests/test_unbiased.py), so their means agree.
    r = renderer("values_float32", size=(40, 36))
    cfg = RenderConfig.balanced().replace(unbiased=True, opacity_threshold=0.5)
    means = []
    for native in (True, False):
        r.native_march = native
        stack = np.stack([r.render(dtype=np.float32, premultiplied=True, config=cfg.replace(jitter_seed=k))
                          for k in range(48)]).astype(np.float64)
        assert r.last_frame_stats["engine"] == ("native" if native else "gpu")
        means.append((stack.mean(0), stack.std(0) / np.sqrt(len(stack))))
    (a, sa), (b, sb) = means
    z = (a - b) / np.maximum(np.hypot(sa, sb), 0.25 * LEVEL)
    # Rays cut short: the frame's opacity reaches the threshold.
    assert a[..., 3].max() > 0.5 and np.sqrt((z ** 2).mean()) < 1.35, np.sqrt((z ** 2).mean())
    assert abs((a - b).mean()) < 0.05 * LEVEL + 4 * np.sqrt((sa ** 2 + sb ** 2).mean() / a.size)


@pytest.mark.parametrize("kind", ["normals_fixed16", "normals_uint8", "gradients", "values_float32"])
def test_the_texture_waits_for_a_frame_on_the_shader(kind):
    # On a CPU adapter the texels are kept once, for the native march; the
    # shader's texture (and normals apart) is made from that copy when a
    # frame first needs it, and then kept.
    r = renderer(kind)
    first = r.render(dtype=np.float32, premultiplied=True)
    assert r.last_frame_stats["engine"] == "native" and not r.counters()["volume_texture"]
    # Uploads are counted by the frame that makes them: the volume's not by
    # the native one (which counts the transfer function's and the cells').
    counted = r.counters()["uploaded_bytes"]
    assert r.last_frame_stats["uploaded_bytes"] == counted < r.counters()["volume_bytes"]
    native, shader = both(r)
    assert r.counters()["volume_texture"]
    assert shader[1]["uploaded_bytes"] >= r.counters()["volume_bytes"] > native[1]["uploaded_bytes"]
    assert r.counters()["uploaded_bytes"] >= counted + r.counters()["volume_bytes"]
    assert_same(native, shader, kind)
    assert np.array_equal(first, native[0])
    # A new volume starts without its texture again.
    r.load_volume(scene(kind)[0], precision=scene(kind)[1])
    r.render()
    assert not r.counters()["volume_texture"]


def test_native_march_off_keeps_frames_on_the_shader():
    r = renderer("normals_fixed16")
    r.render()
    assert r.last_frame_stats["engine"] == "native"
    r.native_march = False
    r.render()
    assert r.last_frame_stats["engine"] == "gpu"


def test_every_cross_validation_scene_matches_the_shader():
    # The scenes checked against the moderngl reference (test_cross_validation.py),
    # each rendered by both engines.
    from scenes import frame, make_renderer
    from test_cross_validation import H, SCENES, W
    from test_cross_validation import scene as cross_scene

    native_scenes = []
    for name in SCENES:
        vol, ctf, otf, cam, light, cfg = cross_scene(name)
        r = make_renderer(vol, size=(W + 1, H + 1), config=cfg, light=light, camera=cam, ctf=ctf, otf=otf)
        out = []
        for native in (True, False):
            r.native_march = native
            out.append((frame(r), r.last_frame_stats["engine"]))
        (a, engine), (b, _) = out
        assert np.abs(a - b).max() < 0.25 * LEVEL, f"{name}: {np.abs(a - b).max() / LEVEL:.4f} levels ({engine})"
        if engine == "native":
            native_scenes.append(name)
    assert len(native_scenes) == len(SCENES), native_scenes


@pytest.mark.parametrize("lit", [False, True])
def test_refined_segments_in_the_native_march(lit):
    # test_refine.py's thin helix under a step transfer function: many
    # segments cross the threshold where their ramp does not see it.
    from test_refine import config as refine_config
    from test_refine import helix_scene

    r = helix_scene(lit)
    r.native_march = True
    plain, _ = both(r, refine_config(r, 0.01, 0))
    native, shader = both(r, refine_config(r, 0.01, 8))
    assert_same(native, shader, f"refined, lit={lit}")
    # Refined segments take 8 samples where unrefined ones take one.
    assert native[1]["samples"] > 1.02 * plain[1]["samples"]
    assert np.abs(native[0] - plain[0]).max() > 2 * LEVEL


@pytest.mark.parametrize("precision, lit", [("fixed16", True), ("float32", False)])
def test_native_march_matches_the_shader_where_it_prefetches(precision, lit):
    # Over 16 MiB of texels (136^3 with 8-byte normals and values, 168^3
    # float32 values) seen by 24x20 rays, which lie several voxels apart:
    # the march prefetches each next sample's texels (src/cpu/avx2.rs
    # `prefetches`), which must change nothing it reads.
    n = 136 if lit else 168
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, n, dtype=np.float32)] * 3, indexing="ij", sparse=True)
    data = (0.5 + 0.5 * np.sin(4 * x) * np.cos(3 * y) * np.sin(5 * z + 1)).astype(np.float32)
    normals = compute_normal_volume(data) if lit else None
    light = Light.directional([-0.6, -0.3, -0.8], ambient=0.25, diffuse=0.75) if lit else Light.ambient_only(0.9)
    r = VolumeRenderer(24, 20, config=RenderConfig.balanced(), light=light)
    r.load_volume(Volume(data, normals, *BOX), precision=precision)
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.3, 0.2))
    r.set_camera(OUTSIDE)
    for name in ("balanced", "pre_integrated", "long_steps"):
        native, shader = both(r, RenderConfig.balanced().replace(**CONFIGS[name]))
        assert_same(native, shader, f"{precision}, {name}")
