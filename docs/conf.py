"""Sphinx configuration of the motorid documentation (``python3 -m sphinx -W -b html docs docs/_build/html``)."""

import sys
from pathlib import Path

import matplotlib

sys.path.insert(0, str(Path(__file__).parent))  # docs/_cli.py, docs/_tutorial.py: local extensions

matplotlib.use("Agg")  # the gallery's figures are rendered without a display

project = "motorid"
author = "motorid contributors"
copyright = "motorid contributors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "_cli",  # docs/_cli.py: the command line reference from the commands
    "_tutorial",  # docs/_tutorial.py: runs the tutorial's code blocks during the build
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "gallery/*.ipynb", "gallery/*.py", "gallery/*.md5", "gallery/*.zip",
                    "gallery/*.codeobj.json", "sg_execution_times.rst"]
html_theme = "alabaster"
myst_heading_anchors = 3

numpydoc_show_class_members = False
numpydoc_xref_param_type = False
autodoc_typehints = "none"  # the numpydoc sections carry the types

sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"plot_",  # every example runs during the build
    "abort_on_example_error": True,
    "download_all_examples": False,
    "write_computation_times": False,
}
