"""The CPU of the sequencer's remaining-time staircase alone (``PlanSource.TimeAfter``), replayed.

    python3 benchmarks/bench_staircase.py [--worlds 8] [--repeat 5] [--steady-worlds]

flies the default policy on the first worlds that ``eaplan-drake certify survey`` draws (its
changing worlds unless ``--steady-worlds``) and records every ``TimeAfter`` call the flights make
(the arguments copied: the sequencer hands over its wind estimate as a view of its state) with
its plan and result; then replays the calls ``--repeat`` times, each time on fresh copies of the
plans (a plan pickles without its caches) with the arc times' cache emptied, and prints the least
process CPU of a replay and its CPU a call. Every replayed result must equal the flown one. Not a
test.
"""

from replay_calls import Main

from eaplan_drake.flight import stages
from eaplan_drake.flight.coverage import PlanSource

if __name__ == "__main__":
    # a plan pickles without its caches; the arcs' times are a module cache, emptied per replay
    Main(__doc__.splitlines()[0], PlanSource, "TimeAfter", reset=stages._ArcTime.cache_clear)
