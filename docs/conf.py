"""Sphinx configuration: exoleg's documentation site -- the guides and references
(Markdown, through MyST) and the API reference generated from the code's docstrings
(autodoc and autosummary; napoleon reads their numpydoc sections).

Why Sphinx: it is what the scientific Python projects a lab reads every day document
themselves with (NumPy, SciPy, Matplotlib, python-control, Pinocchio's Python
bindings), its autodoc reads the code's docstrings and Sphinx roles as written, and
numpydoc -- their docstring standard -- comes with a validator the suite runs.

Build: ``make docs``, or ``.venv/bin/python -m sphinx -W -b html docs docs/_build/html``
(the test suite does it with warnings as errors: ``tests/test_docs_site.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

project = "exoleg"
author = "the exoleg developers"
copyright = "2026, the exoleg developers"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary",
              "sphinx.ext.napoleon", "sphinx.ext.viewcode", "sphinx.ext.mathjax"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "api/generated/*.md"]
# the README is the site's landing page and the repository's; the guides link files of
# the checkout (examples, benchmarks, the source): shown as code, not followed
myst_heading_anchors = 3
suppress_warnings = ["myst.xref_missing"]

autosummary_generate = True
autosummary_imported_members = False
# a package page documents what it defines; what it re-exports is documented where defined
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
napoleon_google_docstring = True  # a few records still say "Attributes:"
napoleon_numpy_docstring = True

html_theme = "alabaster"
html_static_path: list[str] = []
html_title = "exoleg"
