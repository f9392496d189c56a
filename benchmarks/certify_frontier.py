"""Reprints the frontier of mission quality against the measured excess-failure rate from kept
``eaplan-drake certify`` rows (one rows file per configuration), without flying again.

    python3 benchmarks/certify_frontier.py NAME=ROWS.jsonl [NAME=ROWS.jsonl ...] [--plot FILE]

Prints one Markdown row per configuration: feasible worlds, excess failures, their rate and exact
one-sided 95 % (Clopper–Pearson) upper bound, completion and mission quality (lost = 0). The rows
come from e.g. ``eaplan-drake certify survey --worlds 60 --out DIR --set planner.risk=0.10``.
"""

import argparse
import json

from eaplan_drake.studies.certify import Certify


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="+", metavar="NAME=ROWS")
    parser.add_argument("--plot", default="", help="write the frontier figure (PNG) here")
    args = parser.parse_args()
    points = []
    print(
        "| planner | feasible worlds | excess failures | rate | 95 % upper | completed | quality |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for text in args.configs:
        name, _, path = text.partition("=")
        with open(path) as f:
            rows = [json.loads(line) for line in f if line.strip()]
        (c,) = Certify(rows, eps=0.05)
        rate = c.excess_failures / c.feasible
        points.append((name, rate, c.upper, c.mission_quality))
        print(
            f"| {name} | {c.feasible} | {c.excess_failures} | {rate:.3f} | {c.upper:.3f} "
            f"| {100 * c.completion:.1f} % | {c.mission_quality:.3f} |"
        )
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.0, 4.0))
        for name, rate, upper, quality in points:
            marker = "o" if name.startswith("risk") else "s"
            ax.errorbar(rate, quality, xerr=[[0.0], [upper - rate]], fmt=marker, capsize=3)
            ax.annotate(name, (rate, quality), textcoords="offset points", xytext=(5, 4))
        ax.set_xlabel("excess-failure rate (bar: to the 95 % upper bound)")
        ax.set_ylabel("mission quality (lost = 0)")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
