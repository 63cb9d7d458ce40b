"""Sphinx configuration of the rvtool documentation.

Why Sphinx + MyST: Sphinx is the Python ecosystem's documentation convention (NumPy, SciPy,
PyBaMM, Warp use it); autodoc with napoleon reads rvtool's numpy-style docstrings into the API
reference, and MyST lets every page stay Markdown, the format the rest of the project writes.
Build (warnings are errors, as in tests/test_docs.py)::

    python -m sphinx -W -b html docs docs/_build/html

Generated at build time, never committed: the design-file reference (from
rvtool/designs/format.py), the changelog's fragment list (docs/changelog.d/*.md) and every
table and figure read from the committed results.json files under docs/case_results/
(docs/_ext/rvtool_docs.py).
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))
sys.path.insert(0, os.path.dirname(HERE))          # the checkout's rvtool, not an installed copy

project = "rvtool"
author = "rvtool contributors"
copyright = "rvtool contributors, MIT licence"
from rvtool import __version__ as release          # noqa: E402  (light: rvtool/__init__ imports nothing)
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "myst_parser",
    "rvtool_docs",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_generated", "changelog.d", "case_results", "Thumbs.db", ".DS_Store"]
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3
# The history pages are the old README's sections verbatim: their headings start at any level.
# Glob toctrees of the sections other contributors fill may match nothing yet.
suppress_warnings = ["myst.header", "toc.empty_glob"]

autodoc_typehints = "description"
autodoc_member_order = "bysource"
# Heavy imports (Exudyn, Warp, NGSolve) are only made inside functions in rvtool; the modules
# autodoc imports stay light. Nothing is mocked: a renamed object fails the build.
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
nitpicky = False

html_theme = "alabaster"          # built into Sphinx: no extra dependency
html_title = f"rvtool {release}"
html_static_path = []
html_theme_options = {"description": "Precision gear reducers on Exudyn + Warp", "page_width": "1100px",
                      "sidebar_width": "240px"}
