"""The errors a user meets: a bad scenario, file or argument (one line that names the key), and
a missing optional extra."""

__all__ = ["MissingExtraError", "ScenarioError"]


class ScenarioError(ValueError):
    """A scenario (YAML or dataclass) has a bad key, type or value; the message names the key."""


class MissingExtraError(ImportError):
    """A feature needs an optional extra that is not installed; the message says which and how
    to install it."""
