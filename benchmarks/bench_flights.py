"""Times each reference flight end to end and reports its speed as × real time and as the ratio to
the reference loop (``reference_loop.py``: the same closed-loop math as one plain numpy loop, no
Drake) measured in the same run: the ratio carries from one machine to the next, an absolute speed
does not. Also the planner's share of the flight and the peak memory (each flight in a fresh
subprocess, so peaks don't mix). Speeds are per CPU second of the flight's process
(``time.process_time``), so that a busy machine slows both sides alike.

    python3 benchmarks/bench_flights.py [--runs 3] [--baseline-tree DIR] [--set KEY=VALUE ...]
                                        [--rates fast] [FLIGHT ...]

FLIGHT: ``plan_I``, ``plan_II``, ``plan_i``, ``plan_ii``, ``plan_I_full`` (plan I with a battery
ten times larger and no reserve, so the whole c1 = 0 survey, ≈ 767 simulated seconds, is flown).
With ``--runs N`` every figure is the median of N runs (flights and reference loop interleaved).
``--baseline-tree DIR`` also flies each flight with the package found in DIR (another checkout,
e.g. ``git worktree add /tmp/baseline <revision>``) and prints the speed-up of this tree over
it, measured in the same run: as the ratio of the two trees' median speeds and as the median of
the per-run ratios (in each run a flight is flown by both trees back to back, so a drift of the
machine's load between runs cancels in the run's ratio). ``--set`` overrides a scenario key of
this tree's flights (as ``simulate --set``), e.g. ``--set simulation.plant=continuous``;
``--rates fast`` flies them at the studies' rate preset (:mod:`eaplan_drake.rates`, the docs'
rates page, docs/rates.rst).

Prints the reference loop's speed, then one row per flight and tree: status, simulated and CPU
seconds, × real time, the ratio to the reference loop, the planner's share (and its number of
solves) and the peak memory; with a baseline tree, the two speed-ups. The figures measured with
it are in the docs' benchmarks page (docs/benchmarks.rst).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = """
import json, resource, sys, time
try:
    from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
except ImportError:  # a baseline tree from before the package layout
    from eaplan_drake.params import LayerScenario, OverrideFromAssignment
    from eaplan_drake.simulation import LoadNamedScenario
from eaplan_drake.simulation import Simulate
name = sys.argv[1]
rates = [a.removeprefix("rates=") for a in sys.argv[2:] if a.startswith("rates=")]
overrides = [OverrideFromAssignment(a) for a in sys.argv[2:] if not a.startswith("rates=")]
if rates:  # a rate preset (eaplan_drake.rates), applied before the --set overrides
    from eaplan_drake.rates import WithRates
    scenario = WithRates(LoadNamedScenario(name.removesuffix("_full")), rates[0])
    scenario = LayerScenario(scenario, overrides)
else:
    scenario = LoadNamedScenario(name.removesuffix("_full"), overrides)
if name.endswith("_full"):  # the whole survey: a battery that cannot run out
    scenario.battery.capacity *= 10.0
    scenario.battery.reserve_soc = 0.0
cpu = time.process_time()
log = Simulate(scenario)
cpu = time.process_time() - cpu
s = log.summary
planner = s["planner"]
print(json.dumps({
    "flight": sys.argv[1],
    "status": s["status"],
    "simulated_s": s["duration"],
    "cpu_s": cpu,
    "planner_s": sum(planner.get("step_times", []) or []),
    "solves": planner.get("solves", 0),
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
}))
"""

REFERENCE_CHILD = """
import json, sys
sys.path.insert(0, sys.argv[2])
from reference_loop import FlyReferenceLoop
try:
    from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
except ImportError:  # a baseline tree from before the package layout
    from eaplan_drake.params import LayerScenario, OverrideFromAssignment
    from eaplan_drake.simulation import LoadNamedScenario
r = FlyReferenceLoop(LoadNamedScenario(sys.argv[1]))
print(json.dumps({"status": r["status"], "simulated_s": r["duration"], "cpu_s": r["cpu_s"]}))
"""

FLIGHTS = ["plan_I", "plan_II", "plan_i", "plan_ii", "plan_I_full"]
REFERENCE_FLIGHT = "plan_I"


def _Run(code: str, args: list[str], tree: str | None) -> dict:
    env = dict(os.environ)
    if tree:
        env["PYTHONPATH"] = tree
    # From a neutral folder: ``python -c`` puts the working directory first on sys.path, which
    # would shadow the tree under test with a checkout in the current folder.
    out = subprocess.run(
        [sys.executable, "-c", code, *args],
        check=True,
        capture_output=True,
        text=True,
        env=env,
        cwd=tempfile.gettempdir(),
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def _Speed(row: dict) -> float:
    """Simulated seconds per CPU second [-]."""
    return row["simulated_s"] / row["cpu_s"] if row["cpu_s"] > 0 else float("nan")


def _Paired(rows: list[dict], baseline_rows: list[dict]) -> str:
    """The median of the per-run speed ratios of two trees' flights, with each run's ratio."""
    ratios = [_Speed(r) / _Speed(b) for r, b in zip(rows, baseline_rows, strict=True)]
    each = ", ".join(f"{x:.2f}" for x in ratios)
    return f"{statistics.median(ratios):.2f}x ({each})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("flights", nargs="*", default=FLIGHTS)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--baseline-tree", default=None)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument(
        "--rates", default="", help="fly this tree's flights at a rate preset (fast, paper)"
    )
    args = parser.parse_args()
    unknown = [f for f in args.flights if f not in FLIGHTS]
    if unknown or args.runs < 1:
        parser.error(f"flights must be among {', '.join(FLIGHTS)} and --runs >= 1")
    trees = {"this": None}
    if args.baseline_tree:
        trees["baseline"] = str(Path(args.baseline_tree).resolve())
    reference, rows = [], {}
    for run in range(args.runs):
        reference.append(_Speed(_Run(REFERENCE_CHILD, [REFERENCE_FLIGHT, str(HERE)], None)))
        for name in args.flights:
            for label, tree in trees.items():
                extra = args.set if label == "this" else []
                if label == "this" and args.rates:
                    extra = [f"rates={args.rates}", *extra]
                rows.setdefault((name, label), []).append(_Run(CHILD, [name, *extra], tree))
        print(f"run {run + 1}/{args.runs} done", file=sys.stderr)
    ref = statistics.median(reference)
    print(
        f"reference loop ({REFERENCE_FLIGHT}, plain numpy): {ref:.0f}x real time per CPU second "
        f"(median of {len(reference)}: {', '.join(f'{r:.0f}' for r in reference)})"
    )
    print()
    header = "| flight | tree | status | simulated [s] | CPU [s] | x real time | / reference loop |"
    header += " planner share | peak [MB] |"
    if "baseline" in trees:
        header += " speed-up over baseline | paired speed-up (per run) |"
    print(header)
    print("| --- " * (header.count("|") - 1) + "|")
    for name in args.flights:
        base_speed = None
        if "baseline" in trees:
            base_speed = statistics.median(_Speed(r) for r in rows[(name, "baseline")])
        for label in trees:
            rs = rows[(name, label)]
            speed = statistics.median(_Speed(r) for r in rs)
            cpu = statistics.median(r["cpu_s"] for r in rs)
            share = statistics.median(r["planner_s"] / r["cpu_s"] for r in rs)
            peak = max(r["peak_rss_mb"] for r in rs)
            line = (
                f"| {name} | {label} | {rs[0]['status']} | {rs[0]['simulated_s']:.1f} | "
                f"{cpu:.2f} | {speed:.0f} | {speed / ref:.3f} | {100 * share:.0f} % "
                f"({rs[0]['solves']} solves) | {peak:.0f} |"
            )
            if base_speed is not None:
                line += f" {speed / base_speed:.2f}x | {_Paired(rs, rows[(name, 'baseline')])} |"
            print(line)


if __name__ == "__main__":
    main()
