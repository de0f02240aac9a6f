"""Sphinx configuration of the torqueopt documentation (see docs/README.md for why Sphinx, furo and MyST)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # document the checkout being built, not an older installed copy

project = "torqueopt"
author = "torqueopt developers"
copyright = "torqueopt developers"

# sphinx-mathjax-offline copies MathJax into the site, so the equations typeset with no network.
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.napoleon",
    "sphinx-mathjax-offline",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "README.md"]

# A reference that does not resolve is a warning, and CI builds with -W: a broken link fails.
nitpicky = True
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
# Objects of other packages are not links: intersphinx would need the network to fetch their inventories.
nitpick_ignore_regex = [("py:.*", r"(numpy|pinocchio|collections|abc|typing|pathlib)\..*")]

# Signatures carry the parameter names; the docstrings carry their units and meanings. Type hints
# (numpy arrays, Pinocchio objects) would each need a target to link to.
autodoc_typehints = "none"
autodoc_member_order = "bysource"
autodoc_default_options = {"member-order": "bysource"}
# The docstrings use Google-style sections (Args:, Returns:, Attributes:).
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# Attributes as fields of their class: a NamedTuple's fields are documented once, not twice.
napoleon_use_ivar = True

html_theme = "furo"
html_title = "torqueopt"
html_static_path = []
