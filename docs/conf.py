"""Sphinx configuration of pyvr's documentation site: the user guide
(the Markdown pages in this folder), an API reference generated from the
installed package's docstrings, and a gallery in which every example in
examples/ runs and its pictures are captured. Built by scripts/docs.sh
with warnings as errors."""

import os
import sys
import time

import pyvr

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

project = "pyvr"
author = "pyvr developers"
release = pyvr.__version__
version = release
copyright = f"{time.gmtime().tm_year}, {author}"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip", "gallery/*.json"]
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
html_theme = "alabaster"
html_title = f"pyvr {release}"
html_static_path = []

# Types come from the signatures and the docstrings' prose; the reference
# lists members in the order the source defines them.
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "show-inheritance": True}
napoleon_numpy_docstring = True
napoleon_google_docstring = True

os.environ.setdefault("PYVR_OUT", os.path.join(HERE, "_build", "example-output"))
os.makedirs(os.environ["PYVR_OUT"], exist_ok=True)
sys.path.insert(0, HERE)  # gallery_hooks
sys.path.insert(0, os.path.join(ROOT, "examples"))  # the examples import their _common helpers

sphinx_gallery_conf = {
    "examples_dirs": os.path.join(ROOT, "examples"),
    "gallery_dirs": "gallery",
    "filename_pattern": r".*\.py$",  # run every example
    "ignore_pattern": r"_common\.py$",
    "image_scrapers": ("gallery_hooks.scrape_pictures",),
    "reset_argv": "gallery_hooks.example_argv",
    "download_all_examples": False,
    "plot_gallery": "True",
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
}
