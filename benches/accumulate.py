"""Progressive refinement: error and time of render(accumulate=n) against
the converged image (the f64 integrator at step 2e-4), for unbiased frames
(Poisson points, whose mean converges to it) and jittered midpoint frames
(whose mean keeps a bias), against one unjittered frame at the same step,
one frame at an n times smaller step (the other way to spend the time), and
pre-integrated frames alone and accumulated. 128^3 torus, three narrow
opacity peaks (where banding is worst), 256x256, step 0.02 (the fast
preset's). Besides the RMS and max errors, each row gives the mean signed
error (the bias, where the mean over pixels shows it) and, for accumulated
rows, the RMS error 1/sqrt(n) of the n = 1 frame's would predict.

    .venv/bin/python benches/accumulate.py

Prints the table and writes out/accumulate.json (docs/rendering.md's table).
"""

import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import create_sample_volume  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402


def main() -> None:
    warnings.simplefilter("ignore")
    cfg = RenderConfig(step_size=0.02, max_steps=500)
    r = VolumeRenderer(256, 256, config=cfg, light=Light.ambient_only(1.0))
    r.load_volume(Volume(create_sample_volume(128, "torus")))
    r.set_camera(Camera.from_spherical(target=np.zeros(3), distance=3.0, azimuth=0.6, elevation=0.5, roll=0.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                             OpacityTransferFunction.peaks([0.3, 0.5, 0.7], opacity=0.5, eps=0.02))
    exact = r.render_float64(premultiplied=True, progress=False,
                             config=RenderConfig(step_size=2e-4, max_steps=100_000, early_ray_termination=False))

    def mean_of(config, n):
        """The mean of n frames of `config` with consecutive seeds."""
        frames = (r.render(dtype=np.float32, premultiplied=True, config=config.replace(jitter_seed=k))
                  for k in range(n))
        return sum(f.astype(np.float64) for f in frames) / n

    def measure(config, n):
        # accumulate=n takes unbiased frames where it can; jittered midpoint
        # frames are averaged here, the same way.
        def one():
            if n == 1 or config.unbiased or config.pre_integrated:
                return r.render(dtype=np.float32, premultiplied=True, config=config, accumulate=n)
            return mean_of(config, n)

        one()  # warm
        times, img = [], None
        for _ in range(3):
            t = time.perf_counter()
            img = one()
            times.append((time.perf_counter() - t) * 1000)
        d = (img - exact) * 255
        return float(np.median(times)), float(np.sqrt(np.mean(d**2))), float(d.mean()), float(np.abs(d).max())

    rows = []

    def series(label, ns, config=cfg):
        first = None
        for n in ns:
            ms, rms, bias, mx = measure(config, n)
            first = rms if first is None else first
            predicted = "" if n == 1 else round(first / np.sqrt(n), 2)
            rows.append([label, n, round(ms, 1), round(rms, 2), predicted, round(bias, 3), round(mx, 1)])

    series("no jitter", (1,))
    # Poisson points: each frame's expectation is the exact integral.
    series("unbiased", (1, 4, 16, 64, 256), config=cfg.replace(unbiased=True))
    # The jittered midpoint frames' mean converges to the mean over grid offsets.
    series("jitter", (1, 4, 16, 64), config=cfg.replace(jitter=True))
    # The other way to spend n frames' time: an n times smaller step.
    for n in (4, 16, 64):
        series(f"no jitter, step / {n}", (1,), config=RenderConfig(step_size=0.02 / n, max_steps=500 * n))
    # Pre-integrated segments integrate the peaks a midpoint misses; the
    # jittered mean then has far less banding to average away.
    series("pre-integrated, jitter", (1, 4, 16, 64), config=cfg.replace(pre_integrated=True, jitter=True))
    for row in rows:
        print(*row, sep="\t")
    write_table("accumulate", "python benches/accumulate.py",
                ["frames", "n", "ms (median of 3, warm)", "RMS error, levels", "RMS predicted by 1/sqrt(n)",
                 "mean error, levels", "max error, levels"], rows,
                device=r.device,
                note="128^3 torus, peaks([0.3, 0.5, 0.7], opacity=0.5, eps=0.02), 256x256, ambient light, step 0.02; "
                     "errors in 8-bit levels of premultiplied RGBA against the f64 integrator at step 2e-4.")


if __name__ == "__main__":
    main()
