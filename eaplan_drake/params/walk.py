"""The fields of a params dataclass and nothing else, and the one type walker: YAML data and
params objects checked against the dataclasses' type hints, with one-line messages that name the
key."""

import dataclasses as dc
import difflib
import functools
import numbers
import types
import typing

import numpy as np

from eaplan_drake.errors import ScenarioError
from eaplan_drake.params.checks import _check, _is_int


class _Params:
    """Base of every params dataclass: setting an attribute that is not a field raises
    :class:`AttributeError` naming the key (``scenario.planner.enabled = False`` would otherwise
    be accepted and ignored). Construction, ``dc.replace``, ``copy.deepcopy``, pickling and
    pydrake's ``yaml_load_typed`` only ever set fields."""

    __slots__ = ()

    def __setattr__(self, name: str, value) -> None:
        if name not in _FieldNames(type(self)):
            raise AttributeError(_UnknownFieldMessage(type(self), name), name=name, obj=self)
        object.__setattr__(self, name, value)


@functools.cache
def _FieldNames(cls) -> frozenset[str]:
    return frozenset(f.name for f in dc.fields(cls))


@functools.cache
def _Hints(cls) -> dict:
    """The type hints of a dataclass's fields, by name (cached; do not modify)."""
    names = [f.name for f in dc.fields(cls)]
    hints = typing.get_type_hints(cls)
    return {name: hints[name] for name in names}


def _RemovedFieldNote(cls, name: str) -> str:
    """What replaced a removed key, or ""."""
    return _REMOVED_FIELDS.get((cls.__name__, name), "")


def _Suggestion(cls, name) -> str:
    """`` (did you mean 'x'?)`` for the nearest field of ``cls``, or ""."""
    close = difflib.get_close_matches(str(name), sorted(_FieldNames(cls)), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _UnknownFieldMessage(cls, name: str) -> str:
    """One line for setting the non-field ``name`` on a ``cls`` from Python."""
    prefix = _ClassKeys().get(cls)
    full = f"{cls.__name__}.{name}" if prefix is None else (f"{prefix}.{name}" if prefix else name)
    note, close = _RemovedFieldNote(cls, name), _Suggestion(cls, name)
    fields = "" if close or note else f" (fields: {', '.join(sorted(_FieldNames(cls)))})"
    return f"{full}: {cls.__name__} has no field {name!r}{close}{fields}" + (
        f"; {note}" if note else ""
    )


MAX_SHOWN_KEY = 40
"""The most characters of an unknown key a message repeats (``fit`` cuts its cells alike)."""


def _UnknownKeyMessage(cls, name, full: str) -> str:
    """One line for the unknown key ``full`` (last part ``name``) of a ``cls`` in YAML."""
    known = ", ".join(sorted(_FieldNames(cls)))
    note = _RemovedFieldNote(cls, name)
    close = _Suggestion(cls, name).strip(" ()")
    if len(full) > MAX_SHOWN_KEY:  # a file that is not a scenario: never echo a whole line
        full = full[:MAX_SHOWN_KEY] + "…"
    return (
        f"{full}: unknown key (known keys here: {known})"
        + (f"; {close}" if close else "")
        + (f"; {note}" if note else "")
    )


@functools.cache
def _ClassKeys() -> dict:
    """The key of each params class in the scenario tree (``PlannerParams`` → ``planner``,
    ``BatteryFault`` → ``battery.faults[i]``, ``Scenario`` → ""), walked from its root
    (:func:`_Roots`); a class found at two keys maps to None (its messages then name the
    class)."""
    keys: dict = {}

    def visit(hint, key: str) -> None:
        if dc.is_dataclass(hint):
            if hint in keys:
                keys[hint] = None if keys[hint] != key else key
                return
            keys[hint] = key
            for name, sub in _Hints(hint).items():
                visit(sub, f"{key}.{name}" if key else name)
        elif typing.get_origin(hint) is list:
            visit(typing.get_args(hint)[0], f"{key}[i]")
        for member in _Members(hint):
            visit(member, key)

    for root in _Roots():
        visit(root, "")
    return keys


def _Roots() -> list:
    """The params classes that are no field (nor list item, nor Union member) of another: the
    root of the scenario tree, ``Scenario`` (importing any params module imports the package's
    face, hence the whole tree)."""
    classes = _Params.__subclasses__()
    held = set()

    def collect(hint) -> None:
        if dc.is_dataclass(hint):
            held.add(hint)
        elif typing.get_origin(hint) is list:
            collect(typing.get_args(hint)[0])
        for member in _Members(hint):
            collect(member)

    for cls in classes:
        for hint in _Hints(cls).values():
            collect(hint)
    return [cls for cls in classes if cls not in held]


_REMOVED_FIELDS = {
    ("PlannerParams", "enabled"): (
        "'enabled' was removed: the planner's switch is 'policy' (policy 'static' holds the "
        "initial parameters, as enabled false did)"
    ),
}
"""Keys that were removed, by (class name, key): what replaced them."""


# -- the one type walker: YAML data and params objects against the type hints ------------------


def _Members(hint) -> tuple:
    """The members of a Union hint (``X | None``, ``typing.Optional[X]``, ``A | B``), else ()."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return typing.get_args(hint)
    return ()


def _Dataclasses(hint) -> list:
    """The dataclasses a value of ``hint`` may be: [hint], its dataclass members, or []."""
    if dc.is_dataclass(hint):
        return [hint]
    return [m for m in _Members(hint) if dc.is_dataclass(m)]


def _Walk(hint, value, key: str, *, raw: bool, current=None):
    """Checks ``value`` against the type hint ``hint``; raises :class:`ScenarioError` naming
    ``key`` on a mismatch. Returns the value to keep (the same object when nothing changes).

    ``raw=False`` walks a params object (:meth:`Scenario.Validate`): a params dataclass where one
    belongs, numpy integers in integer fields become ``int``, tuples and arrays in list fields
    lists. ``raw=True`` walks YAML data (:mod:`eaplan_drake.loading`) and builds the value: a
    mapping where a dataclass belongs, merged key by key into ``current`` (the value it layers
    over) or a new default instance; an unknown key is named in full; lists replace; integers in
    float fields become floats (as pydrake's ``yaml_load_typed``). Both support ``X | None`` and
    a Union of dataclasses (raw: the first whose fields hold every key given)."""
    if _Members(hint):
        return _WalkUnion(hint, value, key, raw=raw, current=current)
    if dc.is_dataclass(hint):
        if raw:
            if not isinstance(value, dict):
                raise ScenarioError(f"{key}: expected a mapping of keys, got {_Short(value)}")
            target = current if isinstance(current, hint) else hint()
            hints = _Hints(hint)
            for name, v in value.items():
                full = f"{key}.{name}" if key else str(name)
                if name not in hints:
                    raise ScenarioError(_UnknownKeyMessage(hint, name, full))
                sub = getattr(target, name)
                setattr(target, name, _Walk(hints[name], v, full, raw=True, current=sub))
            return target
        if not isinstance(value, hint):
            what = "the scenario" if not key else key
            raise ScenarioError(
                f"{what}: expected a {hint.__name__}, got {type(value).__name__} {_Short(value)}"
            )
        for name, sub_hint in _Hints(hint).items():
            v = getattr(value, name)
            fixed = _Walk(sub_hint, v, f"{key}.{name}" if key else name, raw=False)
            if fixed is not v:
                setattr(value, name, fixed)
        return value
    if typing.get_origin(hint) is list:
        if not raw and isinstance(value, tuple | np.ndarray):
            value = list(np.asarray(value).tolist() if isinstance(value, np.ndarray) else value)
        if not isinstance(value, list):
            raise ScenarioError(f"{key}: expected a list, got {_Short(value)}")
        (item,) = typing.get_args(hint)
        fixed = [_Walk(item, v, f"{key}[{i}]", raw=raw) for i, v in enumerate(value)]
        if raw:
            return fixed  # a new list: a list in a layer replaces the one below
        return value if all(a is b for a, b in zip(fixed, value, strict=True)) else fixed
    if hint in _SCALARS:
        _check(
            _Fits(hint, value, raw), key, f"expected {_Expected(hint, raw)}, got {_Short(value)}"
        )
        if hint is int and type(value) is not int:
            return int(value)
        if hint is float and raw and type(value) is int:
            return float(value)
    return value


_SCALARS = (bool, int, float, str)


def _Fits(hint, value, raw: bool) -> bool:
    """Whether ``value`` is of the kind ``hint`` names (without looking inside)."""
    if hint is type(None):
        return value is None
    if dc.is_dataclass(hint):
        return isinstance(value, dict) if raw else isinstance(value, hint)
    if typing.get_origin(hint) is list:
        return isinstance(value, list) or (not raw and isinstance(value, tuple | np.ndarray))
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool) if raw else _is_int(value)
    if hint is float:
        return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    if hint is str:
        return isinstance(value, str)
    return isinstance(value, typing.get_origin(hint) or hint)


def _Expected(hint, raw: bool) -> str:
    """What a value of ``hint`` is, for a message."""
    if hint is type(None):
        return "null" if raw else "None"
    if dc.is_dataclass(hint):
        return "a mapping of keys" if raw else f"a {hint.__name__}"
    if typing.get_origin(hint) is list:
        return "a list"
    names = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}
    return names.get(hint, f"a {getattr(hint, '__name__', hint)}")


def _WalkUnion(hint, value, key: str, *, raw: bool, current=None):
    """:func:`_Walk` for a Union: the member of the value's exact type, else the first it fits
    (raw mappings: the first dataclass whose fields hold every key, preferring the type of
    ``current``)."""
    members = _Members(hint)
    if value is None and type(None) in members:
        return None
    fitting = [m for m in members if _Fits(m, value, raw)]
    if raw and isinstance(value, dict):
        classes = [m for m in fitting if dc.is_dataclass(m)]
        classes.sort(key=lambda m: not isinstance(current, m))  # stable: current's type first
        holding = [m for m in classes if set(value) <= _FieldNames(m)]
        fitting = holding or classes[:1]  # none holds every key: the first names the unknown one
    exact = [m for m in fitting if m in _SCALARS and type(value) is m]
    if not (exact or fitting):
        expected = " or ".join(dict.fromkeys(_Expected(m, raw) for m in members))
        raise ScenarioError(f"{key}: expected {expected}, got {_Short(value)}")
    member = (exact or fitting)[0]
    sub = current if dc.is_dataclass(member) and isinstance(current, member) else None
    return _Walk(member, value, key, raw=raw, current=sub)


def _Short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
