"""One rule for NaN and infinity, the same in the shader and the f64
integrator (docs/numerics.md, "Missing and infinite values"):

- NaN is missing data: a sample whose eight trilinear neighbours include a
  NaN is empty, and a gradient with a NaN among its six samples has no
  direction (ambient light only). Masked voxels are NaN.
- +-inf is stored as +-f32::MAX / 16: after the transfer function's clamp it
  is the domain's end, and next to finite values it interpolates without
  making NaN (inf * 0).
- Gradients use only their direction, so huge finite values (fill values
  such as 1e20, or NetCDF's 9.97e36) shade as the f64 integrator does.

Each case compares the GPU frame with render_float64 on the same scene: the
tolerance is the engine's usual 2 levels (f32 against f64 sums, one
rounding each)."""

import numpy as np
import pytest

from pyvr import RenderConfig
from pyvr.lighting import Light
from pyvr.transferfunctions import OpacityTransferFunction
from pyvr.volume import Volume
from scenes import blob, frame, make_renderer

TOL = 2.5 / 255


def gpu_vs_f64(volume, **kw):
    r = make_renderer(volume, **kw)
    gpu = frame(r)
    ref = r.render_float64(premultiplied=True)
    return np.abs(gpu - ref).max(), r


def sprinkled(values, fraction, seed):
    data = blob((24, 24, 24), width=0.6)
    rs = np.random.RandomState(seed)
    idx = rs.rand(*data.shape) < fraction
    data[idx] = rs.choice(values, size=int(idx.sum()))
    return data


@pytest.mark.parametrize("values", [[np.nan], [np.inf, -np.inf], [np.nan, np.inf, -np.inf]])
@pytest.mark.parametrize("lit", [False, True])
def test_sprinkled_nan_and_inf_match_the_f64_integrator(values, lit):
    data = sprinkled(values, 0.03, seed=len(values))
    light = Light.directional([1, -1, 0.5]) if lit else Light.ambient_only(1.0)
    err, _ = gpu_vs_f64(Volume(data), light=light)
    assert err < TOL, err * 255


# Faint opacity, so that what lies behind the odd voxels shows.
FAINT = OpacityTransferFunction.linear(0.0, 0.05)


@pytest.mark.parametrize("corner", [(0, 0, 0), (1, 12, 12), (23, 0, 11), (23, 23, 23)])
def test_one_nan_voxel_at_an_edge(corner):
    # (1, 12, 12) was 2.8 levels off before NaN volumes were filtered in the shader.
    data = blob((24, 24, 24), width=0.9)
    data[corner] = np.nan
    err, r = gpu_vs_f64(Volume(data), light=Light.directional([0, 0, -1]), otf=FAINT)
    assert err < TOL, err * 255


@pytest.mark.parametrize("fill", [1e20, 9.969209968386869e36, np.inf, -1e20])
@pytest.mark.parametrize("where", ["block", "voxel"])
def test_a_fill_value_in_a_lit_volume_shades_as_in_f64(fill, where):
    # Before gradients were scaled before their length: 22-41 levels off.
    data = blob((24, 24, 24), width=0.6)
    if where == "block":
        data[5:8, 10:14, 10:14] = fill
    else:
        data[12, 12, 12] = fill
    err, _ = gpu_vs_f64(Volume(data), light=Light.directional([1, -1, 0.5]), otf=FAINT)
    assert err < TOL, err * 255


def test_masked_voxels_are_empty_like_nan():
    data = blob((20, 20, 20), width=0.6)
    mask = np.zeros(data.shape, bool)
    mask[8:12, :, :] = True
    masked = np.ma.MaskedArray(data, mask=mask)
    nan = data.copy()
    nan[mask] = np.nan
    a = frame(make_renderer(Volume(masked)))
    b = frame(make_renderer(Volume(nan)))
    c = frame(make_renderer(Volume(data)))
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() > 0.05  # the mask is not ignored
    assert not np.ma.is_masked(masked.data)  # the caller's array is untouched
    assert masked.mask.sum() == mask.sum()


def test_masked_integers_keep_their_values():
    data = (blob((16, 16, 16), width=0.6) * 255).astype(np.uint8)
    masked = np.ma.MaskedArray(data, mask=np.zeros(data.shape, bool))
    masked.mask[0, 0, 0] = True
    a = frame(make_renderer(Volume(masked)))
    b = frame(make_renderer(Volume(data)))
    # Only rays through the masked corner voxel's neighbourhood may differ.
    assert np.abs(a - b).max() < 0.05 and (np.abs(a - b) > 1e-6).mean() < 0.2


@pytest.mark.parametrize("model", ["mip", "minip", "average", "isosurface"])
def test_projections_and_isosurface_skip_nan_as_in_f64(model):
    data = sprinkled([np.nan], 0.05, seed=3)
    cfg = RenderConfig.balanced().replace(model=model, iso_value=0.5)
    err, _ = gpu_vs_f64(Volume(data), config=cfg)
    assert err < TOL, err * 255


@pytest.mark.parametrize("scale, expected", [
    (1e-300, "is narrower than float32, which the engines sample, can resolve"),  # float32 reads zero
    (1e-40, "is narrower than float32, which the engines sample, can resolve"),   # subnormal: GPUs flush it
    (1e300, "past float32's largest"),                                              # float32 reads inf
])
def test_float_data_outside_float32_is_refused_before_anything_changes(scale, expected):
    # The data's own value range 1e-300 wide rendered an empty frame on both
    # engines and the float64 integrator; 1e-40 wide rendered empty where
    # the integrator drew the volume (245 levels apart).
    from pyvr import VolumeRenderer
    from pyvr.volume import Volume

    x = np.linspace(-1, 1, 12)
    base = np.exp(-3 * (x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2))
    r = VolumeRenderer(24, 20)
    kept = Volume(base.astype(np.float32))
    r.load_volume(kept)
    tiny = Volume(base * scale)
    tiny.value_range = (0.0, float(scale))
    with pytest.raises(ValueError, match=expected):
        r.load_volume(tiny)
    assert r.get_volume() is kept
    # pyvr's [0, 1] rule reads such values as the 0 they nearly are.
    if scale < 1:
        tiny.value_range = None
        r.load_volume(tiny)
        assert r.render()[..., 3].max() == 0
    # Data within float32's range, however small or large, renders as the
    # float64 integrator does.
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction

    for ok in (1e-30, 1e30):
        r.load_volume(Volume(base * ok))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0, 0.5),
                                 value_range=(0.0, ok))
        img = r.render(dtype=np.float32, premultiplied=True)
        assert img[..., 3].max() > 0.5
        assert np.abs(img - r.render_float64(premultiplied=True)).max() * 255 < 0.01
