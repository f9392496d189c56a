"""Closed-loop tests of the planner policies (issue 8): determinism under a slow solver, the
mission-feasible MPC on seeded worlds (one made infeasible by a fault), the policy seam and the
hindsight reference."""

import copy
import time

import numpy as np
import pytest

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.params import AUTHORS_K_B, BatteryFault, Scenario
from eaplan_drake.planning import policies
from eaplan_drake.planning.planner import PlannerDecision, PlannerPolicy
from eaplan_drake.planning.relaxation import MissionProgram
from eaplan_drake.simulation import FlyHindsight, HindsightGrid, Simulate
from eaplan_drake.studies.worlds import DrawWorld, WithPolicy

TABLE = LoadComputationTable("pednet_jetson_nano")


def _PapersScenario(name: str) -> Scenario:
    """The default scenario with the papers' battery (3.2 Ah at the authors' scaling k_b =
    0.00183, 7.19 Wh): the worlds below are tight on that energy."""
    s = Scenario(name=name)
    s.battery.k_b = AUTHORS_K_B
    return s


def _Short(policy="mpc", time_limit=40.0):
    s = Scenario(name=f"short_{policy}")
    s.planner.policy = policy
    s.planner.warmup = 40.0
    s.simulation.time_limit = time_limit
    return s


def _MpcPolicy(scenario):
    from eaplan_drake.diagram import MakeScenarioPolicy
    from eaplan_drake.flight.coverage import MakeCoveragePlan

    plan = MakeCoveragePlan(scenario.coverage, scenario.vehicle, c1=0.0, k_e=scenario.guidance.k_e)
    return MakeScenarioPolicy(scenario, TABLE, plan)


class _SlowProgram(MissionProgram):
    """The mpc NLP on a busy machine: every constraint evaluation takes 2 ms longer."""

    def _Constraints(self, x):
        time.sleep(0.002)
        return super()._Constraints(x)


@pytest.mark.slow
def test_a_slow_solver_gives_a_bit_identical_flight(monkeypatch):
    """A slow machine changes no decision, and neither does skipping the solves whose answer is
    determined without one: the reference skips them, the slow policy solves at every step."""
    scenario = _Short("mpc", time_limit=80.0)
    reference = Simulate(scenario)
    slow = _MpcPolicy(scenario)
    slow.program = _SlowProgram(slow.problem)
    monkeypatch.setattr(policies, "DeterminedDecision", lambda step: None)
    log = Simulate(scenario, policy=slow)
    stats, ref_stats = log.summary["planner"], reference.summary["planner"]
    assert stats["solves"] == ref_stats["solves"] > 20
    assert stats["median_solve_time"] > ref_stats["median_solve_time"] + 0.002
    np.testing.assert_array_equal(log.times, reference.times)
    for name, values in reference.signals.items():
        np.testing.assert_array_equal(log[name], values, err_msg=name)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 7, 13])
def test_mpc_completes_seeded_worlds_that_the_lowest_plan_completes(seed):
    world = DrawWorld(_PapersScenario("w"), seed)
    log = Simulate(WithPolicy(world, "mpc"))
    s = log.summary
    assert s["status"] == "complete", s
    assert s["final_margin"] > 0.0
    # well above the lowest plan's 0 (the default belief, which doubts the stated drop sizes
    # until it has seen one, flies world 7 at 0.225; the point belief flew it above 0.25)
    assert s["quality"] > 0.2
    assert s["planner"]["failures"] <= 0.02 * s["planner"]["solves"]
    c1, c2 = log["path_parameters"][:, 0], log["computation_parameters"][:, 0]
    assert np.all((c1 >= -1000.0) & (c1 <= 0.0))
    assert set(np.unique(c2)) <= set(TABLE.parameter_grids[0])


@pytest.mark.slow
def test_mpc_completes_a_tight_world_it_lost_when_the_warmup_flew_full_quality():
    # World 77: wind 9.4 m/s, SoC drops of 0.12, 0.014 and 0.056 at 159–195 s; the static lowest
    # plan ends only 0.029 above the reserve. A 40 s warm-up at c1 = 0, c2 = 10 fps spent that
    # margin before the planner could act (reserve reached, with the fixed reserve); flying the
    # lowest plan during the warm-up keeps the mission feasible.
    world = DrawWorld(_PapersScenario("w"), 77)
    assert world.wind.speed > 9.0 and len(world.battery.faults) == 3
    s = Simulate(WithPolicy(world, "mpc", reserve="fixed")).summary
    assert s["status"] == "complete", s
    assert s["final_margin"] > 0.0
    lost = Simulate(WithPolicy(world, "mpc", reserve="fixed", warmup_parameters="initial")).summary
    assert lost["status"] == "reserve_reached", lost


@pytest.mark.slow
def test_a_fault_that_makes_the_survey_infeasible_is_flagged_and_the_lowest_plan_flown():
    scenario = _PapersScenario("infeasible")
    scenario.battery.faults = [BatteryFault(time=150.0, soc_drop=0.45)]
    log = Simulate(scenario)
    s = log.summary
    assert s["planner"]["infeasible"] > 0
    assert 150.0 <= s["first_infeasible_time"] <= 151.5
    feasible = log["mission_feasible"][:, 0]
    assert np.all(feasible[log.times < 149.0] == 1.0)
    after = (feasible < 0.5) & (log.times > s["first_infeasible_time"] + 1.0)
    assert np.any(after)
    np.testing.assert_array_equal(log["path_parameters"][after, 0], -1000.0)
    np.testing.assert_array_equal(log["computation_parameters"][after, 0], 2.0)


@pytest.mark.parametrize("policy", ["mpc", "paper", "greedy", "greedy_authors", "static"])
def test_every_policy_flies_through_the_same_ports(policy):
    log = Simulate(_Short(policy, time_limit=60.0))
    s = log.summary
    assert s["policy"] == policy
    assert s["duration"] == pytest.approx(60.0)
    c1, c2 = log["path_parameters"][:, 0], log["computation_parameters"][:, 0]
    assert np.all((c1 >= -1000.0) & (c1 <= 0.0))
    assert set(np.unique(c2)) <= set(TABLE.parameter_grids[0])
    assert (s["planner"]["solves"] == 0) == (policy == "static")


def test_a_python_policy_object_replaces_the_scenarios():
    class Constant(PlannerPolicy):
        name = "constant"

        def Plan(self, observation, memory):
            assert observation.remaining_time.shape == (21,)
            return PlannerDecision(-500.0, np.array([4.0]), memory)

    log = Simulate(_Short("mpc", time_limit=45.0), policy=Constant())
    t = log.times
    np.testing.assert_array_equal(log["path_parameters"][t > 40.05, 0], -500.0)
    np.testing.assert_array_equal(log["computation_parameters"][t > 40.05, 0], 4.0)
    np.testing.assert_array_equal(log["computation_parameters"][t < 39.95, 0], 2.0)
    assert log.summary["policy"] == "constant"


def test_a_policy_that_does_not_observe_the_remaining_time_gets_none():
    seen = []

    class Blind(PlannerPolicy):
        name = "blind"
        observes_remaining_time = False

        def Plan(self, observation, memory):
            seen.append(observation.remaining_time)
            return PlannerDecision(-500.0, np.array([4.0]), memory)

    log = Simulate(_Short("mpc", time_limit=45.0), policy=Blind())
    assert seen and all(r is None for r in seen)
    np.testing.assert_array_equal(log["path_parameters"][log.times > 40.05, 0], -500.0)


@pytest.mark.parametrize(
    "warmup_parameters, c1, c2", [("lowest", -1000.0, 2.0), ("initial", 0.0, 10.0)]
)
def test_the_warmup_flies_the_lowest_plan_or_the_initial_parameters(warmup_parameters, c1, c2):
    scenario = _Short("mpc", time_limit=10.0)
    scenario.planner.warmup_parameters = warmup_parameters
    log = Simulate(scenario)
    np.testing.assert_array_equal(log["path_parameters"][:, 0], c1)
    np.testing.assert_array_equal(log["computation_parameters"][:, 0], c2)
    static = _Short("static", time_limit=10.0)  # a static plan always flies its initial pair
    static.planner.warmup_parameters = "lowest"
    log = Simulate(static)
    np.testing.assert_array_equal(log["path_parameters"][:, 0], 0.0)
    np.testing.assert_array_equal(log["computation_parameters"][:, 0], 10.0)


def test_hindsight_grid_is_ordered_by_quality():
    pairs = HindsightGrid(Scenario())
    assert len(pairs) == 5 * 5
    assert pairs[0][0] == 0.0 and pairs[0][1][0] == 10.0
    assert pairs[-1][0] == -1000.0 and pairs[-1][1][0] == 2.0
    q = [0.5 * (c1 + 1000.0) / 1000.0 + 0.5 * (c2[0] - 2.0) / 8.0 for c1, c2 in pairs]
    assert all(a >= b - 1e-12 for a, b in zip(q, q[1:], strict=False))


def _SmallWorld():
    """A short survey (3 repetitions) on a small battery: only some constant pairs complete."""
    s = _PapersScenario("small")
    s.coverage.polygon = [[-120.0, 11.0], [-120.0, 146.0], [60.0, 146.0], [60.0, 11.0]]
    s.battery.capacity = 1.0
    s.battery.faults = [BatteryFault(time=60.0, soc_drop=0.12)]
    s.planner.hindsight_path_parameters = 2
    return s


@pytest.mark.slow
def test_hindsight_is_the_best_completing_constant_pair():
    world = _SmallWorld()
    best = FlyHindsight(WithPolicy(world, "hindsight"))
    flown = best.summary["hindsight"]
    assert best.summary["policy"] == "hindsight" and best.summary["completed"]
    # Every pair, flown on the same world: the best completing one has hindsight's quality.
    results = []
    for c1, c2 in HindsightGrid(world):
        s = copy.deepcopy(world)
        s.planner.policy = "static"
        s.planner.initial_path_parameters = [c1]
        s.computation.initial_parameters = [float(c2[0])]
        results.append(Simulate(s).summary)
    completing = [r for r in results if r["completed"]]
    assert completing and len(completing) < len(results)  # the world discriminates
    assert best.summary["quality"] == pytest.approx(max(r["quality"] for r in completing))
    assert len(flown) < len(results)  # pruning by monotonicity skipped some flights
