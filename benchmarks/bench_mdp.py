"""The mission MDP (``planner.policy: mdp``) as a yardstick: what it predicts against what its
policy flies, beside the other policies, and how its discretisation converges. Not a test.

    python3 benchmarks/bench_mdp.py ROWS.jsonl [ROWS.jsonl ...] [--worlds N]
    python3 benchmarks/bench_mdp.py --refine [--worlds 2]

With rows of ``eaplan-drake certify`` studies (any policies; an ``mdp`` study's rows carry each
world's take-off prediction ``predicted_quality``): per file and policy, the excess failures on
the worlds the lowest plan completes, the rate and the mission quality (lost = 0) on them; for
``mdp`` also the mean over all worlds of the predicted E[Q 1{complete}] against the flown quality
(lost = 0), with the flown mean's standard error. Only the first N worlds of each file count.

With ``--refine``: on the first steady worlds certify draws (``--steady-worlds``), the take-off
MDP of each is solved at ε = ``planner.risk`` on three grids, each finer than the last (N, Δm,
n_T, n_Q), printing the value, the completion and the wall time of the constrained solve (one
core).
"""

import argparse
import dataclasses
import json
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported: as the CLI flies

import numpy as np  # noqa: E402

from eaplan_drake.planning import mdp, policies  # noqa: E402
from eaplan_drake.simulation import Simulate  # noqa: E402
from eaplan_drake.studies.certify import CertifyStudy  # noqa: E402
from eaplan_drake.studies.sweep import StudyFlights  # noqa: E402

GRIDS = (
    mdp.MdpGrid(stages=10, margin_step=0.02, time_nodes=5, quality_nodes=21),
    mdp.MdpGrid(stages=20, margin_step=0.01, time_nodes=9, quality_nodes=41),
    mdp.MdpGrid(stages=40, margin_step=0.005, time_nodes=13, quality_nodes=81),
)


def Table(paths, worlds: int) -> None:
    print(
        "| rows | policy | excess / feasible | rate | quality (lost = 0) on the feasible | "
        "on all worlds | predicted (mdp) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for path in paths:
        by_world: dict = {}
        with open(path) as f:
            for line in f:
                row = json.loads(line)
                if row["world"] < worlds:
                    by_world.setdefault(row["world"], {})[row["policy"]] = row
        names = sorted({p for w in by_world.values() for p in w} - {"lowest"})
        for name in names:
            pairs = [w for w in by_world.values() if "lowest" in w and name in w]
            feasible = [w for w in pairs if w["lowest"]["completed"]]
            lost = sum(not w[name]["completed"] for w in feasible)
            quality = [w[name]["quality"] if w[name]["completed"] else 0.0 for w in feasible]
            every = [w[name]["quality"] if w[name]["completed"] else 0.0 for w in pairs]
            predicted = ""
            if name == "mdp":
                rows = [w[name] for w in pairs if "predicted_quality" in w[name]]
                flown = np.array([r["quality"] if r["completed"] else 0.0 for r in rows])
                said = np.array([r["predicted_quality"] for r in rows])
                error = float(np.std(flown, ddof=1) / math.sqrt(flown.size))
                predicted = f"{said.mean():.3f} predicted, {flown.mean():.3f} ± {error:.3f} flown"
            n = len(feasible)
            label = os.path.basename(path)
            if label == "rows.jsonl":  # a study's directory names it
                label = os.path.basename(os.path.dirname(os.path.abspath(path)))
            print(
                f"| {label} | {name} | {lost} / {n} | {lost / n:.3f} | {np.mean(quality):.3f} | "
                f"{np.mean(every):.3f} ({len(pairs)}) | {predicted} |"
            )


def TakeoffMdps(worlds: int):
    """(world, the take-off MissionMdp on the finest grid, ε) of the first certify worlds."""
    caught = {}
    original = policies.MdpPolicy.Plan

    class TakeoffReachedError(Exception):
        pass

    def Catch(self, o, memory):
        o = dataclasses.replace(o, remaining_time=policies.StaircaseSteps(o.remaining_time, 1.0))
        step = self.problem.Step(o, budget=float(self.problem.params.risk))
        caught["mdp"] = mdp.MissionMdpFromStep(step, o, GRIDS[-1])
        caught["eps"] = float(self.problem.params.risk)
        raise TakeoffReachedError

    policies.MdpPolicy.Plan = Catch
    try:
        for keys, scenario in StudyFlights(CertifyStudy("survey", worlds, changing=False)):
            if keys["policy"] == "lowest":
                continue
            scenario.planner.policy = "mdp"
            try:
                Simulate(scenario)
            except TakeoffReachedError:
                pass
            yield keys["world"], caught["mdp"], caught["eps"]
    finally:
        policies.MdpPolicy.Plan = original


def Refine(worlds: int) -> None:
    print("| world | grid (N, Δm, n_T, n_Q) | E[Q 1{complete}] | completion | excess | solve [s] |")
    print("| --- | --- | --- | --- | --- | --- |")
    for world, finest, eps in TakeoffMdps(worlds):
        if finest is None:
            print(f"| {world} | lowest plan keeps no margin | | | | |")
            continue
        for grid in GRIDS:
            problem = finest.Regridded(grid)
            t0 = time.process_time()
            _, fig = mdp.SolveConstrained(problem, eps)
            seconds = time.process_time() - t0
            print(
                f"| {world} | {grid.stages}, {grid.margin_step:g}, {grid.time_nodes}, "
                f"{grid.quality_nodes} | {fig['quality']:.4f} | {fig['completion']:.4f} | "
                f"{fig['excess_rate']:.4f} | {seconds:.1f} |",
                flush=True,
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rows", nargs="*")
    parser.add_argument("--worlds", type=int, default=None)
    parser.add_argument("--refine", action="store_true")
    args = parser.parse_args()
    if args.refine:
        Refine(args.worlds or 2)
    else:
        Table(args.rows, args.worlds or 10**9)


if __name__ == "__main__":
    main()
