"""The package's layout: no import cycle (module-level or inside functions), no import from a
lower layer up to a higher one, no private name imported across the planner's modules, a command
line whose ``--help`` imports no pydrake, and the size guides (a module over 700 lines or a
function over 80 is named here with the concept that keeps it whole)."""

import ast
import subprocess
import sys
from pathlib import Path

import eaplan_drake

PACKAGE = Path(eaplan_drake.__file__).resolve().parent


def _ModuleName(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def ImportGraph() -> dict[str, set[str]]:
    """Module → the package modules it imports anywhere in its source (at module level or in a
    function), by ``import a.b`` or ``from a.b import c`` (``c`` counted when it is a module)."""
    modules = {_ModuleName(p): p for p in PACKAGE.rglob("*.py")}
    graph = {name: set() for name in modules}
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for target in targets:
                if target in modules and target != name and target != "eaplan_drake":
                    graph[name].add(target)
    return graph


def Cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_cycle_finder_finds_a_cycle():
    assert Cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert Cycles({"a": {"b"}, "b": set()}) == []


def test_the_package_has_no_import_cycle():
    graph = ImportGraph()
    # the walker sees module-level and function-level imports
    assert "eaplan_drake.params" in graph["eaplan_drake.energy.battery"]
    assert "eaplan_drake.output.replay" in graph["eaplan_drake.output.save"]
    assert Cycles(graph) == []


LAYERS = [
    {"errors", "files", "registry", "packaged"},
    {"params", "ticks", "rates", "flightlog"},
    {"energy"},
    {"flight"},
    {"loading"},
    {"planning"},
    {"field"},
    {"resolve"},
    {"diagram"},
    {"simulation"},
    {"studies", "logfit", "output"},
    {"cli", "__main__"},
]
"""The package's folders and spine modules from the bottom up: a module imports only from its
own layer or the ones below (the spine's ``__init__`` is the public face and is left out)."""


def Layer(module: str) -> int:
    """The index in :data:`LAYERS` of a package module (``eaplan_drake.<room>[.…]``)."""
    room = module.split(".")[1]
    return next(i for i, rooms in enumerate(LAYERS) if room in rooms)


def UpwardArrows(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """The imports (importer, imported) from a lower layer up to a higher one."""
    return sorted(
        (a, b)
        for a, targets in graph.items()
        if a != "eaplan_drake"
        for b in targets
        if Layer(b) > Layer(a)
    )


def test_every_room_of_the_package_has_a_layer():
    rooms = {m.split(".")[1] for m in ImportGraph() if m != "eaplan_drake"}
    assert rooms == set().union(*LAYERS)
    assert UpwardArrows({"eaplan_drake.params.energy": {"eaplan_drake.energy.fourier"}}) == [
        ("eaplan_drake.params.energy", "eaplan_drake.energy.fourier")
    ]


def test_no_import_runs_from_a_lower_layer_up():
    assert UpwardArrows(ImportGraph()) == []


def test_the_planner_imports_no_private_name_across_its_modules():
    found = []
    for path in sorted((PACKAGE / "planning").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("eaplan_drake"):
                found += [f"{path.name}: {a.name}" for a in node.names if a.name.startswith("_")]
    assert found == []


def test_help_imports_no_pydrake():
    code = (
        "import runpy, sys\n"
        "sys.argv = ['eaplan_drake', '--help']\n"
        "try:\n"
        "    runpy.run_module('eaplan_drake', run_name='__main__')\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('pydrake' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_the_public_face_resolves_every_name_to_its_owner():
    import importlib

    for name in eaplan_drake.__all__:
        value = getattr(eaplan_drake, name)
        owner = importlib.import_module(f"eaplan_drake.{eaplan_drake._PUBLIC[name]}")
        assert value is getattr(owner, name), name
        assert getattr(value, "__module__", owner.__name__) == owner.__name__, name
    assert "Simulate" in dir(eaplan_drake)
    try:
        eaplan_drake.NoSuchName  # noqa: B018
    except AttributeError as e:
        assert "NoSuchName" in str(e)
    else:
        raise AssertionError("an unknown name must raise AttributeError")


def test_importing_the_package_imports_no_pydrake():
    code = "import sys, eaplan_drake; print('pydrake' in sys.modules, 'matplotlib' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert out.stdout.split() == ["False", "False"]


MAX_MODULE_LINES = 700
MAX_FUNCTION_LINES = 80


def LongModules(limit: int = MAX_MODULE_LINES) -> list[tuple[str, int]]:
    """The package's modules over ``limit`` lines, as (module, lines)."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        lines = len(path.read_text().splitlines())
        if lines > limit:
            out.append((_ModuleName(path), lines))
    return out


def _Functions(node, prefix: str = ""):
    """(qualified name, def node) of every function and method below ``node``, nested ones too."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            name = f"{prefix}{child.name}"
            if not isinstance(child, ast.ClassDef):
                yield name, child
            yield from _Functions(child, f"{name}.")
        else:
            yield from _Functions(child, prefix)


def LongFunctions(limit: int = MAX_FUNCTION_LINES) -> list[tuple[str, int]]:
    """The package's functions and methods (nested ones too) over ``limit`` lines, counted from
    the ``def`` line to the last line, docstring included, as (module:qualified name, lines)."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for name, node in _Functions(ast.parse(path.read_text())):
            lines = node.end_lineno - node.lineno + 1
            if lines > limit:
                out.append((f"{_ModuleName(path)}:{name}", lines))
    return out


def test_the_size_finders_find_what_is_too_long():
    assert "eaplan_drake.params.scenario" in [name for name, _ in LongModules(limit=100)]
    names = [name for name, _ in LongFunctions(limit=10)]
    assert "eaplan_drake.params.walk:_Walk" in names  # a function
    assert "eaplan_drake.params.scenario:Scenario.Validate" in names  # a method


LONG_BY_DESIGN: dict[str, str] = {}
"""Modules or functions over the size guide, each with the concept that keeps it whole: a split
that moves lines without a concept is worse than a long module (CONTRIBUTING.md)."""


def test_modules_over_700_lines_are_long_by_design():
    assert [name for name, _ in LongModules() if name not in LONG_BY_DESIGN] == []


def test_functions_over_80_lines_are_long_by_design():
    assert [name for name, _ in LongFunctions() if name not in LONG_BY_DESIGN] == []


def test_the_layout_tables_name_every_module():
    """docs/design.rst names every module (``eaplan_drake.x.y`` or ``~eaplan_drake.x.y``) and
    CONTRIBUTING.md every file (``y.py``) of the package: the layout tables stay current."""
    root = PACKAGE.parent
    design = (root / "docs" / "design.rst").read_text()
    contributing = (root / "CONTRIBUTING.md").read_text()
    modules = sorted(m for m in ImportGraph() if m != "eaplan_drake")
    packages = {m for m in modules if (PACKAGE / Path(*m.split(".")[1:]) / "__init__.py").exists()}
    modules = [m for m in modules if m != "eaplan_drake.__main__"]
    missing_design = [m for m in modules if m not in packages and m not in design]
    files = [m.split(".")[-1] + ".py" for m in modules if m not in packages]
    missing_contributing = [f for f in files if f"`{f}`" not in contributing]
    assert missing_design == [] and missing_contributing == []
