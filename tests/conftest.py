"""Shared pytest configuration: the Agg backend, the ``authors_data`` marker, the shipped
computation tables (``table``: PedNet on a Jetson Nano, one parameter; ``table2``: the
two-parameter table) and a small study.

A test marked ``authors_data`` reads the authors' logs and measurements (``$EAPLAN_REFERENCE_DIR``,
default ``../shared/reference/seewald2022`` beside the repository). Without them it is skipped
with that reason, and the run's summary says how many such tests ran and how many were skipped,
so a clone without the data is never mistaken for a full run.
"""

import textwrap

import matplotlib
import pytest

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.logfit.powerlog import REFERENCE_ENV, ReferenceDirectory

matplotlib.use("Agg")

_AUTHORS_DATA = {"ran": 0, "skipped": 0}


@pytest.fixture(scope="session")
def table():
    """The shipped PedNet table (one parameter, fps), immutable."""
    return LoadComputationTable("pednet_jetson_nano")


@pytest.fixture(scope="session")
def table2():
    """The shipped two-parameter table, immutable."""
    return LoadComputationTable("two_parameters")


def pytest_collection_modifyitems(config, items):
    present = ReferenceDirectory().is_dir()
    skip = pytest.mark.skip(
        reason=f"authors' reference data not found in {ReferenceDirectory()} (set {REFERENCE_ENV})"
    )
    for item in items:
        if item.get_closest_marker("authors_data") is not None:
            _AUTHORS_DATA["ran" if present else "skipped"] += 1
            if not present:
                item.add_marker(skip)


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if _AUTHORS_DATA["ran"] or _AUTHORS_DATA["skipped"]:
        terminalreporter.write_line(
            f"authors' data: {_AUTHORS_DATA['ran']} tests with the data, "
            f"{_AUTHORS_DATA['skipped']} skipped without it ({ReferenceDirectory()})"
        )


MINI_STUDY = textwrap.dedent(
    """\
    name: mini
    base: plan_i
    set: {simulation.time_limit: 5.0, planner.warmup: 2.0}
    draws: 1
    seed: 3
    policies: [mpc, greedy]
    """
)
"""A study of two 5 s flights per policy (mpc, greedy) on one world, for the studies' tests."""


@pytest.fixture
def mini_text() -> str:
    """The text of :data:`MINI_STUDY`."""
    return MINI_STUDY


@pytest.fixture
def mini(tmp_path, mini_text):
    """:data:`MINI_STUDY` written to a file in ``tmp_path``: its path."""
    path = tmp_path / "mini.yaml"
    path.write_text(mini_text)
    return path
