"""Sphinx configuration of the excavsim documentation (`make docs`).

Why Sphinx + MyST + furo: it is the stack of Gymnasium, the anchor users know for environments;
MyST lets every page stay Markdown (readable on GitHub, checked by tests/test_docs.py as text);
sphinx-argparse renders the CLI reference from the real parser (excavsim.cli:build_parser), and
autodoc/autosummary render the API reference from the docstrings, so neither can drift from the code.
The build runs with warnings as errors (`sphinx-build -W --keep-going`), in CI too (.ci/run).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # document the checkout, installed or not
os.environ.setdefault("MUJOCO_GL", "disable")

project = "excavsim"
author = "the excavsim authors"
copyright = "2026, the excavsim authors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "README.md"]
templates_path = ["_templates"]

# MyST: anchors for headings down to ###, so pages can link to a section as page.md#section
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]

# API reference: autosummary walks the packages listed on api.md recursively, so modules moving
# between packages need no edit here; the stub pages are generated at build time (not committed).
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
# ray: an optional extra (excavsim[ray]) the docs need not install; excavsim.__main__ and excavsim.cli.__main__
# run the command when imported, and autosummary imports every module it walks: mocked, they are skipped
autodoc_mock_imports = ["ray", "excavsim.__main__", "excavsim.cli.__main__"]

html_theme = "furo"
html_title = "excavsim"
html_static_path: list[str] = []

# Members are documented where they are defined, not again where a package re-exports them
# (excavsim.ExcavsimError is excavsim.errors.ExcavsimError): one target per name.
autodoc_default_options["ignore-module-all"] = True
napoleon_custom_sections = [("Fields", "params_style")]  # the record dtypes' field lists
napoleon_use_ivar = True  # "Attributes:" sections as fields, not a second description of each attribute


def _clean_docstring(app, what, name, obj, options, lines):
    """Keep plain-text docstrings valid reStructuredText without editing them.

    Module data (numpy dtypes, for instance) has no docstring of its own: autodoc would show its
    type's (numpy's), so that is dropped. A ``|F|`` (a magnitude) is escaped so that reST does
    not read it as a substitution."""
    type_doc = getattr(type(obj), "__doc__", None)
    if what in ("data", "attribute") and lines and isinstance(type_doc, str) and type_doc.strip() and \
            lines[0].strip() == type_doc.strip().splitlines()[0].strip():
        lines[:] = []
        return
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        if stripped.startswith("+-") or (stripped.startswith("|") and stripped.rstrip().endswith("|")):
            continue  # a reST table: leave it
        lines[i] = re.sub(r"(?<![\\`])\|(?=[^|\s`][^|`]*\|)([^|`]*)\|", r"\\|\1\\|", line)


def setup(app):
    app.connect("autodoc-process-docstring", _clean_docstring)
