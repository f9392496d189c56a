"""Fields flown by the sequencer: seeded random non-convex fields with 0–2 holes, and the
shipped field.

For each random field (``eaplan_drake.field.random_fields.RandomField(seed, holes=seed % 3)``)
at c1 = 0 in still air: the area its swaths (x_d along the survey lines) cover, how far lines
and turns reach outside it, and the guidance loop's flight (``FlyTracking`` at the fast rates):
whether it completes and its time against the plan's nominal time. Then the pre-flight
prediction (``eaplan-drake plan``: time and SoC of the static lowest plan) against the same plan
flown with the whole closed loop, on the shipped field and three random ones.

    python3 benchmarks/bench_fields.py [--fields 20] [--out benchmarks/results/fields.json]

Prints one row per field and a summary; writes the rows (JSON) whole or not at all.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from eaplan_drake.field.plan import LowestPlanEnergy  # noqa: E402
from eaplan_drake.field.random_fields import RandomField  # noqa: E402
from eaplan_drake.field.readers import FieldGeoJsonText  # noqa: E402
from eaplan_drake.field.source import FieldCoverage  # noqa: E402
from eaplan_drake.files import AtomicWrite, StrictJson  # noqa: E402
from eaplan_drake.flight.stages import APPROACH  # noqa: E402
from eaplan_drake.loading import LoadNamedScenario  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402
from eaplan_drake.rates import WithRates  # noqa: E402
from eaplan_drake.resolve import ResolveScenario  # noqa: E402
from eaplan_drake.simulation import Simulate  # noqa: E402
from eaplan_drake.studies.tracking import FlyTracking  # noqa: E402
from eaplan_drake.studies.worlds import LowestPlan  # noqa: E402

LO, HI = -1000.0, 0.0


def RandomRow(seed: int) -> dict:
    field = RandomField(seed, holes=seed % 3)
    s = WithRates(Scenario(), "fast")
    s.wind.speed = 0.0
    source = FieldCoverage(
        field,
        s.coverage,
        start=(-250.0, -250.0),
        airspeed=s.vehicle.airspeed,
        initial_c1=HI,
        k_e=s.guidance.k_e,
        c1_bounds=(LO, HI),
        initial_heading_deg=45.0,
    )
    stages = source.Stages(HI)
    out = {"line": 0.0, "turn": 0.0}
    for st in stages:
        if st.primitive != APPROACH:
            kind = "line" if st.primitive in (0, 2) else "turn"
            out[kind] = max(out[kind], source.DistanceOutside(st))
    approach = next(i for i, st in enumerate(stages) if st.primitive != APPROACH)
    predicted = source.CoverageTime(HI, s.vehicle.airspeed)
    flight = FlyTracking(s, source, HI, t_max=1.5 * predicted + 120.0)
    return {
        "field": f"random {seed}",
        "holes": len(field.holes),
        "cells": len(source.decomposition.cells),
        "area_ha": field.area / 1e4,
        "covered": source.SwathCoverage(HI),
        "line_outside_m": out["line"],
        "turn_outside_m": out["turn"],
        "complete": flight["complete"],
        "time_s": flight["t_end"],
        "predicted_s": predicted,
        "approach_stages": approach,
    }


def PredictionRow(name: str, scenario) -> dict:
    scenario.wind.speed = 0.0
    scenario = WithRates(LowestPlan(scenario), "fast")
    resolved = ResolveScenario(scenario)
    predicted = LowestPlanEnergy(resolved.plan.plan, scenario)
    stages = resolved.plan.Stages(LO)
    approach = next(i for i, st in enumerate(stages) if st.primitive != APPROACH)
    result = Simulate(scenario)
    stage = result["stage"][:, 0]
    k = int(np.argmax(stage > approach - 0.5))
    t0, soc0 = result.times[k], result["soc"][k, 0]
    flown = result.summary["duration"] - t0
    drop = soc0 - result.summary["final_soc"]
    predicted_drop = predicted["initial_soc"] - predicted["final_soc"]
    return {
        "field": name,
        "complete": result.summary["completed"],
        "flown_s": flown,
        "predicted_s": predicted["time"],
        "time_error": flown / predicted["time"] - 1.0,
        "soc_drop": drop,
        "predicted_soc_drop": predicted_drop,
        "soc_error": drop - predicted_drop,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fields", type=int, default=20)
    parser.add_argument("--out", default="benchmarks/results/fields.json")
    args = parser.parse_args(argv)
    rows = []
    print("field       holes cells  ha   covered  line out  turn out  complete  time/nominal")
    for seed in range(args.fields):
        r = RandomRow(seed)
        rows.append(r)
        print(
            f"{r['field']:<11} {r['holes']:>5} {r['cells']:>5} {r['area_ha']:5.1f} "
            f"{100 * r['covered']:7.2f} % {r['line_outside_m']:7.1f} m {r['turn_outside_m']:7.1f} m"
            f"  {str(r['complete']):>8}  {r['time_s'] / r['predicted_s']:.4f}"
        )
    predictions = []
    with tempfile.TemporaryDirectory() as tmp:
        cases = [("funen", LoadNamedScenario("funen"))]
        for seed in (0, 4, 8):
            path = Path(tmp) / f"random_{seed}.geojson"
            path.write_text(FieldGeoJsonText(RandomField(seed, holes=seed % 3)))
            s = LoadNamedScenario("funen")
            s.coverage.field = str(path)
            cases.append((f"random {seed}", s))
        print("\npre-flight plan vs the same lowest plan flown (still air, fast rates)")
        print("field       complete  flown s  predicted s  time error  SoC drop  predicted  error")
        for name, s in cases:
            p = PredictionRow(name, s)
            predictions.append(p)
            print(
                f"{name:<11} {str(p['complete']):>8} {p['flown_s']:8.1f} {p['predicted_s']:12.1f} "
                f"{100 * p['time_error']:+9.2f} % {p['soc_drop']:9.4f} "
                f"{p['predicted_soc_drop']:10.4f} {p['soc_error']:+.4f}"
            )
    covered = min(r["covered"] for r in rows)
    line_out = max(r["line_outside_m"] for r in rows)
    turn_out = max(r["turn_outside_m"] for r in rows)
    print(
        f"\n{sum(r['complete'] for r in rows)}/{len(rows)} random fields completed at c1 = 0; "
        f"covered >= {100 * covered:.2f} %; lines <= {line_out:.1f} m "
        f"and turns <= {turn_out:.1f} m outside the field; "
        f"prediction within {100 * max(abs(p['time_error']) for p in predictions):.2f} % and "
        f"{max(abs(p['soc_error']) for p in predictions):.4f} SoC"
    )
    text = StrictJson({"random_fields": rows, "predictions": predictions})
    AtomicWrite(Path(args.out), lambda f: f.write(text), binary=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
