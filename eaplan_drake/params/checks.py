"""The checks the params dataclasses' ``Validate`` methods are made of: each raises
:class:`~eaplan_drake.errors.ScenarioError` naming the key."""

import math
import numbers

import numpy as np

from eaplan_drake.errors import ScenarioError


def CheckType(value, kind, name: str, what: str) -> None:
    """Raises :class:`ScenarioError` ``name: expected what, got <type>`` unless ``value`` is a
    ``kind`` (the check of a Python argument that is not a scenario key)."""
    if not isinstance(value, kind):
        raise ScenarioError(f"{name}: expected {what}, got {type(value).__name__}")


def _check(cond: bool, key: str, message: str) -> None:
    if not cond:
        raise ScenarioError(f"{key}: {message}")


def _is_int(value) -> bool:
    """An integer (Python or numpy), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _finite(value, key: str) -> float:
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise ScenarioError(f"{key}: expected a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{key}: expected a number, got {value!r}") from None
    _check(math.isfinite(v), key, f"must be finite, got {value!r}")
    return v


def _positive(value, key: str) -> None:
    v = _finite(value, key)
    _check(v > 0.0, key, f"must be > 0, got {v:g}")


def _nonnegative(value, key: str) -> None:
    v = _finite(value, key)
    _check(v >= 0.0, key, f"must be >= 0, got {v:g}")


def _in_range(value, key: str, lo: float, hi: float) -> None:
    v = _finite(value, key)
    _check(lo <= v <= hi, key, f"must be in [{lo:g}, {hi:g}], got {v:g}")


def _vector(value, key: str, size: int | None = None) -> list[float]:
    values = [_finite(v, f"{key}[{i}]") for i, v in enumerate(value)]
    if size is not None:
        _check(len(values) == size, key, f"must have {size} entries, got {len(values)}")
    return values


def _at_most(value, key: str, hi: float, unit: str, why: str) -> None:
    """An upper bound on a field that sets an amount of work; ``why`` says what it bounds."""
    v = _finite(value, key)
    _check(v <= hi, key, f"must be <= {hi:g} {unit} ({why}), got {v:g}")


def _Shown(values) -> str:
    """Numbers as a user writes them: ``[0, -1000]``, not ``array([0., -1000.])``."""
    return "[" + ", ".join(f"{float(v):g}" for v in values) + "]"
