"""Sphinx configuration of the cosserat-fsi documentation (MyST pages, executed MyST notebooks, autodoc).

Build: ``make docs`` (``sphinx-build -T -W --keep-going -b html docs docs/_build/html``; warnings are errors).
No warning type is suppressed.
"""

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent

# This checkout, for autodoc here and for the notebook kernels that execute the tutorials.
sys.path.insert(0, str(REPO))
os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(REPO / "meshes"))
os.environ["OMP_NUM_THREADS"] = "1"
os.environ["MPLBACKEND"] = "Agg"

import cosserat_fsi  # noqa: E402

project = "cosserat-fsi"
author = "cosserat-fsi"
copyright = "cosserat-fsi authors"
version = release = cosserat_fsi.__version__

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.mathjax"]

exclude_patterns = ["_build", "runs", "perf", "jupyter_execute", "**.ipynb_checkpoints"]
# A code block without a language (``` alone) is plain text: give commands, YAML and Python their language.
highlight_language = "none"

# ---------------------------------------------------------------------------------------------- MyST
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
# `[text](page.md#a-heading)` links resolve to headings of levels 1-3.
myst_heading_anchors = 3

# ---------------------------------------------------------------------------------------------- notebooks
# The tutorials are executed whenever Sphinx reads them (all in a fresh build), in their own folder
# (docs/tutorials) as the working directory; an error in a cell fails the build.
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 300
nb_execution_show_tb = True

# ---------------------------------------------------------------------------------------------- autodoc
# The API is documented under its short names (cosserat_fsi.load_scene, api.md); reST docstrings.
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True  # comm=MPI.COMM_WORLD, not the object's repr
autoclass_content = "both"  # a class's docstring, then its __init__'s

# ---------------------------------------------------------------------------------------------- HTML
html_theme = "furo"
html_title = f"cosserat-fsi {release}"


def write_scene_reference(app) -> None:
    """Generate docs/scene_reference.md from the scene schema (rewritten only when its text changes)."""
    from cosserat_fsi.config.reference import scene_reference_markdown

    page = DOCS / "scene_reference.md"
    text = scene_reference_markdown()
    if not page.exists() or page.read_text(encoding="utf-8") != text:
        page.write_text(text, encoding="utf-8")


def setup(app):
    app.connect("builder-inited", write_scene_reference)
