"""How the documentation's gallery runs the examples (docs/conf.py names
these by their qualified names, so Sphinx can cache its configuration).

The examples save their pictures into ``PYVR_OUT`` (examples/_common.py)
rather than showing matplotlib figures, and take command-line options."""

import glob
import os
import shutil

# Each example's options for the build: small enough to keep it to minutes on a CPU.
ARGS = {
    "benchmark.py": ["--frames", "1", "--size", "256"],
    "animation.py": ["--size", "200", "--frames", "24"],
    "progressive.py": ["--size", "256"],
}

_seen = {}


def out_dir():
    return os.environ["PYVR_OUT"]


def example_argv(gallery_conf, script_vars):
    """The options an example runs with (sphinx-gallery's ``reset_argv``)."""
    name = os.path.basename(script_vars["src_file"])
    args = list(ARGS.get(name, []))
    if name == "interactive.py":
        args += ["--screenshot", os.path.join(out_dir(), "interface.png")]
    if name == "animation.py":
        args += ["--out", os.path.join(out_dir(), "orbit.gif")]
    return args


def scrape_pictures(block, block_vars, gallery_conf):
    """An image scraper: the pictures written to ``PYVR_OUT`` since the
    last code block join the gallery, in name order."""
    from sphinx_gallery.scrapers import figure_rst

    names = []
    paths = sorted(glob.glob(os.path.join(out_dir(), "*.png")) + glob.glob(os.path.join(out_dir(), "*.gif")))
    for path in paths:
        stamp = os.path.getmtime(path)
        if _seen.get(path) == stamp:
            continue
        _seen[path] = stamp
        target = os.path.splitext(next(block_vars["image_path_iterator"]))[0] + os.path.splitext(path)[1]
        shutil.copyfile(path, target)
        names.append(target)
    return figure_rst(names, gallery_conf["src_dir"])
