"""Benchmark of one planner-scheduler step (NLP + integer mapping + path rule).

Replays a few hundred planner steps of a synthetic, reference-like closed loop: periodic motion
power (T = 46 s, mean ≈ 21 W, three harmonics), the PedNet computation table, the reference Rint
battery with the plan i faults (−6 % at 93 s, −9 % at 270 s), a noisy energy estimate q̂, and the
coverage fraction advancing at 1/t(c1) per second. Starts after the warm-up (t = 92 s) from the
plan i (c1 = 0, c2 = 10) and plan ii (c1 = −1000, c2 = 2) configurations. Prints the median and
95th percentile of the NLP solve time and of the whole step, and the failure count (paper
policy; with the table's integer parameters it solves no NLP, ``--continuous`` makes c2
continuous so that it does). Then, for the mpc policy: on ``--states`` random feasible planner
states as in flight (:func:`eaplan_drake.studies.worlds.RandomPlannerObservation`: the reference
plan at
a random stage, wind 0–12 m/s from any direction, random energy state and SoC), how often the
NLP's first move equals brute-force enumeration of the same discrete problem, and its step
times. Not a test.

    python3 benchmarks/bench_planner.py [--steps 300] [--cold] [--states 300] [--solver snopt]
        [--continuous]
"""

import argparse
import math
import time

import numpy as np

from eaplan_drake.energy.battery import SocDerivative
from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.energy.fourier import DiscreteFourierMatrices
from eaplan_drake.params import AUTHORS_K_B, BatteryFault, BatteryParams, PlannerParams
from eaplan_drake.planning.paper import Planner

PERIOD = 46.0
ORDER = 3
COVERAGE_TIMES = (270.0, 706.0)
WARMUP = 92.0


def Replay(planner: Planner, c1: float, c2: float, steps: int, seed: int, cold: bool):
    """Runs the synthetic loop; returns (solve times, step times, failures, infeasible, trace)."""
    rng = np.random.default_rng(seed)
    table, battery, h = planner.table, planner.battery, planner.step
    faults = sorted((f.time, f.soc_drop) for f in battery.faults)
    # Motion power: mean 21 W plus harmonics (turn peaks) [W], in the scaled state form.
    q = np.array([21.0, 4.0, 2.5, 2.0, -1.0, 0.8, 0.5]) + rng.normal(0.0, 0.3, 7)
    c2 = np.array([c2])
    q[0] += table.power(c2)
    Ad_fine, _ = DiscreteFourierMatrices(ORDER, PERIOD, 0.01)
    soc, t, fraction = 1.0, 0.0, 1.0
    # Warm-up with the initial parameters (battery drains, coverage advances).
    warm = None
    solve_times, step_times, failures, infeasible, trace = [], [], 0, 0, []

    def advance(duration):
        nonlocal q, soc, t, fraction
        for _ in range(round(duration / 0.01)):
            soc += 0.01 * SocDerivative(q[0] + q[1] + q[3] + q[5], battery)
            q = Ad_fine @ q
            t += 0.01
            while faults and faults[0][0] <= t + 1e-9:
                soc -= faults.pop(0)[1]
            fraction = max(fraction - 0.01 / planner.coverage_time(c1), 0.0)

    advance(WARMUP)
    for _ in range(steps):
        q_hat = q + rng.normal(0.0, 0.2, q.size)  # estimation error [W]
        t0 = time.perf_counter()
        sol = planner.Plan(q_hat, soc, PERIOD, fraction, c2, c1, None if cold else warm)
        step_times.append(time.perf_counter() - t0)
        solve_times.append(sol.solve_time)
        failures += not sol.success
        infeasible += sol.success and not sol.feasible
        warm = sol.warm_start
        q[0] += table.power(sol.computation_parameters) - table.power(c2)  # B Δg
        c1, c2 = sol.path_parameter, sol.computation_parameters
        trace.append((t, soc, fraction, c1, c2[0], sol.time_to_reserve))
        advance(h)
        if fraction <= 0.0 or soc <= battery.reserve_soc:
            break
    return solve_times, step_times, failures, infeasible, trace


def MpcAgreement(states: int, solver: str, seed: int = 8):
    """(agreeing, total, failures, step times [s]) of the mpc policy against brute force."""
    from eaplan_drake.flight.coverage import MakeCoveragePlan
    from eaplan_drake.params import Scenario
    from eaplan_drake.planning.policies import MakePolicy
    from eaplan_drake.studies.worlds import RandomPlannerObservation

    scenario = Scenario()
    scenario.battery.k_b = AUTHORS_K_B  # the papers' battery, as before packs had labels
    scenario.planner.solver = solver
    table = LoadComputationTable(scenario.computation.table)
    grid = scenario.planner.PathParameterGrid()
    plan = MakeCoveragePlan(scenario.coverage, scenario.vehicle, c1=0.0, k_e=scenario.guidance.k_e)
    policy = MakePolicy(
        scenario.planner,
        table,
        ORDER,
        scenario.battery,
        coverage_time_bounds=COVERAGE_TIMES,
        path_parameter_grid=grid,
    )
    rng = np.random.default_rng(seed)
    memory = policy.InitialMemory()
    agree = total = failures = 0
    times = []
    while total < states:
        o = RandomPlannerObservation(rng, plan, grid, table.parameter_grids[0])
        step = policy.Step(o, memory)
        if not step.Lowest().feasible:
            continue
        expected = step.BruteForce()
        t0 = time.perf_counter()
        d = policy.Plan(o, memory)
        times.append(time.perf_counter() - t0)
        memory = d.memory
        total += 1
        failures += not d.success
        agree += d.path_parameter == expected.path_parameter and np.array_equal(
            d.computation_parameters, expected.computation_parameters
        )
    return agree, total, failures, times


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=300, help="planner steps per start")
    parser.add_argument("--cold", action="store_true", help="no warm start")
    parser.add_argument("--states", type=int, default=300, help="random states for the mpc")
    parser.add_argument("--solver", default="ipopt", help="planner.solver: ipopt or snopt")
    parser.add_argument(
        "--continuous", action="store_true", help="paper policy with continuous c2 (solves the NLP)"
    )
    args = parser.parse_args()

    table = LoadComputationTable("pednet_jetson_nano")
    battery = BatteryParams(  # the papers' battery: the authors' scaling of Ah to seconds
        k_b=AUTHORS_K_B,
        faults=[BatteryFault(time=93.0, soc_drop=0.06), BatteryFault(time=270.0, soc_drop=0.09)],
    )
    solve, step, fail, infeasible, n = [], [], 0, 0, 0
    for name, c1, c2, seed in (("plan i ", 0.0, 10.0, 1), ("plan ii", -1000.0, 2.0, 2)):
        planner = Planner(
            PlannerParams(solver=args.solver),
            table,
            ORDER,
            battery,
            COVERAGE_TIMES,
            integer=not args.continuous,
        )
        planner.Plan(np.r_[30.0, np.zeros(6)], 1.0, PERIOD, 1.0, [c2], c1)  # first-call setup
        s, w, f, i, trace = Replay(planner, c1, c2, args.steps, seed, args.cold)
        solve += s
        step += w
        fail += f
        infeasible += i
        n += len(s)
        last = trace[-1]
        c2s = sorted({round(float(row[4]), 2) for row in trace})
        print(
            f"{name}: {len(s)} steps, t = {trace[0][0]:.0f}…{last[0]:.0f} s, final SoC "
            f"{last[1]:.3f}, coverage left {last[2]:.2f}, c1 {last[3]:.0f}, c2 values {c2s}"
        )
    ms = 1e3 * np.array(solve)
    ws = 1e3 * np.array(step)
    kind = "continuous c2" if args.continuous else "integer c2: no NLP"
    print(f"steps            {n}  ({'cold' if args.cold else 'warm'} start, {kind}, {args.solver})")
    print(
        f"NLP solve        median {np.median(ms):.1f} ms, p95 {np.percentile(ms, 95):.1f} ms, "
        f"max {ms.max():.1f} ms"
    )
    print(
        f"planner step     median {np.median(ws):.1f} ms, p95 {np.percentile(ws, 95):.1f} ms, "
        f"max {ws.max():.1f} ms"
    )
    print(f"failures         {fail}")
    print(f"infeasible steps {infeasible} (lowest c2 still above the budget: slack used)")
    agree, total, failures, times = MpcAgreement(args.states, args.solver)
    ts = 1e3 * np.array(times)
    print(
        f"mpc vs brute force: first move equal in {agree} of {total} random feasible states "
        f"({100.0 * agree / total:.1f} %), {failures} solver fallbacks ({args.solver}); "
        f"step median "
        f"{np.median(ts):.1f} ms, p95 {np.percentile(ts, 95):.1f} ms"
    )
    if not math.isfinite(np.median(ws)):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
