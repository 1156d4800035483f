"""Sphinx configuration of the rvflex documentation site.

Build (what CI runs, warnings are errors)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are MyST markdown (myst-parser): the hand-written docs/*.md files are the user
guide as they are; the API reference is generated from the numpydoc docstrings (autodoc +
numpydoc); the gallery runs the scripts in docs/examples/ at build time (sphinx-gallery).
"""

from __future__ import annotations

import os

import rvflex

project = "rvflex"
author = "the rvflex authors"
copyright = "2026, the rvflex authors"  # noqa: A001 -- Sphinx's name
release = version = rvflex.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "examples", "**/*.ipynb", "results/**"]  # results/table.md: included by diagnosis.md

# MyST: heading anchors make ``page.md#section`` links resolvable, so -W checks them too
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath", "colon_fence"]

# autodoc + numpydoc: the docstrings are numpydoc (tests/test_docstrings.py checks them)
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc sections state the types (with units)
autosummary_generate = False
numpydoc_show_class_members = False  # members are listed by autodoc's :members:
numpydoc_xref_param_type = False

# sphinx-gallery: quick rigid examples, run at every build (each a few seconds)
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": (),
    "capture_repr": (),
    "write_computation_times": False,
}

html_theme = "pydata_sphinx_theme"
html_title = "rvflex"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path: list[str] = []
os.environ.setdefault("MPLBACKEND", "Agg")
