"""Command line: ``eaplan-drake simulate | diagram | compare``.

- ``eaplan-drake simulate SCENARIO [--out DIR]``: SCENARIO is a shipped name (plan_I, plan_II,
  plan_i, plan_ii) or a YAML path; prints progress and the summary, writes the log and the plots.
- ``eaplan-drake diagram [--out DIR]``: DOT and SVG of the closed loop and each subsystem.
- ``eaplan-drake compare [--out DIR]``: the four reference flights next to the paper's numbers.

A bad scenario is one line on stderr and exit status 2, never a traceback.
"""

import argparse
import sys
from pathlib import Path

from eaplan_drake.params import ScenarioError

__all__ = ["PAPER_RESULTS", "main"]

PAPER_RESULTS = {
    # paper 003 Sec. V / the authors' logs: survey time [s] and metric P (None = fails)
    "plan_I": {"duration": 724.7, "metric": None},
    "plan_II": {"duration": 318.7, "metric": 0.0},
    "plan_i": {"duration": 403.2, "metric": 13.045},
    "plan_ii": {"duration": 662.0, "metric": 2.245},
}


def _Progress(t: float, soc: float) -> None:
    print(f"  t = {t:6.0f} s   SoC = {soc:.3f}", file=sys.stderr, flush=True)


def _FormatSummary(summary: dict) -> str:
    metric = summary.get("metric")
    planner = summary.get("planner", {})
    lines = [
        f"scenario        {summary['scenario']}",
        f"status          {summary['status']}",
        f"duration        {summary['duration']:.1f} s",
        f"final SoC       {summary['final_soc']:.3f} (reserve {summary['reserve_soc']:.2f})",
        f"mean c1~, c2~   {summary['mean_path_parameter_normalised']:.3f}, "
        f"{summary['mean_computation_parameter_normalised']:.3f}",
        f"metric P        {'fail' if metric is None else f'{metric:.3f}'}",
        f"planner         {planner.get('solves', 0)} solves, {planner.get('failures', 0)} "
        f"failures, median {1e3 * (planner.get('median_solve_time') or 0.0):.1f} ms",
        f"wall time       {summary['wall_time']:.1f} s "
        f"({summary['realtime_factor']:.0f}x real time)",
    ]
    return "\n".join(lines)


def _Simulate(args) -> int:
    from eaplan_drake.plots import SaveFlightPlots
    from eaplan_drake.simulation import LoadNamedScenario, Simulate

    scenario = LoadNamedScenario(args.scenario)
    out = Path(args.out) / scenario.name
    print(f"simulating {scenario.name} ...", file=sys.stderr, flush=True)
    log = Simulate(scenario, progress=_Progress)
    log.Save(out)
    png = SaveFlightPlots(log, scenario, out)
    print(_FormatSummary(log.summary))
    print(f"log and plots in {out} ({png.name})")
    return 0


def _Diagram(args) -> int:
    from eaplan_drake.graphviz import WriteDiagrams

    written = WriteDiagrams(args.out)
    print(f"wrote {len(written)} files to {args.out}")
    if not any(p.suffix == ".svg" for p in written):
        print("note: Graphviz's `dot` was not found, so no SVG was rendered", file=sys.stderr)
    return 0


def _Compare(args) -> int:
    from eaplan_drake.plots import SaveFlightPlots
    from eaplan_drake.simulation import REFERENCE_SCENARIOS, LoadNamedScenario, Simulate

    rows = []
    for name in REFERENCE_SCENARIOS:
        scenario = LoadNamedScenario(name)
        print(f"simulating {name} ...", file=sys.stderr, flush=True)
        log = Simulate(scenario)
        if args.out:
            log.Save(Path(args.out) / name)
            SaveFlightPlots(log, scenario, Path(args.out) / name)
        rows.append((name, log.summary, PAPER_RESULTS[name]))
    print(CompareTable(rows))
    return 0


def CompareTable(rows) -> str:
    """A Markdown table of (name, our summary, paper numbers) rows."""

    def fmt(m):
        return "fail" if m is None else f"{m:.3f}"

    lines = [
        "| flight | status | time [s] | paper time [s] | final SoC | P | paper P |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, s, paper in rows:
        lines.append(
            f"| {name} | {s['status']} | {s['duration']:.1f} | {paper['duration']:.1f} | "
            f"{s['final_soc']:.3f} | {fmt(s['metric'])} | {fmt(paper['metric'])} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="eaplan-drake",
        description="Energy-aware planning-scheduling for fixed-wing UAVs (Drake).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("simulate", help="fly one scenario; print the summary; write log and plots")
    p.add_argument("scenario", help="shipped name (plan_I, plan_II, plan_i, plan_ii) or YAML path")
    p.add_argument("--out", default="out", help="output directory (default: out/)")
    p.set_defaults(run=_Simulate)
    p = sub.add_parser("diagram", help="write DOT and SVG of the closed loop and its systems")
    p.add_argument("--out", default="diagrams", help="output directory (default: diagrams/)")
    p.set_defaults(run=_Diagram)
    p = sub.add_parser("compare", help="the four reference flights next to the paper's numbers")
    p.add_argument("--out", default="", help="also write each flight's log and plots here")
    p.set_defaults(run=_Compare)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except ScenarioError as e:
        print(f"eaplan-drake: scenario error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("eaplan-drake: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
