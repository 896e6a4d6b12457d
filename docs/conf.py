"""Sphinx configuration of the aromm documentation (docs/about.md says why Sphinx + MyST-NB).

Build (what .ci/run does, warnings are errors):

    pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The notebooks (docs/notebooks is a link to ../notebooks) are rendered from their stored outputs and never
executed here; ``python scripts/regenerate_notebooks.py`` recomputes those outputs at the papers' sizes.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "aromm"
author = "the aromm developers"
copyright = "aromm developers"

extensions = [
    "myst_nb",  # Markdown (MyST) pages and stored notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax 3 copied into the site: equations render without a network
    "sphinx.ext.viewcode",
    "sphinx_click",
    "reference_keys",  # docs/_ext: [Chavez2020, eq. 13] in docstrings links to the references page
]

# .rst first: autosummary writes its pages with the first suffix
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "notebooks/.ipynb_checkpoints", "**/.ipynb_checkpoints"]

# MyST: $...$ and $$...$$ maths as in the method notes; headings get anchors for cross-page links
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# notebooks: show what is stored (outputs computed at the papers' sizes), never execute
nb_execution_mode = "off"
nb_merge_streams = True

# API reference from the docstrings
autosummary_generate = True
autosummary_imported_members = False
# members defined in each module only (a package re-exports names documented on its submodules' pages)
autodoc_default_options = {"members": True, "member-order": "bysource", "ignore-module-all": True}
autodoc_mock_imports = ["pymor"]  # optional extra [mor]: aromm.interop.pymor is documented without it
autodoc_typehints = "signature"
autodoc_class_signature = "separated"
autodoc_preserve_defaults = True
napoleon_numpy_docstring = True
napoleon_google_docstring = False

html_theme = "furo"
html_title = "aromm"
html_static_path: list[str] = []
