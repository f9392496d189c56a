"""Times each reference flight end to end: wall time, simulated seconds per wall second, the
planner's share, and peak memory (each flight in a fresh subprocess, so peaks don't mix).

Target on the 2-core reference machine: plan I in <= 15 s wall (>= 50x real time), peak memory
<= 1 GB.

    python3 benchmarks/bench_flights.py [plan_I plan_II plan_i plan_ii plan_I_full]

``plan_I_full`` is plan I with a battery ten times larger and no reserve, so that the whole
c1 = 0 survey (~767 simulated seconds) is flown: the case the target speaks of.
"""

import json
import subprocess
import sys

CHILD = """
import json, resource, sys, time
from eaplan_drake.simulation import LoadNamedScenario, Simulate
name = sys.argv[1]
scenario = LoadNamedScenario(name.removesuffix("_full"))
if name.endswith("_full"):  # the whole survey: a battery that cannot run out
    scenario.battery.capacity *= 10.0
    scenario.battery.reserve_soc = 0.0
log = Simulate(scenario)
s = log.summary
planner = s["planner"]
print(json.dumps({
    "flight": sys.argv[1],
    "status": s["status"],
    "simulated_s": s["duration"],
    "wall_s": s["wall_time"],
    "realtime_factor": s["realtime_factor"],
    "planner_s": sum(planner.get("step_times", []) or []),
    "solves": planner.get("solves", 0),
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
}))
"""


def main(names):
    rows = []
    for name in names:
        out = subprocess.run(
            [sys.executable, "-c", CHILD, name], check=True, capture_output=True, text=True
        ).stdout
        rows.append(json.loads(out.strip().splitlines()[-1]))
    header = (
        "| flight | status | simulated [s] | wall [s] | x real time | planner share | peak [MB] |"
    )
    print(header)
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        share = r["planner_s"] / r["wall_s"] if r["wall_s"] > 0 else 0.0
        print(
            f"| {r['flight']} | {r['status']} | {r['simulated_s']:.1f} | {r['wall_s']:.2f} | "
            f"{r['realtime_factor']:.0f} | {100 * share:.0f} % ({r['solves']} solves) | "
            f"{r['peak_rss_mb']:.0f} |"
        )


if __name__ == "__main__":
    main(sys.argv[1:] or ["plan_I", "plan_II", "plan_i", "plan_ii", "plan_I_full"])
