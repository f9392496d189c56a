"""How many worlds certify needs, by sampling mode: the chance that a claim passes within N worlds,
measured on the synthetic stand-in (eaplan_drake.studies.standin: exact rate, no flight) over many
seeds, and the power figure of kept real certify rows. Not a test.

    python3 benchmarks/bench_certify_sampling.py [--runs 1000] [--rows FILE=EPS ...]
        [--real DIR ...]

1. Stand-in calibrated like the default planner (ρ = 0.030, losses mostly with two or more drops
   in the flight), claim ε = 0.05: per mode, the fraction of ``--runs`` seeds certified within 300
   worlds and the median worlds to a decision (fixed-N Clopper–Pearson counting, the anytime bound
   on plain worlds, stratified and importance worlds; the proposals by the pilot rules of
   certify on a 30-world pilot of each seed), and the claim at ε = 0.01 (above the rate: how often
   it is wrongly certified, and how often refuted).
2. Stand-in with a small rate (ρ = 0.001), claims at 0.01 and 0.005: worlds for a 90 % chance.
3. ``--rows``: kept real rows and their claim (default: the 340-world survey runs at ε = 0.05
   and 0.01 in benchmarks/results/certify): the power of counting and of the anytime bound at
   their measured rate.
4. The weighting's own cost: drawing 200 worlds plain and with a proposal.
5. ``--real DIR|ROWS``: certify output directories or rows files of real runs (plain and
   weighted): their verdicts and the mean wall time per flight of each (on a shared machine the
   wall times also measure the other load).
"""

import argparse
import dataclasses as dc
import json
import time
from pathlib import Path

import numpy as np

from eaplan_drake.studies.bounds import (
    PlainPower,
    SequentialDecision,
    SequentialPower,
    WorldsForPower,
)
from eaplan_drake.studies.certify import Certify, CertifyReport, WorldSeries
from eaplan_drake.studies.sampling import (
    CountProbabilities,
    CrossEntropyTilt,
    StratifiedProposal,
    TiltedProposal,
)
from eaplan_drake.studies.standin import StandIn, StandInRate, StandInWorlds

PILOT = 30


def _Proposal(mode: str, s: StandIn, rng):
    """The stand-in's proposal by certify's pilot rules on a 30-world pilot (the pilot's own
    worlds are returned too: they stay in the run with weight 1)."""
    w, e, f, n = StandInWorlds(rng, s, None, PILOT)
    if mode == "stratified":
        if not e.any():
            return StratifiedProposal(s.model, s.window), (w, e, f)
        top = int(n.max())
        k = np.array([np.sum(e * (n == j)) for j in range(top + 1)])
        m = np.array([np.sum(f * (n == j)) for j in range(top + 1)])
        r = (k + 0.5) / (m + 1.0)
        return StratifiedProposal(s.model, s.window, allocation=np.sqrt(r * (1 - r))), (w, e, f)
    elite = e.astype(bool)  # the stand-in's score: the most drops (its total is not kept)
    if elite.sum() < 3:
        elite = np.zeros(PILOT, bool)
        elite[np.argsort(-n, kind="stable")[:3]] = True
    sizes = np.full(PILOT, 0.5 * sum(s.model.size_bounds))
    rate, theta = CrossEntropyTilt(s.model, s.window, n, sizes, w, elite)
    return TiltedProposal(s.model, s.window, rate, theta), (w, e, f)


def _Runs(mode: str, s: StandIn, runs: int, worlds: int, seed: int):
    """(W, E, F, B) arrays (runs, worlds) of a mode on the stand-in."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(runs):
        if mode in ("stratified", "importance"):
            proposal, (w0, e0, f0) = _Proposal(mode, s, rng)
            w, e, f, _ = StandInWorlds(rng, s, proposal, worlds - PILOT)
            b = np.r_[np.ones(PILOT), np.full(worlds - PILOT, proposal.weight_bound)]
            out.append((np.r_[w0, w], np.r_[e0, e], np.r_[f0, f], b))
        else:
            w, e, f, _ = StandInWorlds(rng, s, None, worlds)
            out.append((w, e, f, np.ones(worlds)))
    return tuple(np.array([o[i] for o in out]) for i in range(4))


def _Counting(e, f, eps, worlds):
    """Fraction of runs that fixed-N counting (Clopper–Pearson) certifies with ``worlds``."""
    from eaplan_drake.studies.bounds import CertifyThreshold

    k = e[:, :worlds].sum(axis=1).astype(int)
    n = f[:, :worlds].sum(axis=1).astype(int)
    cache = {}
    return float(
        np.mean(
            [
                k_ <= cache.setdefault(n_, CertifyThreshold(n_, eps))
                for k_, n_ in zip(k, n, strict=True)
            ]
        )
    )


def StandInTable(runs: int) -> None:
    s = StandIn()
    rho = StandInRate(s)
    print(f"## stand-in, ρ = {rho:.4f} (closed form), {runs} seeds per mode\n")
    print(
        "| mode | claim ε | certified within 300 | refuted within 300 | median worlds to certify |"
    )
    print("| --- | --- | --- | --- | --- |")
    for eps in (0.05, 0.01):
        counted = _Counting(*_Runs("plain", s, runs, 300, 1)[1:3], eps, 300)
        print(f"| counting (Clopper–Pearson, N = 300) | {eps} | {counted:.3f} | – | – |")
        for mode in ("plain", "stratified", "importance"):
            w, e, f, b = _Runs(mode, s, runs, 300, 1)
            c, r = SequentialDecision(w, e, f, b, eps)
            med = np.median(np.where(c > 0, c, np.inf))
            print(
                f"| anytime, {mode} | {eps} | {np.mean(c > 0):.3f} | {np.mean(r > 0):.3f} | "
                f"{med:.0f} |"
            )
    p = PlainPower(rho, _Feasible(s), 300, 0.05)
    print(
        f"\ncounting's exact power at ρ with 300 worlds: {p:.3f}; worlds for 90 %: "
        f"{WorldsForPower(lambda n: PlainPower(rho, _Feasible(s), n, 0.05))}\n"
    )


def _Feasible(s: StandIn) -> float:
    p = CountProbabilities(s.model, s.window)
    from eaplan_drake.planning.risk import UniformDrops

    q = UniformDrops(*s.model.size_bounds).sum_tail(p.size - 1, s.lowest_margin)
    return float(np.sum(p * (1.0 - q)))


def SmallRateTable(runs: int) -> None:
    s = dc.replace(StandIn(), policy_margin=0.2967, other_loss=0.0)
    rho = StandInRate(s)
    print(f"## stand-in with a small rate, ρ = {rho:.5f}: worlds for a 90 % chance\n")
    print(
        "| claim ε | counting (exact power) | anytime, plain | anytime, stratified "
        "| anytime, importance |"
    )
    print("| --- | --- | --- | --- | --- |")
    feasible = _Feasible(s)
    for eps in (0.01, 0.005):
        cells = [str(WorldsForPower(lambda n, eps=eps: PlainPower(rho, feasible, n, eps)))]
        for mode in ("plain", "stratified", "importance"):
            w, e, f, b = _Runs(mode, s, min(runs, 300), 4000, 2)
            c, _ = SequentialDecision(w, e, f, b, eps)
            hit = np.sort(np.where(c > 0, c, np.inf))
            q = hit[int(np.ceil(0.9 * hit.size)) - 1]
            cells.append(f"{q:.0f}" if np.isfinite(q) else "> 4000")
        print(f"| {eps} | " + " | ".join(cells) + " |")
    print()


def RowsPower(path: Path, eps: float) -> None:
    """The power figure of kept real rows at their claim ``eps``."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    (c,) = Certify(rows, eps)
    series = WorldSeries(rows, c.policy)
    w, e, f, b = (series[k] for k in ("weight", "excess", "feasible", "weight_bound"))
    power = SequentialPower(w, e, f, b, eps, 3000, runs=400)
    n90 = int(np.argmax(power >= 0.9)) + 1 if np.any(power >= 0.9) else "> 3000"
    print(
        f"{path.name}, ε = {eps}: {c.excess_failures} of {c.feasible} feasible, rate "
        f"{c.rate:.4f}, Clopper–Pearson bound {c.upper:.4f}; counting: P(300 worlds certify) = "
        f"{PlainPower(c.rate, c.feasible / c.worlds, 300, eps):.3f}, worlds for 50 / 90 %: "
        f"{c.worlds_for_power[0]} / {c.worlds_for_power[1]}; anytime (plain worlds): "
        f"P(certified within 300) = {power[299]:.3f}, worlds for 90 %: {n90}\n"
    )


def DrawCost(worlds: int = 200) -> None:
    """The weighting's own cost per world: drawing the worlds' flights (plain, then with an
    importance proposal), as a ratio measured in this run; the flights are the same in number."""
    from eaplan_drake.studies.certify import CertifyStudy
    from eaplan_drake.studies.sweep import StudyFlights

    model = StandIn().model
    times = []
    for proposal in (None, TiltedProposal(model, 520.0, 2 * model.rate, 4.0)):
        study = CertifyStudy("survey", worlds, proposal=proposal, changing=False)
        t0 = time.perf_counter()
        StudyFlights(study)
        times.append((time.perf_counter() - t0) / worlds)
    print(
        f"## cost of weighting\n\ndrawing a world's two flights: plain {1e3 * times[0]:.2f} ms, "
        f"importance {1e3 * times[1]:.2f} ms (ratio {times[1] / times[0]:.2f})\n"
    )


def RealRuns(dirs: list[str]) -> None:
    print("## real runs\n")
    for d in dirs:
        path = Path(d) / "rows.jsonl" if Path(d).is_dir() else Path(d)
        rows = [json.loads(line) for line in path.read_text().splitlines()]
        walls = [r["wall_time"] for r in rows if r.get("wall_time")]
        print(f"### {d}: {len(rows)} flights, mean wall time {np.mean(walls):.2f} s per flight\n")
        for c in Certify(rows, 0.05):
            print(CertifyReport(c))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000)
    kept = Path(__file__).parent / "results/certify"
    default = [
        f"{kept}/survey_risk_340_rows.jsonl=0.05",
        f"{kept}/survey_risk_0.01_340_rows.jsonl=0.01",
    ]
    parser.add_argument("--rows", nargs="*", default=default, metavar="FILE=EPS")
    parser.add_argument("--real", nargs="*", default=[])
    args = parser.parse_args()
    t0 = time.perf_counter()
    StandInTable(args.runs)
    SmallRateTable(args.runs)
    print("## kept real rows (flown by an earlier version)\n")
    for item in args.rows:
        path, _, eps = item.rpartition("=")
        RowsPower(Path(path), float(eps))
    DrawCost()
    if args.real:
        RealRuns(args.real)
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
