"""The CPU of the mpc's risk margin alone (``RiskReserve.Margin``, once a planner step), replayed.

    python3 benchmarks/bench_risk_margin.py [--worlds 8] [--repeat 5] [--steady-worlds]

flies the default policy on the first worlds that ``eaplan-drake certify survey`` draws (its
changing worlds unless ``--steady-worlds``) and records every ``Margin`` call the flights make
with its risk reserve and its result; then replays the calls ``--repeat`` times, each time on
fresh copies of the reserves (their tables of the step rebuilt), and prints the least process
CPU of a replay and its CPU a call. Every replayed margin must equal the flown one bit for bit.
Not a test.
"""

import argparse
import copy
import os
import pickle
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

from eaplan_drake.planning.margins import RiskReserve
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.sweep import StudyFlights


def _Bits(margin) -> bytes:
    """What a replayed margin must reproduce: why it is unpriced, or its times [s], margins [-]
    and lowest plan, bit for bit."""
    if hasattr(margin, "why"):
        return margin.why.encode()
    return margin.times.tobytes() + margin.margins.tobytes() + repr(margin.lowest_state).encode()


def Record(worlds: int, changing: bool) -> tuple[bytes, list]:
    """(the pickled reserves by id, the calls (reserve id, arguments, result's bits)) of the
    policy flights."""
    calls, reserves = [], {}
    margin = RiskReserve.Margin

    def Recorded(self, *args, **kwargs):
        reserves[id(self)] = self
        args, kwargs = copy.deepcopy(args), copy.deepcopy(kwargs)
        result = margin(self, *args, **kwargs)
        calls.append((id(self), args, kwargs, _Bits(result)))
        return result

    RiskReserve.Margin = Recorded
    try:
        for keys, scenario in StudyFlights(CertifyStudy("survey", worlds, changing=changing)):
            if keys["policy"] != "lowest":
                Simulate(scenario)
    finally:
        RiskReserve.Margin = margin
    for reserve in reserves.values():
        reserve._tables = {}  # a replay builds its tables as a flight does
    return pickle.dumps(reserves), calls


def Replay(reserves: bytes, calls: list) -> float:
    """Process CPU [s] of the calls on fresh reserves; AssertionError if a margin differs."""
    fresh = pickle.loads(reserves)
    start = time.process_time()
    results = [fresh[reserve].Margin(*args, **kwargs) for reserve, args, kwargs, _ in calls]
    cpu = time.process_time() - start
    assert [_Bits(r) for r in results] == [bits for *_, bits in calls], "a replayed margin differs"
    return cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=5, help="replays (least CPU kept)")
    parser.add_argument("--steady-worlds", action="store_true")
    args = parser.parse_args()
    reserves, calls = Record(args.worlds, changing=not args.steady_worlds)
    cpu = min(Replay(reserves, calls) for _ in range(max(args.repeat, 1)))
    kind = "steady" if args.steady_worlds else "changing"
    print(
        f"{len(calls)} Margin calls of {args.worlds} {kind} worlds: {cpu:.3f} s CPU, "
        f"{1e6 * cpu / max(len(calls), 1):.0f} us a call"
    )


if __name__ == "__main__":
    main()
