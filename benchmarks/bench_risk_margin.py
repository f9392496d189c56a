"""The CPU of the mpc's risk margin alone (``RiskReserve.Margin``, once a planner step), replayed.

    python3 benchmarks/bench_risk_margin.py [--worlds 8] [--repeat 5] [--steady-worlds]

flies the default policy on the first worlds that ``eaplan-drake certify survey`` draws (its
changing worlds unless ``--steady-worlds``) and records every ``Margin`` call the flights make
with its risk reserve and its result; then replays the calls ``--repeat`` times, each time on
fresh copies of the reserves (their tables of the step rebuilt), and prints the least process
CPU of a replay and its CPU a call. Every replayed margin must equal the flown one bit for bit.
Not a test.
"""

from replay_calls import Main

from eaplan_drake.planning.margins import RiskReserve


def _Bits(margin) -> bytes:
    """What a replayed margin must reproduce: why it is unpriced, or its times [s], margins [-]
    and lowest plan, bit for bit."""
    if hasattr(margin, "why"):
        return margin.why.encode()
    return margin.times.tobytes() + margin.margins.tobytes() + repr(margin.lowest_state).encode()


def _Clean(reserve) -> None:
    reserve._tables = {}  # a replay builds its tables as a flight does


if __name__ == "__main__":
    Main(__doc__.splitlines()[0], RiskReserve, "Margin", key=_Bits, clean=_Clean)
