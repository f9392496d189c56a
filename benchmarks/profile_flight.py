"""Profiles one reference flight with cProfile and prints the top functions by own time, with
their share of the flight's profiled time: where a flight's time goes.

    python3 benchmarks/profile_flight.py [FLIGHT] [--top 10] [--set KEY=VALUE ...]

FLIGHT: a shipped scenario name (default ``plan_i``). The profiler roughly doubles the run time;
read the shares, not the seconds.
"""

import argparse
import cProfile
import pstats
import time

from eaplan_drake.loading import LoadNamedScenario, OverrideFromAssignment
from eaplan_drake.simulation import Simulate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("flight", nargs="?", default="plan_i")
    parser.add_argument("--top", type=int, default=10)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    scenario = LoadNamedScenario(args.flight, [OverrideFromAssignment(a) for a in args.set])
    profile = cProfile.Profile()
    cpu = time.process_time()
    profile.enable()
    log = Simulate(scenario)
    profile.disable()
    cpu = time.process_time() - cpu
    s = log.summary
    flown = f"{s['status']}, {s['duration']:.1f} s simulated"
    print(f"{args.flight}: {flown}, {cpu:.1f} s CPU (profiled)")
    print()
    stats = pstats.Stats(profile)
    total = sum(row[2] for row in stats.stats.values())  # own time of every function
    rows = sorted(stats.stats.items(), key=lambda kv: -kv[1][2])[: args.top]
    print("| # | function | calls | own time [s] | share |")
    print("| --- | --- | --- | --- | --- |")
    for i, ((path, line, name), (_, calls, own, _cum, _)) in enumerate(rows, 1):
        where = name if path == "~" else f"{path.rsplit('/', 1)[-1]}:{line}({name})"
        print(f"| {i} | `{where}` | {calls} | {own:.2f} | {100.0 * own / total:.0f} % |")


if __name__ == "__main__":
    main()
