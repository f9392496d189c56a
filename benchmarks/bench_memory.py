"""Peak memory of the worst legal scenarios against a reference flight, in the same run.

Each flight runs in its own process (its peak resident set is its own): the reference plan i
with the mpc policy, and scenarios that push the fields setting an amount of work to their limits
(a crawling aircraft, whose remaining mission time is far beyond any flight; the longest time
limit; the finest planner grid). Prints each flight's peak RSS [MB] and its ratio to the
reference flight's::

    python3 benchmarks/bench_memory.py

The prediction of the mpc covers at most the longest legal flight (``MAX_TIME_LIMIT``), so no
legal scenario should need much more memory than the reference flight.
"""

import json
import subprocess
import sys

CHILD = """
import json, resource, sys
from eaplan_drake.loading import LoadNamedScenario
from eaplan_drake.simulation import Simulate
log = Simulate(LoadNamedScenario("plan_i", sys.argv[1:]))
print(json.dumps({"status": log.summary["status"],
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))
"""

MPC = "planner: {policy: mpc, warmup: 0.0}"
FLIGHTS = {
    "reference (plan i, mpc, 120 s)": [MPC, "simulation: {time_limit: 120}"],
    "crawling aircraft (airspeed 1e-4 m/s)": [
        MPC,
        "vehicle: {airspeed: 1.0e-4}",
        "wind: {speed: 0.0}",
        "simulation: {time_limit: 120}",
    ],
    "crawling aircraft, risk reserve": [
        MPC,
        "planner: {reserve: risk}",
        "vehicle: {airspeed: 1.0e-4}",
        "wind: {speed: 0.0}",
        "simulation: {time_limit: 120}",
    ],
    "finest c1 grid (201 values)": [
        MPC,
        "planner: {path_parameter_grid_size: 201}",
        "simulation: {time_limit: 120}",
    ],
}


def main() -> None:
    results = {}
    for name, overrides in FLIGHTS.items():
        out = subprocess.run(
            [sys.executable, "-c", CHILD, *overrides], capture_output=True, text=True, check=True
        )
        results[name] = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"  {name}: done", file=sys.stderr, flush=True)
    reference = results[next(iter(FLIGHTS))]["peak_mb"]
    print("| flight | status | peak RSS [MB] | / reference |")
    print("| --- | --- | --- | --- |")
    for name, r in results.items():
        print(f"| {name} | {r['status']} | {r['peak_mb']:.0f} | {r['peak_mb'] / reference:.2f} |")


if __name__ == "__main__":
    main()
