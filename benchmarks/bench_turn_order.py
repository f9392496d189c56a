"""How the line order's turns leave the field: on seeded random non-convex fields at 1, 2 and 3
times their size, the route of ``eaplan-drake plan`` at the lowest plan's spacing (x_d = 10 m,
r_min = 62.45 m, the survey's), per field: its turns, those between lines closer than 2 r_min
(the three-arc Ω turns), the route's length and the farthest a turn reaches beyond the field.

    python3 benchmarks/bench_turn_order.py [--fields 10]

Run it against another checkout with ``PYTHONPATH=<checkout>`` to compare two line orders.
Not a test.
"""

import argparse
import dataclasses as dc

import numpy as np
import shapely

from eaplan_drake.field.airspace import LegPoints
from eaplan_drake.field.plan import MakeFieldPlan
from eaplan_drake.field.random_fields import RandomField

SPACING = 10.0
"""x_d [m]."""
MIN_TURNING_RADIUS = 62.45
"""r_min [m]."""


def TurnGroups(legs) -> list[list]:
    """The route's turns, each the list of its consecutive ``turn`` legs (``Route.TurnGroups``,
    written here too so that the script runs against checkouts older than it)."""
    groups, current = [], []
    for leg in legs:
        if leg.kind == "turn":
            current.append(leg)
        elif current:
            groups.append(current)
            current = []
    return groups


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fields", type=int, default=10)
    args = parser.parse_args()
    print("| field | scale | area [ha] | turns | Ω turns | route [m] | farthest turn [m] |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    omega_total, length_total = 0, 0.0
    for seed in range(args.fields):
        for scale in (1.0, 2.0, 3.0):
            field = RandomField(seed, holes=seed % 3)
            field = dc.replace(
                field,
                exterior=np.asarray(field.exterior) * scale,
                holes=tuple(np.asarray(h) * scale for h in field.holes),
            )
            legs = MakeFieldPlan(field, SPACING, MIN_TURNING_RADIUS).route.legs
            groups = TurnGroups(legs)
            omega = sum(1 for g in groups if sum(1 for leg in g if leg.radius > 0) >= 3)
            polygon = field.Polygon()
            farthest = max(
                float(shapely.distance(polygon, shapely.points(LegPoints(leg))).max())
                for g in groups
                for leg in g
            )
            length = sum(leg.length for leg in legs)
            omega_total += omega
            length_total += length
            print(
                f"| {seed} | {scale:g} | {polygon.area / 1e4:.1f} | {len(groups)} | {omega} | "
                f"{length:.0f} | {farthest:.1f} |"
            )
    print(f"total: {omega_total} Ω turns, route {length_total:.0f} m")


if __name__ == "__main__":
    main()
