"""Sphinx configuration of the bayescal documentation (``make docs``).

Everything the build needs is installed by the ``docs`` extra; nothing is
fetched while building (no intersphinx).
"""
import os
import sys

sys.path.insert(0, os.path.abspath(".."))

from bayescal import __version__  # noqa: E402

project = "bayescal"
author = "the bayescal authors"
copyright = "the bayescal authors, BSD-3-Clause"
version = release = __version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinxarg.ext",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "generated/*.md"]
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
# A class's page documents its public methods and properties (templates/).
templates_path = ["_templates"]
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

html_theme = "furo"
html_title = f"bayescal {version}"
html_static_path = []


# The commands' descriptions are written for the terminal (argparse's
# RawDescriptionHelpFormatter: aligned lists, indented examples). Show them in
# the command reference exactly as ``--help`` prints them, preformatted,
# rather than reparsed as reStructuredText.
def _preformatted_descriptions():
    import textwrap

    import sphinxarg.ext
    import sphinxarg.parser

    parse = sphinxarg.parser.parse_parser

    def walk(data):
        if data.get("description"):
            data["description"] = "::\n\n" + textwrap.indent(data["description"], "    ")
        for child in data.get("children", []):
            walk(child)
        return data

    sphinxarg.ext.parse_parser = lambda *args, **kw: walk(parse(*args, **kw))


_preformatted_descriptions()
