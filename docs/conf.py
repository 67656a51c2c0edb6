"""Sphinx configuration of the pulsemap documentation (build: sphinx-build -W -b html docs docs/_build)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs"))  # nothing else: autodoc imports the installed pulsemap

project = "pulsemap"
author = "the pulsemap developers"
copyright = "2026, the pulsemap developers"

os.environ.setdefault("PULSEMAP_CACHE_DIR", str(ROOT / "docs" / "_build" / "cache"))

from pulsemap import __version__ as release  # noqa: E402

version = release

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.mathjax"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}
nitpicky = False
exclude_patterns = ["_build"]
html_theme = "alabaster"
html_static_path: list[str] = []
