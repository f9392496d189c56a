"""Regenerates ``flights.json``: the headline numbers of the reference and default-planner flights.

    python3 tests/golden/regenerate.py

flies the flights of ``eaplan-drake compare`` (``eaplan_drake.output.reference.COMPARE_FLIGHTS``)
and writes, for each, its policy, status, duration [s], final SoC [-], quality and the paper's
metric P, rounded for a reader. ``tests/test_golden.py`` flies them again and compares within
stated tolerances; regenerate only when a change of the numbers is intended, and say why in the
change log.
"""

import json
from pathlib import Path

from eaplan_drake.files import AtomicWrite
from eaplan_drake.output.reference import CompareScenarios
from eaplan_drake.simulation import Simulate

GOLDEN = Path(__file__).resolve().with_name("flights.json")


def HeadlineNumbers(summary: dict) -> dict:
    """The numbers a reader quotes from a flight's summary, rounded."""
    metric = summary["metric"]
    return {
        "policy": summary["policy"],
        "status": summary["status"],
        "duration": round(float(summary["duration"]), 2),
        "final_soc": round(float(summary["final_soc"]), 4),
        "quality": round(float(summary["quality"]), 4),
        "metric": None if metric is None else round(float(metric), 3),
    }


def main() -> None:
    flights = {}
    for _, scenario in CompareScenarios():
        flights[scenario.name] = HeadlineNumbers(Simulate(scenario).summary)
        print(scenario.name, flights[scenario.name], flush=True)
    text = json.dumps(flights, indent=2) + "\n"
    AtomicWrite(GOLDEN, lambda f: f.write(text), binary=False)
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
