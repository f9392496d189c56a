"""The CPU of the sequencer's remaining-time staircase alone (``PlanSource.TimeAfter``), replayed.

    python3 benchmarks/bench_staircase.py [--worlds 8] [--repeat 5] [--steady-worlds]

flies the default policy on the first worlds that ``eaplan-drake certify survey`` draws (its
changing worlds unless ``--steady-worlds``) and records every ``TimeAfter`` call the flights make
(the arguments copied: the sequencer hands over its wind estimate as a view of its state) with
its plan and result; then replays the calls ``--repeat`` times, each time on fresh copies of the
plans (a plan pickles without its caches) with the arc times' cache emptied, and prints the least
process CPU of a replay. Every replayed result must equal the flown one. Not a test.
"""

import argparse
import copy
import os
import pickle
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

from eaplan_drake.flight import stages
from eaplan_drake.flight.coverage import PlanSource
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.sweep import StudyFlights


def Record(worlds: int, changing: bool) -> tuple[bytes, list]:
    """(the pickled plans by id, the calls (plan id, arguments, result)) of the policy flights."""
    calls, plans = [], {}
    time_after = PlanSource.TimeAfter

    def Recorded(self, *args):
        plans[id(self)] = self
        args = copy.deepcopy(args)
        result = time_after(self, *args)
        calls.append((id(self), args, result))
        return result

    PlanSource.TimeAfter = Recorded
    try:
        for keys, scenario in StudyFlights(CertifyStudy("survey", worlds, changing=changing)):
            if keys["policy"] != "lowest":
                Simulate(scenario)
    finally:
        PlanSource.TimeAfter = time_after
    return pickle.dumps(plans), calls


def Replay(plans: bytes, calls: list) -> float:
    """Process CPU [s] of the calls on fresh plans; AssertionError if a result differs."""
    fresh = pickle.loads(plans)
    stages._ArcTime.cache_clear()
    start = time.process_time()
    results = [fresh[plan].TimeAfter(*args) for plan, args, _ in calls]
    cpu = time.process_time() - start
    assert results == [result for _, _, result in calls], "a replayed time differs"
    return cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=5, help="replays (least CPU kept)")
    parser.add_argument("--steady-worlds", action="store_true")
    args = parser.parse_args()
    plans, calls = Record(args.worlds, changing=not args.steady_worlds)
    cpu = min(Replay(plans, calls) for _ in range(max(args.repeat, 1)))
    kind = "steady" if args.steady_worlds else "changing"
    print(f"{len(calls)} TimeAfter calls of {args.worlds} {kind} worlds: {cpu:.3f} s CPU")


if __name__ == "__main__":
    main()
