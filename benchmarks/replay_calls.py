"""Record one method's calls in the default policy's flights and replay them for their CPU: the
shared part of ``bench_staircase.py`` and ``bench_risk_margin.py``. Not a test.

The flights are those of the first worlds that ``eaplan-drake certify survey`` draws (its
changing worlds unless ``--steady-worlds``). Each call's arguments are copied (a system may hand
over a view of its state) and kept with its object and what its result must reproduce; a replay
runs the calls on fresh copies of the objects (unpickled) and checks every result.
"""

import argparse
import copy
import os
import pickle
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.sweep import StudyFlights


def _Same(result):
    return result


def Record(cls, name: str, worlds: int, changing: bool, key=_Same, clean=None):
    """(the pickled objects by id, the calls (object id, args, kwargs, ``key(result)``)) of the
    method ``cls.name`` in the policy flights; ``clean(obj)`` runs on each object before it is
    pickled (to drop what a replay must build again)."""
    calls, owners = [], {}
    method = getattr(cls, name)

    def Recorded(self, *args, **kwargs):
        owners[id(self)] = self
        args, kwargs = copy.deepcopy(args), copy.deepcopy(kwargs)
        result = method(self, *args, **kwargs)
        calls.append((id(self), args, kwargs, key(result)))
        return result

    setattr(cls, name, Recorded)
    try:
        for keys, scenario in StudyFlights(CertifyStudy("survey", worlds, changing=changing)):
            if keys["policy"] != "lowest":
                Simulate(scenario)
    finally:
        setattr(cls, name, method)
    for owner in owners.values():
        if clean is not None:
            clean(owner)
    return pickle.dumps(owners), calls


def Replay(owners: bytes, name: str, calls: list, key=_Same, reset=None) -> float:
    """Process CPU [s] of the calls on fresh objects (``reset()`` first); AssertionError if a
    result's key differs from the flown one."""
    fresh = pickle.loads(owners)
    if reset is not None:
        reset()
    start = time.process_time()
    results = [getattr(fresh[owner], name)(*args, **kwargs) for owner, args, kwargs, _ in calls]
    cpu = time.process_time() - start
    assert [key(r) for r in results] == [k for *_, k in calls], f"a replayed {name} differs"
    return cpu


def Main(description: str, cls, name: str, key=_Same, clean=None, reset=None) -> None:
    """The command line of a replay benchmark: records, replays ``--repeat`` times and prints the
    least CPU of a replay and its CPU a call."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=5, help="replays (least CPU kept)")
    parser.add_argument("--steady-worlds", action="store_true")
    args = parser.parse_args()
    owners, calls = Record(cls, name, args.worlds, not args.steady_worlds, key, clean)
    cpu = min(Replay(owners, name, calls, key, reset) for _ in range(max(args.repeat, 1)))
    kind = "steady" if args.steady_worlds else "changing"
    print(
        f"{len(calls)} {name} calls of {args.worlds} {kind} worlds: {cpu:.3f} s CPU, "
        f"{1e6 * cpu / max(len(calls), 1):.0f} us a call"
    )
