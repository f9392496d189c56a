"""The paper's reference numbers (paper 003 Sec. V and the authors' logs), the flights that are
set beside them (:data:`COMPARE_FLIGHTS`, :func:`CompareScenarios`) and the table that does it
(``eaplan-drake compare``, notebook 03)."""

import typing

from eaplan_drake.loading import LayerScenario, LoadNamedScenario
from eaplan_drake.params import PlannerParams, Scenario

__all__ = ["COMPARE_FLIGHTS", "PAPER_RESULTS", "CompareScenarios", "CompareTable"]

COMPARE_FLIGHTS = (
    ("plan_I", None),
    ("plan_II", None),
    ("plan_i", None),
    ("plan_ii", None),
    ("plan_i", "mpc"),
    ("plan_ii", "mpc"),
)
"""The flights of ``compare``: the four reference flights (the paper's policy, as pinned in
their scenarios) and the two dynamic ones again with the default planner (the mpc policy)."""

PAPER_RESULTS = {
    # paper 003 Sec. V / the authors' logs: survey time [s] and metric P (None = fails)
    "plan_I": {"duration": 724.7, "metric": None},
    "plan_II": {"duration": 318.7, "metric": 0.0},
    "plan_i": {"duration": 403.2, "metric": 13.045},
    "plan_ii": {"duration": 662.0, "metric": 2.245},
}


def CompareScenarios(
    overrides: typing.Sequence[str] = (), flights=None
) -> list[tuple[str, Scenario]]:
    """``(reference name, scenario)`` of each of ``flights`` (default :data:`COMPARE_FLIGHTS`),
    with the YAML ``overrides`` layered last. A flight with a policy is the shipped scenario
    flown by that policy with the planner's default warm-up (``planner.warmup``,
    ``planner.warmup_parameters``), named ``<name>_<policy>``."""
    scenarios = []
    for name, policy in COMPARE_FLIGHTS if flights is None else flights:
        scenario = LoadNamedScenario(name)
        if policy:
            scenario.planner.policy = policy
            scenario.planner.warmup = PlannerParams().warmup
            scenario.planner.warmup_parameters = PlannerParams().warmup_parameters
            scenario.name = f"{name}_{policy}"
        scenarios.append((name, LayerScenario(scenario, overrides)))
    return scenarios


def CompareTable(rows) -> str:
    """A Markdown table of (name, our summary, paper numbers) rows: quality and completion
    first, the paper's metric P last."""

    def fmt(m):
        return "fail" if m is None else f"{m:.3f}"

    lines = [
        "| flight | policy | status | quality | final margin | time [s] | paper time [s] | P | "
        "paper P |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, s, paper in rows:
        lines.append(
            f"| {name} | {s.get('policy', '')} | {s['status']} | {s['quality']:.3f} | "
            f"{s['final_margin']:+.3f} | {s['duration']:.1f} | {paper['duration']:.1f} | "
            f"{fmt(s['metric'])} | {fmt(paper['metric'])} |"
        )
    return "\n".join(lines)
