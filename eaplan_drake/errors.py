"""The errors a user meets: a bad scenario, file or argument (one line that names the key), and
a missing optional extra."""

import math

__all__ = ["CheckCount", "CheckNumber", "CheckProbability", "MissingExtraError", "ScenarioError"]


class ScenarioError(ValueError):
    """A scenario (YAML or dataclass) has a bad key, type or value; the message names the key."""


class MissingExtraError(ImportError):
    """A feature needs an optional extra that is not installed; the message says which and how
    to install it."""


def CheckNumber(
    name: str, value, low: float, high: float, what: str, *, open_low=False, open_high=False
) -> float:
    """``value`` as a float in the interval [low, high] (or open at either end), or a one-line
    ValueError naming ``name``, the interval and ``what`` it is (its unit or kind)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a number, got {value!r}") from None
    inside = (x > low if open_low else x >= low) and (x < high if open_high else x <= high)
    if not (math.isfinite(x) and inside):
        interval = f"{'(' if open_low else '['}{low:g}, {high:g}{')' if open_high else ']'}"
        raise ValueError(f"{name}: must be finite and in {interval} {what}, got {value!r}")
    return x


def CheckProbability(name: str, value) -> float:
    """``value`` as a float in (0, 1), or a one-line ValueError naming ``name``."""
    return CheckNumber(name, value, 0.0, 1.0, "(probability)", open_low=True, open_high=True)


def CheckCount(name: str, value, low: int, high: float) -> int:
    """``value`` as an int in [low, high], or a one-line ValueError naming ``name``."""
    x = CheckNumber(name, value, low, high, "(an integer)")
    if x != math.floor(x):
        raise ValueError(f"{name}: must be an integer, got {value!r}")
    return int(x)
