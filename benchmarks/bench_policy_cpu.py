"""The CPU a policy's flight costs against the static lowest plan's, flown in the same process on
the same worlds (the first worlds that ``eaplan-drake certify`` draws, at the ``fast`` rates).

For each world the lowest plan and each configuration are flown back to back and timed with the
process clock, ``--repeat`` times interleaved, and the least CPU of each is kept (the process clock
of a shared machine varies by up to ±50 % between identical flights; the least is the flight's own
cost); the ratio of the two is per world, so a drift of the machine's load between worlds cancels.
Prints a table of per-world ratios and their median, and the decisions' summary (status, quality)
so that a faster version can be checked for the same flights. Not a test.

The flights run with one BLAS thread, as ``eaplan-drake`` and a study's workers fly them
(``OPENBLAS_NUM_THREADS=1`` unless set): with OpenBLAS's default threads the risk tables'
products keep a second thread spinning, which the process clock counts (a learning flight then
costs about twice its single-thread CPU for ~10 % less wall time).

    python3 benchmarks/bench_policy_cpu.py [--worlds 6] [--repeat 3] [--steady-worlds]
        [--config risk=] [--config fixed=planner.reserve=fixed]

A configuration is ``NAME=KEY=VALUE[,KEY=VALUE…]`` (empty: the scenario as it is).
"""

import argparse
import os
import statistics
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

from eaplan_drake.loading import LayerScenario, OverrideFromAssignment
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.sweep import StudyFlights

DEFAULT_CONFIGS = ["risk=", "fixed=planner.reserve=fixed"]


def _Cpu(scenario) -> tuple[float, dict]:
    start = time.process_time()
    summary = Simulate(scenario).summary
    return time.process_time() - start, summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="survey")
    parser.add_argument("--worlds", type=int, default=6)
    parser.add_argument("--repeat", type=int, default=3, help="flights of each pair (least kept)")
    parser.add_argument("--config", action="append", default=None, metavar="NAME=SETTINGS")
    parser.add_argument(
        "--steady-worlds",
        action="store_true",
        help="certify's steady worlds (constant wind, nominal pack) instead of its default ones",
    )
    args = parser.parse_args()
    configs = []
    for text in args.config or DEFAULT_CONFIGS:
        name, _, settings = text.partition("=")
        configs.append((name, [s for s in settings.split(",") if s]))
    flights = StudyFlights(
        CertifyStudy(args.scenario, args.worlds, changing=not args.steady_worlds)
    )
    worlds = {}
    for keys, scenario in flights:
        worlds.setdefault(keys["world"], {})[keys["policy"]] = scenario
    Simulate(worlds[0]["lowest"])  # imports and caches outside the measurement
    ratios = {name: [] for name, _ in configs}
    print("| world | config | status | quality | CPU [s] | lowest CPU [s] | ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for world, pair in sorted(worlds.items()):
        policy = next(s for p, s in pair.items() if p != "lowest")
        for name, settings in configs:
            scenario = LayerScenario(policy, [OverrideFromAssignment(s) for s in settings])
            low_cpu = cpu = float("inf")
            for _ in range(max(args.repeat, 1)):
                low_cpu = min(low_cpu, _Cpu(pair["lowest"])[0])
                this, s = _Cpu(scenario)
                cpu = min(cpu, this)
            ratios[name].append(cpu / low_cpu)
            print(
                f"| {world} | {name} | {s['status']} | {s['quality']:.4f} | {cpu:.2f} | "
                f"{low_cpu:.2f} | {cpu / low_cpu:.2f} |"
            )
    print()
    for name, values in ratios.items():
        print(f"{name}: median CPU ratio to the lowest plan {statistics.median(values):.2f}")


if __name__ == "__main__":
    main()
