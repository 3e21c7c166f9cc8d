"""pyvr 0.4.1's synthetic volumes, formula for formula.

The grid comes from ``np.meshgrid(L, L, L)`` with numpy's default 'xy'
indexing, so a formula's ``x`` varies along numpy axis 1 (world y) and its
``y`` along axis 0 (world x); kept so images match pyvr's.
"""

import numpy as np

SHAPES = "sphere, torus, double_sphere, cube, helix, random_blob"


def create_sample_volume(size: int = 64, shape: str = "sphere") -> np.ndarray:
    """A (size, size, size) float32 volume with values in [0, 1]."""
    lin = np.linspace(-1, 1, size)
    x, y, z = np.meshgrid(lin, lin, lin)
    if shape == "sphere":
        r = np.sqrt(x**2 + y**2 + z**2)
        v = np.exp(-((3 * r) ** 2))
    elif shape == "torus":
        big, small = 0.6, 0.3
        q = np.sqrt(x**2 + y**2)
        t = np.sqrt((q - big) ** 2 + z**2)
        v = np.exp(-((4 * t / small) ** 2))
    elif shape == "double_sphere":
        r1 = np.sqrt((x - 0.3) ** 2 + y**2 + z**2)
        r2 = np.sqrt((x + 0.3) ** 2 + y**2 + z**2)
        v = np.maximum(np.exp(-((4 * r1) ** 2)), np.exp(-((4 * r2) ** 2)))
    elif shape == "cube":
        c = np.maximum(np.maximum(np.abs(x), np.abs(y)), np.abs(z))
        v = np.exp(-((8 * (c - 0.4)) ** 2))
        v[c > 0.6] = 0
    elif shape == "helix":
        radius, thickness, turns = 0.5, 0.15, 3
        hx = radius * np.cos(2 * np.pi * turns * z)
        hy = radius * np.sin(2 * np.pi * turns * z)
        dist = np.sqrt((x - hx) ** 2 + (y - hy) ** 2)
        v = np.exp(-((3 * dist / thickness) ** 2))
    elif shape == "random_blob":
        from scipy.ndimage import gaussian_filter

        # pyvr's values (seed 42, the legacy generator), without reseeding
        # numpy's global generator as pyvr did.
        rng = np.random.RandomState(42)
        off = rng.uniform(-1, 1, 3)
        xs, ys, zs = x + 0.5 * off[0], y + 0.5 * off[1], z + 0.5 * off[2]
        noise = rng.random_sample((size, size, size)).astype(np.float32)
        noise = gaussian_filter(noise, sigma=size / 18)
        g = (xs + 1.5) * (ys + 1.2) * (zs + 0.8)
        g = g / np.max(np.abs(g))
        v = noise * (0.7 + 0.3 * g)
        v = np.maximum(0, v - 0.25) * 2.5
        for _ in range(3):
            cx, cy, cz = rng.uniform(-0.7, 0.7, 3)
            amp = rng.uniform(0.5, 1.2)
            d = np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2)
            v = v + np.exp(-((6 * d) ** 2)) * amp
        v = np.clip(v, 0, 1)
    else:
        raise ValueError(f"Unknown shape: {shape}. Available shapes: {SHAPES}")
    return v.astype(np.float32)


# The modified 3-D Shepp–Logan head phantom (Kak and Slaney's ellipsoids
# with Toft's higher-contrast intensities): intensity added inside each
# ellipsoid, semi-axes (a, b, c), centre (x0, y0, z0), rotation phi about z
# in degrees. Values in [0, 1]: skull 1, brain 0.2, features 0.1 to 0.4.
_SHEPP_LOGAN = [
    (1.0, 0.6900, 0.920, 0.810, 0.0, 0.0, 0.0, 0.0),
    (-0.8, 0.6624, 0.874, 0.780, 0.0, -0.0184, 0.0, 0.0),
    (-0.2, 0.1100, 0.310, 0.220, 0.22, 0.0, 0.0, -18.0),
    (-0.2, 0.1600, 0.410, 0.280, -0.22, 0.0, 0.0, 18.0),
    (0.1, 0.2100, 0.250, 0.410, 0.0, 0.35, -0.15, 0.0),
    (0.1, 0.0460, 0.046, 0.050, 0.0, 0.1, 0.25, 0.0),
    (0.1, 0.0460, 0.046, 0.050, 0.0, -0.1, 0.25, 0.0),
    (0.1, 0.0460, 0.023, 0.050, -0.08, -0.605, 0.0, 0.0),
    (0.1, 0.0230, 0.023, 0.020, 0.0, -0.606, 0.0, 0.0),
    (0.1, 0.0230, 0.046, 0.020, 0.06, -0.605, 0.0, 0.0),
]


def shepp_logan_3d(size: int = 128) -> np.ndarray:
    """A (size, size, size) float32 Shepp–Logan head phantom, ``data[i, j, k]``
    at world (x, y, z) on the cell centres of [-1, 1]^3: a dense, CT-like
    volume with sharp edges."""
    c = (np.arange(size, dtype=np.float64) + 0.5) / size * 2 - 1
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    v = np.zeros((size, size, size), np.float64)
    for amp, a, b, cc, x0, y0, z0, phi in _SHEPP_LOGAN:
        t = np.deg2rad(phi)
        dx, dy, dz = x - x0, y - y0, z - z0
        u = dx * np.cos(t) + dy * np.sin(t)
        w = -dx * np.sin(t) + dy * np.cos(t)
        v += amp * ((u / a) ** 2 + (w / b) ** 2 + (dz / cc) ** 2 <= 1.0)
    return np.clip(v, 0.0, 1.0).astype(np.float32)


def compute_normal_volume(volume: np.ndarray) -> np.ndarray:
    """Unit gradient directions (toward increasing value), shape volume.shape + (3,).

    Index-space central differences (np.gradient); flat regions give (0, 0, 0).
    """
    g0, g1, g2 = np.gradient(volume)
    g = np.stack([g0, g1, g2], axis=-1)
    norm = np.linalg.norm(g, axis=-1, keepdims=True)
    return (g / (norm + 1e-8)).astype(np.float32)
