"""The data files the package ships, under the names a scenario may give instead of a path: one
owner for each name (the loaders, the scenario's path resolution and the command line read them
here)."""

from pathlib import Path

__all__ = ["DATA", "PACKAGED_FIELDS", "PACKAGED_PLANS", "PACKAGED_TABLES", "PackagedPath"]

DATA = Path(__file__).resolve().parent / "data"
"""The package's data folder."""

PACKAGED_TABLES = {
    "pednet_jetson_nano": DATA / "powprofiler_pednet_jetson_nano.csv",
    "two_parameters": DATA / "powprofiler_two_parameters.csv",
}
"""``computation.table`` names → packaged powprofiler CSV files."""

PACKAGED_PLANS = {
    "reference": DATA / "reference_plan.pln",
    "reference_plan": DATA / "reference_plan.pln",
}
"""``coverage.plan_file`` names → the packaged authors' plan (``plan_specification.pln``)."""

PACKAGED_FIELDS = {"funen_field": DATA / "funen_field.geojson"}
"""``coverage.field`` names → packaged field files."""


def PackagedPath(packaged: dict, name_or_path: str) -> str:
    """The file a scenario's ``name_or_path`` means: a packaged one of ``packaged`` (one of the
    tables above) by its name, else the path itself."""
    found = packaged.get(name_or_path)
    return str(found) if found is not None else name_or_path
