"""Loading a scenario: YAML files and text, layers of overrides, and the shipped names.

A scenario is a YAML mapping over the defaults of :class:`~eaplan_drake.params.Scenario` (keys
left out keep their reference values). :func:`LoadScenario` reads a file or a string;
:func:`LayerScenario` loads YAML layers over a scenario in order (mappings merge key by key, any
other value, lists included, replaces: ``yaml_load_typed(defaults=…)``'s rule);
:func:`OverrideFromAssignment` turns the command line's ``--set key.path=value`` into such a
layer. :func:`ShippedFile` is the one place that turns "a shipped name or a YAML path" into a
file, for scenarios and studies alike, and :func:`LoadNamedScenario` loads either.

The YAML follows 1.2 (its core schema) where 1.1 surprises: ``1e3`` is a number; only ``true`` and
``false`` (``True``, ``FALSE``, …) are booleans, so ``no``, ``on``, ``yes``, ``off`` are strings
(and a string where a boolean belongs is an error naming the key); a date is a string; a duplicate
key is an error. The scenario is built from that data by the same walker that checks it (the type
walker of :mod:`eaplan_drake.params.walk`), with ``yaml_load_typed``'s merge rule, so that the
checks and the values never read the text differently. A misspelt key, a wrong type or a value out
of range raises :class:`~eaplan_drake.params.ScenarioError` naming the key (``file:line:col`` for
syntax). Nothing here imports pydrake until a scenario is validated, so the command line can check a
name first.
"""

import copy
import re
import typing
from importlib import resources
from pathlib import Path

import yaml

from eaplan_drake.errors import ScenarioError
from eaplan_drake.files import MissingFile, ReadTextFile
from eaplan_drake.packaged import PACKAGED_FIELDS, PACKAGED_PLANS, PACKAGED_TABLES
from eaplan_drake.params import BatteryParams, Scenario
from eaplan_drake.params.walk import _Dataclasses, _Hints, _UnknownKeyMessage, _Walk

__all__ = [
    "LayerScenario",
    "LoadNamedScenario",
    "LoadScenario",
    "OverrideFromAssignment",
    "ResolveFilePaths",
    "ShippedFile",
    "YamlData",
    "ShippedNames",
]


def LoadScenario(
    filename: str | Path | None = None,
    data: str | None = None,
    *,
    overrides: typing.Sequence[str] = (),
) -> Scenario:
    """Loads and validates a :class:`Scenario` from a YAML file or string, then layers the YAML
    ``overrides`` on it in order (as ``yaml_load_typed(defaults=…)`` does: mappings merge key by
    key, any other value, lists included, replaces; see :func:`OverrideFromAssignment`).

    Keys left out keep their reference defaults. Raises :class:`ScenarioError` (a ValueError)
    naming the key on an unknown key, a wrong type or a value out of range.
    """
    if (filename is None) == (data is None):
        raise ScenarioError("LoadScenario: give exactly one of filename= or data=")
    if filename is not None:
        path = Path(filename)
        if MissingFile(path, "scenario file"):
            raise ScenarioError(f"{path}: {MissingFile(path, 'scenario file')}")
        data = ReadTextFile(path, MAX_SCENARIO_BYTES, ScenarioError)
        scenario = _LoadLayer(data, Scenario(), f"{path}: ", source=str(path))
        return LayerScenario(ResolveFilePaths(scenario, path.parent), overrides)
    if not isinstance(data, str):
        raise ScenarioError(f"LoadScenario: data= must be YAML text, got {type(data).__name__}")
    return LayerScenario(_LoadLayer(data, Scenario(), ""), overrides)


MAX_SCENARIO_BYTES = 1_000_000
"""Largest scenario file [bytes]."""


def ResolveFilePaths(scenario: Scenario, base_dir: str | Path) -> Scenario:
    """``scenario`` with a relative ``computation.table`` / ``coverage.plan_file`` /
    ``coverage.field`` path made
    relative to ``base_dir`` (the scenario file's folder) instead of the current directory;
    packaged names (``pednet_jetson_nano``, ``reference``, …) stay. Modifies and returns it."""
    base = Path(base_dir)
    table = scenario.computation.table
    if isinstance(table, str) and table and table not in PACKAGED_TABLES:
        if not Path(table).is_absolute():
            scenario.computation.table = str(base / table)
    plan = scenario.coverage.plan_file
    if isinstance(plan, str) and plan and plan not in PACKAGED_PLANS:
        if not Path(plan).is_absolute():
            scenario.coverage.plan_file = str(base / plan)
    field = scenario.coverage.field
    if isinstance(field, str) and field and field not in PACKAGED_FIELDS:
        if not Path(field).is_absolute():
            scenario.coverage.field = str(base / field)
    return scenario


def LayerScenario(scenario: Scenario, overrides: typing.Sequence[str]) -> Scenario:
    """A copy of ``scenario`` with the YAML ``overrides`` loaded over it in order, validated."""
    scenario = copy.deepcopy(scenario)
    for i, text in enumerate(overrides):
        if not isinstance(text, str):
            raise ScenarioError(f"overrides[{i}]: expected YAML text, got {type(text).__name__}")
        scenario = _LoadLayer(text, scenario, f"override {i + 1}: ")
    return scenario.Validate()


class _StrictYamlLoader(yaml.SafeLoader):
    """PyYAML's safe loader with YAML 1.2's core schema where 1.1 surprises: ``1e3``, ``5e-1``
    are numbers, not strings; only ``true``/``false`` (``True``, ``TRUE``, …) are booleans, so
    ``no``, ``on``, ``yes``, ``off`` are strings (a country code, a table name); a date is a
    string; a duplicate key is an error (YAML 1.2 forbids them; PyYAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen = {}
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                try:
                    hash(key)
                except TypeError:  # an unhashable key: the base class says so
                    continue
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None,
                        None,
                        f"duplicate key {key!r} (first on line {seen[key]})",
                        key_node.start_mark,
                    )
                seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


_StrictYamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)
_NOT_CORE = ("tag:yaml.org,2002:bool", "tag:yaml.org,2002:timestamp")
_StrictYamlLoader.yaml_implicit_resolvers = {  # the loader's own copy (made by the call above)
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in _NOT_CORE]
    for first, resolvers in _StrictYamlLoader.yaml_implicit_resolvers.items()
}
_StrictYamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)


def YamlData(data: str, source: str):
    """The raw YAML data of ``data`` (``_StrictYamlLoader``); a syntax error is one line
    ``source:line:col: invalid YAML: problem``."""
    try:
        return yaml.load(data, Loader=_StrictYamlLoader)  # noqa: S506 (a SafeLoader)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        problem = " ".join(str(e.problem or e.context or "syntax error").split())
        at = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark else source
        raise ScenarioError(f"{at}: invalid YAML: {problem}") from None
    except (yaml.YAMLError, RecursionError) as e:
        raise ScenarioError(f"{source}: invalid YAML: {' '.join(str(e).split())}") from None


def _LoadLayer(data: str, defaults: Scenario, where: str, source: str = "") -> Scenario:
    """``defaults`` with the YAML ``data`` loaded over it: a copy built from the strict loader's
    data, checked key by key (the type walker of :mod:`eaplan_drake.params.walk`: mappings merge,
    lists and scalars replace, integers in float fields become floats, as ``yaml_load_typed``
    does)."""
    raw = YamlData(data, source or where.rstrip(": ") or "<yaml>")
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ScenarioError(f"{where}the scenario must be a mapping of keys at the top level")
    if not raw:
        return defaults
    current = copy.deepcopy(defaults)
    if isinstance(raw.get("battery"), dict) and isinstance(current.battery, BatteryParams):
        current.battery.ForgetLabel(raw["battery"])  # a pack's label replaces the one below
    return _Walk(Scenario, raw, "", raw=True, current=current)


def OverrideFromAssignment(assignment: str) -> str:
    """The YAML layer of one ``key.path=value`` assignment (the CLI's ``--set``), e.g.
    ``battery.capacity=2.5`` or ``battery.faults=[{time: 90, soc_drop: 0.1}]``; the value is
    YAML. Raises :class:`ScenarioError` for a malformed assignment or an unknown key."""
    key, sep, value = assignment.partition("=")
    parts = key.strip().split(".")
    if not sep or not all(p.isidentifier() for p in parts):
        raise ScenarioError(
            f"--set {assignment!r}: expected KEY.PATH=VALUE (e.g. battery.capacity=2.5)"
        )
    schemas = [Scenario]  # the dataclasses the key so far may be (several for a Union)
    for depth, name in enumerate(parts):
        full = ".".join(parts[: depth + 1])
        owners = [s for s in schemas if name in _Hints(s)]
        if not owners:
            if not schemas:
                raise ScenarioError(f"{full}: unknown key (known keys here: none: not a mapping)")
            raise ScenarioError(_UnknownKeyMessage(schemas[0], name, full))
        schemas = [c for owner in owners for c in _Dataclasses(_Hints(owner)[name])]
    lines = [f"{'  ' * d}{name}:" for d, name in enumerate(parts)]
    lines[-1] += " " + (value.strip() or "''")
    return "\n".join(lines) + "\n"


_KINDS = {"scenarios": "scenario", "studies": "study"}


def ShippedNames(kind: str = "scenarios") -> list[str]:
    """The names of the YAML files shipped in the package folder ``kind`` (``scenarios`` or
    ``studies``), sorted."""
    folder = resources.files("eaplan_drake") / kind
    return sorted(f.name[: -len(".yaml")] for f in folder.iterdir() if f.name.endswith(".yaml"))


def ShippedFile(
    name_or_path: str | Path, kind: str = "scenarios", caller: str = "ShippedFile"
) -> tuple[Path, bool]:
    """``(path, shipped)`` of a YAML path (``shipped`` False) or of the shipped file of that name
    in ``kind`` (``scenarios`` or ``studies``); raises :class:`ScenarioError` naming the shipped
    ones when it is neither."""
    if not isinstance(name_or_path, str | Path):
        raise ScenarioError(
            f"{caller}: expected a shipped name or a YAML path, got {type(name_or_path).__name__}"
        )
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") or path.exists():
        return path, False
    shipped = resources.files("eaplan_drake") / kind / f"{name_or_path}.yaml"
    if not shipped.is_file():
        raise ScenarioError(
            f"{name_or_path}: not a YAML file nor a shipped {_KINDS[kind]} "
            f"(shipped: {', '.join(ShippedNames(kind))})"
        )
    return Path(str(shipped)), True


def LoadNamedScenario(name_or_path: str | Path, overrides: typing.Sequence[str] = ()) -> Scenario:
    """A shipped scenario by name (:func:`ShippedNames`: ``plan_I``, ``plan_II``, ``plan_i``,
    ``plan_ii``, ``survey``, ``funen``) or a YAML path, with the YAML ``overrides`` layered on it
    in order (see :func:`LoadScenario`). Raises :class:`ScenarioError` with one clear line on any
    problem."""
    path, shipped = ShippedFile(name_or_path, "scenarios", "LoadNamedScenario")
    if shipped:
        return LoadScenario(data=path.read_text(), overrides=overrides)
    return LoadScenario(filename=path, overrides=overrides)
