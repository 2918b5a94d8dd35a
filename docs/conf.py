"""Sphinx configuration: MyST Markdown pages and an API reference from the docstrings.

Build: ``python3 -m sphinx -W -b html docs out/docs`` (the test suite does this, warnings as errors).
"""
project = "rollsim"
author = "rollsim developers"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "sphinx.ext.mathjax",
              "sphinx.ext.napoleon"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 4
autosummary_generate = True
autodoc_default_options = {"members": True, "ignore-module-all": True}
autodoc_typehints = "none"
exclude_patterns = ["_build"]
html_theme = "alabaster"
