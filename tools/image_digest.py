"""Digests of the engine's frames on a fixed set of scenes: the
cross-validation scenes, each with every optical model and option the
shader has (shadows, jitter, pre-integration, both orders, float16
storage, value maps, crop), as float32 premultiplied RGBA bytes.

A change meant to keep behaviour (a refactor) must leave every digest
unchanged: run before and after and compare.

Run: .venv/bin/python tools/image_digest.py out/digest.json
     .venv/bin/python tools/image_digest.py out/digest-after.json --compare out/digest.json
"""

import hashlib
import json
import os
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from test_cross_validation import SCENES, scene  # noqa: E402

from pyvr import VolumeRenderer  # noqa: E402

VARIANTS = {
    "as_is": {},
    "absorption": dict(model="absorption"),
    "emission": dict(model="emission"),
    "mip": dict(model="mip"),
    "average": dict(model="average"),
    "isosurface": dict(model="isosurface", iso_value=0.4),
    "shadows": dict(model="single_scattering", anisotropy=0.3, shadow_step_size=0.03),
    "jitter": dict(jitter=True, jitter_seed=7),
    "preintegrated": dict(pre_integrated=True),
    "back_to_front": dict(order="back_to_front", early_ray_termination=False),
}


def frames():
    for name in SCENES:
        vol, ctf, otf, cam, light, cfg = scene(name)
        for variant, fields in VARIANTS.items():
            for precision in ("float32", "float16"):
                r = VolumeRenderer(40, 32, config=cfg.replace(**fields), light=light)
                r.load_volume(vol, precision=precision)
                r.set_camera(cam)
                r.set_transfer_functions(ctf, otf)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    yield f"{name}/{variant}/{precision}", r.render(dtype=np.float32, premultiplied=True)
                    if variant == "as_is":
                        r.set_transfer_functions(ctf, otf, value_range=(-0.2, 1.3))
                        r.set_crop_box((-0.3, -1, -1), (1, 0.4, 0.5))
                        yield f"{name}/value_map_crop/{precision}", r.render(dtype=np.float32, premultiplied=True)


def main(out, compare=None):
    digests = {k: hashlib.sha256(img.tobytes()).hexdigest() for k, img in frames()}
    with open(out, "w") as f:
        json.dump(digests, f, indent=1, sort_keys=True)
    print(f"{len(digests)} frames -> {out}")
    if compare:
        with open(compare) as f:
            before = json.load(f)
        changed = [k for k in before if digests.get(k) != before[k]]
        print(f"compared with {compare}: {len(before) - len(changed)} identical, {len(changed)} changed")
        for k in changed:
            print("  changed:", k)
        sys.exit(1 if changed else 0)


if __name__ == "__main__":
    args = sys.argv[1:]
    cmp = args[args.index("--compare") + 1] if "--compare" in args else None
    main(args[0] if args else "out/digest.json", cmp)
