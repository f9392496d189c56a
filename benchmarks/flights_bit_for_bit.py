"""Are the flights of this tree the same, bit for bit, as those of another tree?

    python3 benchmarks/flights_bit_for_bit.py --baseline-tree ../base [--flights plan_i,survey]
        [--certify-worlds 20] [--changing-worlds 8] [--certify-set planner.reserve=fixed]

flies each flight in a fresh process with this tree and with the baseline tree (a checkout of
another version, e.g. ``git worktree add ../base <commit>``), saves every logged signal and the
summary, and compares them with ``numpy.array_equal(..., equal_nan=True)``; summary fields that
measure the machine (wall and solve times) are left out. Prints one line per flight and exits
non-zero if any differs. The default flights: the four reference flights, the compare flights
with the default planner, a greedy flight in wind, the shipped survey and the shipped field
(``funen``); ``--certify-worlds N`` adds the default policy's flights on the first N worlds that
``eaplan-drake certify survey`` draws (faults, noise, dropouts and wind: they exercise the risk
reserve's every branch), with ``--certify-set`` assignments on their scenario if given;
``--changing-worlds N`` the same on the first N of certify's default worlds, those that change in
flight (gusts, drift, the pack's health, the payload's offset: the wind estimate and the staircase
move at every stage), for trees that have them.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

FLIGHTS = {
    "plan_I": ("plan_I", []),
    "plan_II": ("plan_II", []),
    "plan_i": ("plan_i", []),
    "plan_ii": ("plan_ii", []),
    "plan_i_mpc": ("plan_i", ["planner: {policy: mpc}"]),
    "plan_ii_mpc": ("plan_ii", ["planner: {policy: mpc}"]),
    "plan_i_greedy_wind": ("plan_i", ["planner: {policy: greedy}", "wind: {speed: 6.0}"]),
    "survey": ("survey", []),
    "funen": ("funen", []),
}

CHILD = """
import json, sys
import numpy as np
try:
    from eaplan_drake.loading import LoadNamedScenario
except ImportError:  # a tree from before the package layout
    from eaplan_drake.simulation import LoadNamedScenario
from eaplan_drake.simulation import Simulate
name, out = sys.argv[1], sys.argv[2]
if name.startswith("certify"):  # the policy flight of one world that certify draws
    import inspect
    from eaplan_drake.studies.certify import CertifyStudy
    from eaplan_drake.studies.sweep import StudyFlights
    # certify's steady worlds (a tree from before they were certify's default takes no keyword),
    # or its changing ones
    kind = {"changing": False} if "changing" in inspect.signature(CertifyStudy).parameters else {}
    if name.startswith("certify-changing:"):
        kind = {"changing": True}
    scenario_name, world = name.split(":")[1], int(name.split(":")[2])
    flights = StudyFlights(CertifyStudy(scenario_name, world + 1, **kind))
    scenario = next(s for k, s in flights if k["world"] == world and k["policy"] != "lowest")
    if json.loads(sys.argv[3]):  # --certify-set: KEY=VALUE assignments on the world's scenario
        from eaplan_drake.loading import LayerScenario, OverrideFromAssignment

        assignments = json.loads(sys.argv[3])
        scenario = LayerScenario(scenario, [OverrideFromAssignment(a) for a in assignments])
else:
    scenario = LoadNamedScenario(name, json.loads(sys.argv[3]))
log = Simulate(scenario)
np.savez(out, times=log.times, summary=json.dumps(log.summary, default=str), **log.signals)
"""

MACHINE = (
    "wall_time",
    "realtime_factor",
    "step_times",
    "median_step_time",
    "p95_step_time",
    "solve_times",
    "median_solve_time",
    "p95_solve_time",
)


def _Fly(tree: Path, scenario: str, overrides: list, out: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(tree))
    subprocess.run(
        [sys.executable, "-c", CHILD, scenario, str(out), json.dumps(overrides)],
        env=env,
        check=True,
        capture_output=True,
        cwd=tree,
    )


def _Summary(text: str) -> dict:
    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if k not in MACHINE}
        return value

    return strip(json.loads(text))


def Compare(a: Path, b: Path) -> tuple[list[str], list[str]]:
    """(signals and summary keys that differ, signals only this tree logs) of two saved flights."""
    with np.load(a) as x, np.load(b) as y:
        new = [k for k in x.files if k not in y.files]
        differ = [
            k
            for k in x.files
            if k != "summary" and k in y.files and not np.array_equal(x[k], y[k], equal_nan=True)
        ]
        sx, sy = _Summary(str(x["summary"])), _Summary(str(y["summary"]))
    return differ + [f"summary.{k}" for k in _Differ(sx, sy)], new


def _Differ(x: dict, y: dict) -> list[str]:
    """The keys both summaries have whose values differ (nested dicts key by key: statistics this
    tree adds are new, not different)."""
    out = []
    for k in x:
        if k not in y:
            continue
        if isinstance(x[k], dict) and isinstance(y[k], dict):
            out += [f"{k}.{inner}" for inner in _Differ(x[k], y[k])]
        elif x[k] != y[k]:
            out.append(k)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline-tree", required=True, type=Path)
    ap.add_argument("--flights", default=",".join(FLIGHTS), help="comma-separated names")
    ap.add_argument("--certify-worlds", type=int, default=0, metavar="N")
    ap.add_argument(
        "--changing-worlds",
        type=int,
        default=0,
        metavar="N",
        help="the first N of certify's worlds that change in flight (its default ones)",
    )
    ap.add_argument(
        "--certify-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an assignment on every certify world's policy scenario (e.g. planner.reserve=fixed)",
    )
    args = ap.parse_args()
    here = Path(__file__).resolve().parents[1]
    flights = {name: FLIGHTS[name] for name in args.flights.split(",") if name}
    flights.update(
        {
            f"certify_{k}": (f"certify:survey:{k}", args.certify_set)
            for k in range(args.certify_worlds)
        }
    )
    flights.update(
        {
            f"changing_{k}": (f"certify-changing:survey:{k}", args.certify_set)
            for k in range(args.changing_worlds)
        }
    )
    same = True
    with tempfile.TemporaryDirectory() as tmp:
        for name, (scenario, overrides) in flights.items():
            mine, theirs = Path(tmp) / f"{name}_this.npz", Path(tmp) / f"{name}_base.npz"
            _Fly(here, scenario, overrides, mine)
            _Fly(args.baseline_tree.resolve(), scenario, overrides, theirs)
            differ, new = Compare(mine, theirs)
            same &= not differ
            verdict = "bit for bit the same" if not differ else "DIFFERS: " + ", ".join(differ)
            extra = f" (signals only this tree logs: {', '.join(new)})" if new else ""
            print(f"{name}: {verdict}{extra}")
    print("all flights bit for bit the same" if same else "some flights differ")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
