"""What a pre-integrated segment's ramp can resolve: the opacity of rays
through the accuracy benchmark's narrow-peaks scene (the 128^3 torus under
three peaks 0.04 wide) by five rules a segment might use, against the
integral of the trilinear values themselves.

Pre-integration takes the values between a segment's two ends as a ramp.
The trilinear interpolant of a smooth field is not one: its slope along a
ray changes at every voxel face it crosses, by about the field's curvature
times a voxel (10-30% of the slope at the three peaks here), so the ramp
takes the values to cross a peak at the wrong speed and gives it the wrong
opacity. The rules:

- midpoint: the transfer function at each segment's middle (a plain frame);
- ramp: the ramp between the two ends (a pre-integrated frame);
- estimated middle: two ramps, through a middle value estimated from the
  four nearest ends (Catmull-Rom), which costs no volume read;
- read middle: two ramps through the value read at the middle, a second
  read per segment (a pre-integrated frame at half the step, in samples);
- slopes' middle: two ramps through the middle of the cubic that has each
  end's value and slope along the ray, the slope being the trilinear
  interpolant's own inside the end's cell, from the eight voxels its read
  takes anyway (no second read; a second table read per segment).

Each is scored by the largest and the 99th-percentile error of the rays'
opacity, in 8-bit levels, with the float64 arithmetic of numpy and scipy
(no renderer), so that only the rule differs. A rule that reached 4 levels
at twice pre-integration's step without a second read would make
pre-integrated frames of this scene twice as cheap at that error.

Run: .venv/bin/python benches/ramp_limit.py [--rays N]
"""

import argparse
import os
import sys

import numpy as np
from scipy.ndimage import map_coordinates

sys.path.insert(0, os.path.dirname(__file__))
from _report import write_table  # noqa: E402
from pyvr.datasets import create_sample_volume  # noqa: E402
from pyvr.transferfunctions import OpacityTransferFunction  # noqa: E402

SIZE = 128  # the accuracy benchmark's torus at full size
REFERENCE_STEP = 0.01  # pyvr's opacity is per this much of a ray (world units)
FINE = 2e-5  # the reference's step: 0.0013 voxel
STEPS = [0.0025, 0.005, 0.007, 0.01, 0.014]
LEVELS = 255.0


def opacity_integral(lut):
    """The antiderivative of the piecewise-linear opacity over [0, 1],
    exact at the entries and in between (a quadratic per interval)."""
    x = np.linspace(0.0, 1.0, len(lut))
    widths = np.diff(x)
    at_entries = np.concatenate([[0.0], np.cumsum(widths * (lut[:-1] + lut[1:]) / 2)])

    def integral(v):
        v = np.clip(v, 0.0, 1.0)
        k = np.minimum((v * (len(lut) - 1)).astype(int), len(lut) - 2)
        d = v - x[k]
        slope = (lut[k + 1] - lut[k]) / widths[k]
        return at_entries[k] + lut[k] * d + slope * d * d / 2

    return integral


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rays", type=int, default=600, help="rays through the ring (default 600)")
    args = ap.parse_args()
    if args.rays < 10:
        ap.error(f"--rays must be at least 10 (a 99th percentile of fewer says little), got {args.rays}")
    vol = create_sample_volume(SIZE, "torus").astype(np.float64)
    lut = OpacityTransferFunction.peaks([0.25, 0.5, 0.75], opacity=0.6, eps=0.02).to_lut().astype(np.float64)
    entries = np.linspace(0.0, 1.0, len(lut))
    integral = opacity_integral(lut)
    voxel = 2.0 / SIZE  # the box spans [-1, 1], as in the accuracy benchmark
    rng = np.random.default_rng(7)

    def values(origin, direction, t):
        p = origin[None] + t[:, None] * direction[None]
        # World x runs along numpy axis 0 (pyvr's volumes are (x, y, z));
        # texel centres lie half a voxel in from the box's faces, and
        # 'nearest' clamps to the edge texels, as the renderer's sampler does.
        idx = (p + 1.0) / voxel - 0.5
        return map_coordinates(vol, idx.T, order=1, mode="nearest")

    def slopes(origin, direction, t):
        """d/dt of the trilinear values at ray parameters t: the gradient of
        the interpolant inside each point's cell (zero along an axis where
        the point lies beyond the edge texels' centres, as 'nearest' clamps)."""
        idx = ((origin[None] + t[:, None] * direction[None]) + 1.0) / voxel - 0.5
        lo = np.clip(np.floor(idx).astype(int), 0, SIZE - 2)
        f = idx - lo
        inside = (idx >= 0) & (idx <= SIZE - 1)
        f = np.clip(f, 0.0, 1.0)
        corner = {(a, b, c): vol[lo[:, 0] + a, lo[:, 1] + b, lo[:, 2] + c]
                  for a in (0, 1) for b in (0, 1) for c in (0, 1)}
        total = np.zeros(len(t))
        for k in range(3):
            # The difference across axis k, interpolated along the other two.
            g = np.zeros(len(t))
            for key, v in corner.items():
                w = np.prod([f[:, j] if key[j] else 1.0 - f[:, j] for j in range(3) if j != k], axis=0)
                g += (v if key[k] else -v) * w
            total += np.where(inside[:, k], g, 0.0) * direction[k] / voxel
        return total

    def depth(vf, vb, h):
        """Optical depth of ramps from vf to vb over h."""
        flat = np.abs(vb - vf) < 1e-9
        dv = np.where(flat, 1.0, vb - vf)
        mean = np.where(flat, np.interp((vf + vb) / 2, entries, lut), (integral(vb) - integral(vf)) / dv)
        return mean * h / REFERENCE_STEP

    rules = ["midpoint", "ramp", "estimated middle", "read middle", "slopes' middle"]
    errors = {(h, r): [] for h in STEPS for r in rules}
    view = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)  # the benchmark's isometric view
    for _ in range(args.rays):
        # A ray along (about) the view through a random point of the tube.
        a = rng.uniform(0, 2 * np.pi)
        target = np.array([0.6 * np.cos(a), 0.6 * np.sin(a), 0.0]) + rng.normal(scale=0.04, size=3)
        d = view + rng.normal(scale=0.05, size=3)
        d /= np.linalg.norm(d)
        origin = target - 0.5 * d
        # The part of the ray where the torus is above a value no peak reaches.
        coarse = np.arange(0.0, 1.0, 0.004)
        inside = coarse[values(origin, d, coarse) > 1e-3]
        if len(inside) == 0:
            continue
        t0, t1 = inside[0] - 0.05, inside[-1] + 0.05
        for h in STEPS:
            phase = rng.uniform(0, h)
            ends = t0 - phase + h * np.arange(-1, int((t1 - t0) / h) + 4)
            v = values(origin, d, ends)
            # Segments [ends[k], ends[k + 1]] for k = 1 .. len - 3 (each has a
            # neighbouring end on both sides for the estimated middle).
            k = np.arange(1, len(ends) - 2)
            vf, vb = v[k], v[k + 1]
            fine = np.arange(ends[1], ends[-2], FINE) + FINE / 2
            exact = np.interp(values(origin, d, fine), entries, lut).sum() * FINE / REFERENCE_STEP
            read = values(origin, d, ends[k] + h / 2)
            guess = (-v[k - 1] + 9 * vf + 9 * vb - v[k + 2]) / 16
            s_ends = slopes(origin, d, ends)
            cubic = (vf + vb) / 2 + h * (s_ends[k] - s_ends[k + 1]) / 8
            depths = {
                "midpoint": (np.interp(read, entries, lut) * h / REFERENCE_STEP).sum(),
                "ramp": depth(vf, vb, h).sum(),
                "estimated middle": (depth(vf, guess, h / 2) + depth(guess, vb, h / 2)).sum(),
                "read middle": (depth(vf, read, h / 2) + depth(read, vb, h / 2)).sum(),
                "slopes' middle": (depth(vf, cubic, h / 2) + depth(cubic, vb, h / 2)).sum(),
            }
            for r in rules:
                errors[h, r].append(abs(np.exp(-depths[r]) - np.exp(-exact)) * LEVELS)
    rows = []
    for h in STEPS:
        row = [h, round(h / voxel, 2)]
        for r in rules:
            e = np.array(errors[h, r])
            row.append(f"{e.max():.2f} / {np.percentile(e, 99):.2f}")
        rows.append(row)
        print(row, flush=True)
    note = (f"{args.rays} rays along about the isometric view through the ring of create_sample_volume({SIZE}, 'torus'), "
            "OpacityTransferFunction.peaks([0.25, 0.5, 0.75], opacity=0.6, eps=0.02); each ray's opacity by each rule "
            f"against the trilinear values integrated at step {FINE:g}, in 8-bit levels (float64, no renderer; "
            "a random phase of the segments per ray and step).")
    columns = ["step", "voxels"] + [f"{r}: max / p99" for r in rules]
    write_table("ramp_limit", f"benches/ramp_limit.py --rays {args.rays}", columns, rows, note=note)


if __name__ == "__main__":
    main()
