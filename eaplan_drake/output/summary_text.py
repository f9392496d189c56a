"""A flight's summary as the command line prints it (``eaplan-drake simulate``): its status,
quality and margin, and how the planner decided its steps, in the words of each policy's
:class:`~eaplan_drake.registry.PolicyInfo`."""

import statistics

from eaplan_drake.output.plot_style import InfeasibleCause
from eaplan_drake.registry import POLICIES

__all__ = ["FormatSummary"]


def FormatSummary(summary: dict) -> str:
    """The summary of a flight as ``eaplan-drake simulate`` prints it: status, quality, margin,
    the paper's metric, how the planner decided its steps, wall time."""
    metric = summary.get("metric")
    planner = summary.get("planner", {})
    policy = summary.get("policy", "?")
    infeasible_at = summary.get("first_infeasible_time")
    steps, infeasible = planner.get("solves", 0), planner.get("infeasible", 0)
    indent = " " * 16
    info = POLICIES.Info(policy)
    if info.holds_parameters and not steps:
        planning = [f"planner         none: the {policy} policy holds the initial parameters"]
    else:
        planning = [
            f"planner         {steps} steps: {infeasible} infeasible"
            + (f" (first at {infeasible_at:.1f} s)" if infeasible_at is not None else "")
            + f", {planner.get('failures', 0)} solver fallbacks"
        ]
        solved = [t for t in planner.get("solve_times") or [] if t and t > 0.0]
        kinds = planner.get("kinds") or {}
        if not steps:
            planning.append(f"{indent}no planner step: the flight ended before the first one")
        elif kinds:
            planning.append(indent + _DecisionKinds(kinds, steps, solved))
        elif solved:
            planning.append(
                f"{indent}NLP solved at {len(solved)} of {steps} steps, "
                f"median {1e3 * statistics.median(solved):.1f} ms"
            )
        elif "solve_times" not in planner and planner.get("median_solve_time"):
            planning.append(f"{indent}median solve {1e3 * planner['median_solve_time']:.1f} ms")
        else:  # a policy that solves no NLP: say so, not "median solve 0.0 ms"
            planning.append(indent + info.without_solve)
        unpriced = kinds.get("unpriced", 0)
        if unpriced:
            why = planner.get("first_status", {}).get("unpriced", "")
            why = why.removeprefix("unpriced: ").removesuffix("; the lowest plan")
            planning.append(
                f"{indent}{unpriced} steps whose fault risk could not be priced (first: {why}); "
                "flew the lowest plan there, flagged infeasible"
            )
        infeasible -= unpriced + kinds.get("invalid", 0)
        if infeasible:
            why, what = InfeasibleCause(policy)
            planning.append(f"{indent}{infeasible} steps where {why}; {what}")
        health = (planner.get("policy_figures") or {}).get("pack_health")
        if health is not None:
            planning.append(
                f"{indent}the pack holds {health:.2f} of its label (estimated in flight)"
            )
    lines = [
        f"scenario        {summary['scenario']}",
        f"policy          {summary.get('policy', '?')}",
        f"status          {summary['status']}: {summary.get('end_reason', '')}",
        f"quality         {summary['quality']:.3f} = mean(½c1~ + ½c2~), "
        f"c1~ {summary['mean_path_parameter_normalised']:.3f}, "
        f"c2~ {summary['mean_computation_parameter_normalised']:.3f}",
        f"final margin    {summary['final_margin']:+.3f} (SoC {summary['final_soc']:.3f}, "
        f"reserve {summary['reserve_soc']:.2f})",
        f"duration        {summary['duration']:.1f} s",
        f"metric P        {'fail' if metric is None else f'{metric:.3f}'} (paper's; see README)",
        *planning,
        f"wall time       {summary['wall_time']:.1f} s "
        f"({summary['realtime_factor']:.0f}x real time)",
    ]
    for skipped in summary.get("skipped_exports") or []:
        lines.append(f"not written     {skipped}")
    if "hindsight" in summary:
        lines.append(f"hindsight       {len(summary['hindsight'])} static flights flown")
    return "\n".join(lines)


_KIND_TEXTS = {
    "determined": "decided exactly on the table's grid without a solve at {}",
    "fallback": "the solver failed at {} (c1 kept, the best admissible c2)",
    "lowest": "the lowest plan at {} (its margin not met yet, infeasible, or after a drop)",
    "invalid": "an observation not finite at {}",
    "chosen": "a static plan chosen at take-off ({} step)",
    "held": "held at {}",
}


def _DecisionKinds(kinds: dict, steps: int, solved: list) -> str:
    """How a policy that reports its decisions' kinds decided its steps, in one line."""
    parts = []
    if kinds.get("solved"):
        median = f", median {1e3 * statistics.median(solved):.1f} ms" if solved else ""
        parts.append(f"NLP solved at {kinds['solved']} of {steps} steps{median}")
    else:
        parts.append(f"no NLP solved in {steps} steps")
    parts += [text.format(kinds[k]) for k, text in _KIND_TEXTS.items() if kinds.get(k)]
    return "; ".join(parts)
