"""The error every bad scenario, file or argument raises: one line that names the key."""

__all__ = ["ScenarioError"]


class ScenarioError(ValueError):
    """A scenario (YAML or dataclass) has a bad key, type or value; the message names the key."""
