"""How often a policy changes its plan in flight: c1 changes and reversals, and c2 dips to its
lowest value, per flight on the first worlds ``eaplan-drake certify`` draws (the policy flights,
at the ``fast`` rates), with each flight's status, mission quality and the drops that fell inside
it. Not a test.

    python3 benchmarks/bench_plan_changes.py [--worlds 24] [--steady-worlds] [--set KEY=VALUE ...]

A reversal is a change of c1 in the direction opposite to the previous change; a c2 dip is a
stretch at the lowest value of c2's first parameter (the value it flies during the warm-up) after
a stretch above it. Prints one row per
world and the means (quality with lost = 0), and the dips in flights that met no drop.
"""

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

import numpy as np  # noqa: E402

from eaplan_drake.loading import LayerScenario, OverrideFromAssignment  # noqa: E402
from eaplan_drake.simulation import Simulate  # noqa: E402
from eaplan_drake.studies.certify import CertifyStudy  # noqa: E402
from eaplan_drake.studies.sweep import StudyFlights  # noqa: E402


def PlanChanges(times, c1, c2) -> dict:
    """c1 changes and reversals, c2 dips and the time at c2's lowest value [s] of one flight."""
    d = np.diff(np.asarray(c1, dtype=float))
    d = d[np.abs(d) > 1e-9]
    at_lowest = np.asarray(c2, dtype=float) <= float(np.min(c2)) + 1e-9
    return {
        "c1_changes": int(d.size),
        "c1_reversals": int(np.sum(np.sign(d[1:]) != np.sign(d[:-1]))),
        "c2_dips": int(np.sum(at_lowest[1:] & ~at_lowest[:-1])),
        "c2_lowest_time": float(np.sum(np.diff(times)[at_lowest[:-1]])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="survey")
    parser.add_argument("--worlds", type=int, default=24)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument(
        "--steady-worlds",
        action="store_true",
        help="certify's steady worlds (constant wind, nominal pack) instead of its default ones",
    )
    args = parser.parse_args()
    overrides = [OverrideFromAssignment(a) for a in args.set]
    rows = []
    print(
        "| world | status | quality | drops | c1 changes | c1 reversals | c2 dips | c2 lowest [s] |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for keys, scenario in StudyFlights(
        CertifyStudy(args.scenario, args.worlds, changing=not args.steady_worlds)
    ):
        if keys["policy"] == "lowest":
            continue
        log = Simulate(LayerScenario(scenario, overrides))
        s = log.summary
        quality = s["quality"] if s["status"] == "complete" else 0.0
        c = PlanChanges(
            log.times,
            np.asarray(log["path_parameters"])[:, 0],
            np.asarray(log["computation_parameters"])[:, 0],
        )
        drops = sum(1 for f in scenario.battery.faults if f.time < float(log.times[-1]))
        rows.append((quality, *c.values(), drops))
        print(
            f"| {keys['world']} | {s['status']} | {quality:.4f} | {drops} | {c['c1_changes']} | "
            f"{c['c1_reversals']} | {c['c2_dips']} | {c['c2_lowest_time']:.0f} |",
            flush=True,
        )
    table = np.array(rows, dtype=float)
    mean = np.mean(table, axis=0)
    quiet = table[:, 5] == 0
    print()
    print(
        f"mean of {len(rows)} flights: quality {mean[0]:.4f}, c1 changes {mean[1]:.1f}, "
        f"c1 reversals {mean[2]:.1f}, c2 dips {mean[3]:.2f}, c2 at its lowest {mean[4]:.0f} s"
    )
    print(
        f"{int(quiet.sum())} flights met no drop: c2 dips {int(table[quiet, 3].sum())} in all; "
        f"{int((~quiet).sum())} met one or more: c2 dips {int(table[~quiet, 3].sum())}"
    )


if __name__ == "__main__":
    main()
