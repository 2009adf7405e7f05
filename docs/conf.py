"""Sphinx configuration of the ced documentation (``make docs`` builds it with ``-W``).

The pages are MyST Markdown; the API reference is generated from the numpy-style docstrings
(autosummary + numpydoc); the example gallery runs every script in ``examples/`` at build
time (sphinx-gallery), so a broken example fails the build. The reference pages in
``docs/reference/`` are generated from the code (``python -m ced.study.reference``) and checked
by ``tests/test_docs_reference.py``.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # the gallery's figures, without a display

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("PYTHONHASHSEED", "0")

import ced  # noqa: E402

project = "ced"
author = "ced developers"
copyright = "2026, ced developers"
version = release = ced.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.md5", "auto_examples/*.json",
                    "**/sg_execution_times.rst", "sg_execution_times.rst"]

myst_enable_extensions = ["dollarmath", "amsmath", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

intersphinx_mapping = {}  # no network at build time: links to xarray etc. are plain text

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "show_memory": False,
    "plot_gallery": "True",
}

html_theme = "pydata_sphinx_theme"
html_title = f"ced {release}"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}
html_static_path: list[str] = []

nitpicky = False
templates_path = ["_templates"]

def plain_text_math(app, what, name, obj, options, lines) -> None:
    """Docstrings write math as plain text: ``|x|`` is an absolute value and ``(*batch, n)`` a
    shape, never a reST substitution or emphasis (ced uses neither). Escape ``|`` and ``(*``
    outside literal text (inline ````code````, ``>>>`` examples, ``::`` blocks)."""
    literal_indent = None  # indentation of the paragraph that opened a ``::`` block
    doctest = False
    for i, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if not stripped or indent > literal_indent:
                continue
            literal_indent = None
        if stripped.startswith(">>>"):
            doctest = True
        if doctest:
            doctest = bool(stripped)
            continue
        parts = line.split("``")
        lines[i] = "``".join(part if k % 2 else part.replace("|", "\\|").replace("(*", "(\\*")
                             for k, part in enumerate(parts))
        if stripped.endswith("::"):
            literal_indent = indent


def setup(app):
    app.connect("autodoc-process-docstring", plain_text_math)
