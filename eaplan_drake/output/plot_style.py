"""The conventions of every figure (:mod:`~eaplan_drake.output.plots`,
:mod:`~eaplan_drake.output.path_plot`) and of the Meshcat replay
(:mod:`~eaplan_drake.output.replay`): one colour, one meaning (:data:`COLORS`), the quality's
colour map (:data:`QUALITY_COLORMAP`), and the texts the figures share (what an infeasible
planner step means for each policy, read from its :class:`~eaplan_drake.registry.PolicyInfo`; the
faults; the end of a flight)."""

import numpy as np

from eaplan_drake.flightlog import FlightLog
from eaplan_drake.params import Scenario
from eaplan_drake.registry import POLICIES

__all__ = ["COLORS", "InfeasibleCause", "QUALITY_COLORMAP"]


QUALITY_COLORMAP = "viridis"
"""The colour map of the quality ½c̃1 + ½c̃2 ∈ [0, 1] (purple 0, yellow 1), in the figures and in
the replay."""

COLORS = {
    "c1": "tab:blue",  # c1 / c̃1, and the markers where c1 changed
    "c2": "tab:orange",  # c2 / c̃2
    "soc": "tab:green",  # SoC b
    "reserve": "tab:cyan",  # the reserve SoC
    "fault": "tab:red",  # battery faults
    "warmup": "0.88",  # the planner's warm-up
    "measured": "0.7",  # measured power Υ
    "true": "k",  # true power y
    "estimated": "tab:brown",  # estimated power ŷ
    "period": "tab:purple",  # period T
    "budget": "tab:olive",  # the paper's output bound b·Q_c·V
    "infeasible": "tab:pink",  # planner steps whose constraint could not be met
    "progress": "k",  # start, end, time marks and direction on the path
    "wind": "0.3",  # the wind arrow
    "uncovered": "0.3",  # the part of the area not covered
}
"""One colour, one meaning, in every figure here (and the replay's bars)."""

_QUALITY_LABEL = "quality ½c̃1 + ½c̃2 [-]"
_C1_NOTE = "c1 = r2² − r² ≤ 0"


def InfeasibleCause(policy: str) -> tuple[str, str]:
    """(why, what was flown) for the planner steps of ``policy`` with ``mission_feasible`` = 0,
    e.g. for ``paper``: ("the paper's output constraint y ≤ b·Q_c·V cannot hold", "flew the
    lowest c2 there")."""
    return _Cause(policy)[:2]


def _Cause(policy: str) -> tuple[str, str, str]:
    info = POLICIES.Info(policy)
    return info.infeasible_why, info.infeasible_flown, info.feasible_means


def _Faults(scenario: Scenario) -> str:
    return ", ".join(f"−{100 * f.soc_drop:g} % at {f.time:g} s" for f in scenario.battery.faults)


def _EndText(summary: dict) -> str:
    status = summary.get("status", "?")
    t = summary.get("duration", float("nan"))
    if status == "complete":
        return f"survey complete at {t:.1f} s"
    if status == "reserve_reached":
        return f"reserve reached at {t:.1f} s"
    if status == "brownout":
        return f"brown-out at {t:.1f} s"
    if status == "time_limit":
        return f"time limit {t:.0f} s"
    return f"{status} at {t:.1f} s"


def _PathBounds(log: FlightLog, scenario: Scenario | None) -> tuple[float, float]:
    bounds = log.summary.get("path_parameter_bounds")
    if bounds is None and scenario is not None:
        bounds = scenario.planner.path_parameter_bounds
    if bounds is None:
        c1 = log["path_parameters"][:, 0]
        bounds = (float(np.min(c1)), float(np.max(c1)))
    return float(bounds[0]), float(bounds[1])
