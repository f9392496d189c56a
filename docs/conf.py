"""Sphinx configuration of the eaplan_drake documentation.

Build (from the repository root; every warning is an error):

    python3 -m sphinx -W --keep-going -b html docs docs/_build/html

Only Sphinx itself is needed (its default theme, ``autodoc``, and napoleon's parser for the few
Google-style sections); the API pages import the package, so build in an environment where
``import eaplan_drake`` and ``import pydrake`` work.
"""

import importlib.util
import os
import sys

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from sphinx.ext.napoleon import Config as NapoleonConfig
from sphinx.ext.napoleon.docstring import GoogleDocstring
from sphinx.util import logging

logger = logging.getLogger(__name__)

sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..")))

project = "eaplan_drake"
author = "The eaplan_drake developers"
copyright = "2026, The eaplan_drake developers"
try:
    from importlib import metadata as _metadata

    release = _metadata.version("eaplan-drake")
except Exception:  # a source tree that is not installed
    release = "0.1.0"
version = release

extensions = ["sphinx.ext.autodoc"]

# pydrake is a real dependency; mock it only where it cannot be imported (the docs then lose
# nothing but the base classes' names).
if importlib.util.find_spec("pydrake") is None:
    autodoc_mock_imports = ["pydrake"]

exclude_patterns = ["_build", "examples"]
templates_path = []
html_static_path = []
html_theme = "alabaster"
html_theme_options = {"description": "Energy-aware planning-scheduling in Drake"}
html_title = "eaplan_drake"

# Docstrings are plain reStructuredText with Sphinx roles; paper symbols are Unicode.
primary_domain = "py"
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"show-inheritance": False}
autoclass_content = "class"
add_module_names = False
nitpicky = False


class PydrakeSystem(Directive):
    """Drake's ``.. pydrake_system::`` port block: a YAML body with ``name``, ``input_ports`` and
    ``output_ports``, rendered as a three-column table (inputs → system → outputs), as in Drake's
    own API documentation."""

    has_content = True

    def run(self):
        import yaml

        try:
            spec = yaml.safe_load("\n".join(self.content)) or {}
        except yaml.YAMLError as e:
            error = self.state_machine.reporter.error(
                f"pydrake_system: bad YAML: {e}", line=self.lineno
            )
            return [error]
        name = str(spec.get("name", ""))
        inputs = [str(p) for p in spec.get("input_ports", []) or []]
        outputs = [str(p) for p in spec.get("output_ports", []) or []]

        def Cell(lines):
            return ["       | " + line for line in lines] or ["       |"]

        rst = [".. list-table::", "   :class: pydrake-system", "", "   * - "]
        body = Cell([f"``{p}`` →" for p in inputs]) if inputs else ["       (no inputs)"]
        rst[-1] += body[0].lstrip()
        rst += body[1:]
        rst.append(f"     - **{name}**")
        out = Cell([f"→ ``{p}``" for p in outputs]) if outputs else ["       (no outputs)"]
        rst.append("     - " + out[0].lstrip())
        rst += out[1:]
        container = nodes.container(classes=["pydrake-system"])
        self.state.nested_parse(
            StringList(rst, source="pydrake_system"), self.content_offset, container
        )
        return [container]


GOOGLE_SECTIONS = ("Args:", "Attributes:", "Returns:", "Raises:", "Yields:")
NAPOLEON = NapoleonConfig(
    napoleon_google_docstring=True, napoleon_numpy_docstring=False, napoleon_use_ivar=True
)


def GoogleSections(app, what, name, obj, options, lines):
    """Renders the Google-style sections (``Args:``, ``Attributes:``) some docstrings have, with
    napoleon's parser (part of Sphinx), and leaves every other docstring as written: attribute
    and data docstrings here are prose whose first ``words:`` napoleon would read as a type."""
    if what in ("attribute", "data", "property"):
        return
    if not any(line.strip() in GOOGLE_SECTIONS for line in lines):
        return
    lines[:] = GoogleDocstring(lines, NAPOLEON, app, what, name, obj, options).lines()


def ResolvePublicName(app, env, node, contnode):
    """Resolves a Python reference to a name of the public face (``eaplan_drake.Simulate``, or
    a bare ``Scenario`` in a module that imports it) to where that name is defined and
    documented (``eaplan_drake.simulation.Simulate``)."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "")
    name = target.removeprefix("eaplan_drake.")
    if not name or "." in name:
        return None
    import eaplan_drake

    if name not in getattr(eaplan_drake, "__all__", ()):
        return None
    try:
        module = getattr(eaplan_drake, name).__module__
    except Exception:  # a module of the public face that does not import: autodoc says so
        return None
    if not module:
        return None
    py = env.get_domain("py")
    return py.resolve_xref(
        env, node["refdoc"], app.builder, node["reftype"], f"{module}.{name}", node, contnode
    )


def setup(app):
    app.add_directive("pydrake_system", PydrakeSystem)
    app.connect("missing-reference", ResolvePublicName)
    app.connect("autodoc-process-docstring", GoogleSections)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
