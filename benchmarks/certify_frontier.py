"""Reprints the frontier of mission quality against the measured excess-failure rate from kept
``eaplan-drake certify`` rows (one rows file per configuration), without flying again.

    python3 benchmarks/certify_frontier.py NAME=ROWS.jsonl [NAME=ROWS.jsonl ...] [--worlds N]
        [--plot FILE]

Prints one Markdown row per configuration: feasible worlds, excess failures, their rate and exact
one-sided 95 % (Clopper–Pearson) upper bound, completion and mission quality (lost = 0). The rows
come from e.g. ``eaplan-drake certify survey --worlds 60 --out DIR --set planner.risk=0.10``;
``--worlds N`` keeps the first N worlds of each file (certify draws world k the same way for any
number of worlds, so a 300-world run gives the 60-world point too).

Configurations named ``risk …`` form the risk planner's curve (linear between its points, sorted
by rate). Then it names every other configuration that lies above that curve, i.e. no risk point
or segment has both at least its quality and at most its rate; ``hindsight``, which knows the
world in advance, is a yardstick and not checked. With a ``hindsight`` configuration, the last
column is each configuration's mean quality over hindsight's, on the feasible worlds where
hindsight's quality is above 0 (a lost mission counting 0), and how many such worlds there are.
"""

import argparse
import json

import numpy as np

from eaplan_drake.files import AtomicWrite
from eaplan_drake.studies.certify import Certify


def _Rows(path: str, worlds: int) -> list[dict]:
    with open(path) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    return [r for r in rows if worlds <= 0 or r["world"] < worlds]


def CurveQuality(curve: list[tuple[float, float]], rate: float) -> float:
    """The risk curve's quality at ``rate``: linear between its (rate, quality) points, the best
    quality of the points at or below ``rate`` beyond them; -inf below its lowest rate."""
    rates = np.array([r for r, _ in curve])
    qualities = np.array([q for _, q in curve])
    if rate < rates[0]:
        return -np.inf
    best = float(np.max(qualities[rates <= rate]))
    if rate <= rates[-1]:
        best = max(best, float(np.interp(rate, rates, qualities)))
    return best


def HindsightRatios(rows: list[dict], hindsight: list[dict]) -> list[float]:
    """Per world: the policy's quality (0 if lost) over hindsight's, on the worlds the lowest plan
    completes and hindsight surveys at a quality above 0."""
    by = {(r["world"], r["policy"]): r for r in rows}
    best = {r["world"]: r for r in hindsight if r["policy"] != "lowest"}
    ratios = []
    for (world, policy), row in sorted(by.items()):
        low, hind = by.get((world, "lowest")), best.get(world)
        if policy == "lowest" or not (low and low["completed"] and hind and hind["quality"] > 0):
            continue
        ratios.append((row["quality"] if row["completed"] else 0.0) / hind["quality"])
    return ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="+", metavar="NAME=ROWS")
    parser.add_argument("--worlds", type=int, default=0, help="only the first N worlds (0: all)")
    parser.add_argument("--plot", default="", help="write the frontier figure (PNG) here")
    args = parser.parse_args()
    points = []
    configs = [text.partition("=")[::2] for text in args.configs]
    rows = {name: _Rows(path, args.worlds) for name, path in configs}
    hindsight = rows.get("hindsight")
    head = "| planner | feasible | excess failures | rate | 95 % upper | completed | quality |"
    print(head + (" quality / hindsight |" if hindsight else ""))
    print("| --- " * (8 if hindsight else 7) + "|")
    for name, _ in configs:
        (c,) = Certify(rows[name], eps=0.05)
        rate = c.excess_failures / c.feasible
        points.append((name, rate, c.upper, c.mission_quality))
        line = (
            f"| {name} | {c.feasible} | {c.excess_failures} | {rate:.3f} | {c.upper:.3f} "
            f"| {100 * c.completion:.1f} % | {c.mission_quality:.3f} |"
        )
        if hindsight:
            ratios = HindsightRatios(rows[name], hindsight)
            line += f" {np.mean(ratios):.3f} on {len(ratios)} |" if ratios else " – |"
        print(line)
    curve = sorted((rate, q) for name, rate, _, q in points if name.startswith("risk"))
    if curve:
        above = [
            name
            for name, rate, _, q in points
            if not name.startswith("risk")
            and name != "hindsight"
            and q > CurveQuality(curve, rate) + 1e-12
        ]
        print(f"\nabove the risk curve: {', '.join(above) if above else 'none'}")
    if args.plot:
        _Plot(points, curve, args.plot)
        print(f"wrote {args.plot}")


def _Plot(points, curve, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    if curve:
        ax.plot(*zip(*curve, strict=True), color="C0", alpha=0.5, zorder=1)
    for name, rate, upper, quality in points:
        kind = name.split()[0]
        marker, color = {"risk": ("o", "C0"), "fixed": ("s", "C1")}.get(kind, ("^", "C2"))
        if name == "hindsight":
            marker, color = "*", "C3"
        ax.errorbar(rate, quality, xerr=[[0.0], [upper - rate]], fmt=marker, color=color, capsize=3)
        ax.annotate(name, (rate, quality), textcoords="offset points", xytext=(5, 4), fontsize=8)
    ax.set_xlabel("excess-failure rate (bar: to the 95 % upper bound)")
    ax.set_ylabel("mission quality (lost = 0)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    AtomicWrite(path, lambda f: fig.savefig(f, format="png", dpi=120), binary=True)
    plt.close(fig)


if __name__ == "__main__":
    main()
