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
nitpicky = True
# Every reference must resolve, but for the external types that have no inventory offline (the
# docs build without network access): numpy's, the standard library's and pydrake's classes, as
# they appear in signatures, type hints and base classes.
nitpick_ignore = [
    ("py:class", "argparse.ArgumentParser"),
    ("py:class", "collections.abc.Callable"),
    ("py:class", "numpy.ndarray"),
    ("py:class", "numpy.random._generator.Generator"),
    ("py:class", "pathlib.Path"),
    ("py:class", "pydrake.common.containers.NamedViewBase"),
    ("py:class", "pydrake.systems.framework.Context"),
    ("py:class", "pydrake.systems.framework.Diagram"),
    ("py:class", "pydrake.systems.framework.DiagramBuilder"),
    ("py:class", "pydrake.systems.framework.LeafSystem"),
    ("py:class", "pydrake.systems.framework.OutputPort"),
    ("py:class", "pydrake.systems.primitives.Adder"),
    ("py:class", "pydrake.systems.primitives.ConstantVectorSource"),
]


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


def _Owner(target: str) -> str | None:
    """Where a name of a package's face is defined: ``eaplan_drake.Simulate`` →
    ``eaplan_drake.simulation.Simulate``, ``eaplan_drake.params.VehicleParams[.Validate]`` →
    ``eaplan_drake.params.flight.VehicleParams[.Validate]``; a template instantiation
    (``eaplan_drake.flight.plant.FixedWingPlant_𝓣float𝓤``) → the module's name for it
    (``eaplan_drake.flight.plant.FixedWingPlant``). None for any other target."""
    import importlib

    parts = target.split(".")
    if parts[0] != "eaplan_drake":
        return None
    for n in range(len(parts) - 1, 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:n]))
        except ImportError:
            continue
        name, rest = parts[n], parts[n + 1 :]
        if "𝓣" in name:
            for alias, value in vars(module).items():
                public = not alias.startswith("_") and "𝓣" not in alias
                if public and getattr(value, "__name__", None) == name:
                    return ".".join([module.__name__, alias, *rest])
            return None
        if not hasattr(module, "__path__") or name not in getattr(module, "__all__", ()):
            return None
        owner = getattr(getattr(module, name), "__module__", None)
        if not owner or owner == module.__name__:
            return None
        return ".".join([owner, name, *rest])
    return None


def ResolvePublicName(app, env, node, contnode):
    """Resolves a Python reference to a name of a package's face (``eaplan_drake.Simulate``,
    ``eaplan_drake.params.Scenario``, or a bare ``Scenario`` in a module that imports it from
    the top-level face) to where that name is defined and documented (:func:`_Owner`)."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "")
    if target and "." not in target:
        import eaplan_drake

        if target not in getattr(eaplan_drake, "__all__", ()):
            return None
        target = f"eaplan_drake.{target}"
    try:
        owner = _Owner(target)
    except Exception:  # a module of the face that does not import: autodoc says so
        return None
    if owner is None:
        return None
    py = env.get_domain("py")
    return py.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], owner, node, contnode)


def PublicBases(app, name, obj, options, bases):
    """Leaves the private bases (``_Params``, a ``_FixedWingPorts`` mixin) out of a class's
    "Bases:" line: they are not part of the documented API."""
    bases[:] = [b for b in bases if not getattr(b, "__name__", "").startswith("_")]


def setup(app):
    app.add_directive("pydrake_system", PydrakeSystem)
    app.connect("missing-reference", ResolvePublicName)
    app.connect("autodoc-process-docstring", GoogleSections)
    app.connect("autodoc-process-bases", PublicBases)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
