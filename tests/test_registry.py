"""Registries: a choice is validated and built from one table, and a new one is one line.

The toy battery model and the toy policy here are the examples of CONTRIBUTING.md: each is
registered, named in a scenario, and flown."""

import numpy as np
import pytest

from eaplan_drake.energy.battery import RintBatteryModel
from eaplan_drake.energy.battery_model import AsBatteryModel, BatteryModel
from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LoadNamedScenario
from eaplan_drake.params import BatteryParams, PlannerParams, SimulationParams
from eaplan_drake.planning.planner import PlannerDecision, PlannerPolicy
from eaplan_drake.registry import (
    AIRCRAFT_MODELS,
    BATTERY_MODELS,
    PLAN_SOURCES,
    POLICIES,
    POWER_LOG_READERS,
    PolicyInfo,
    Registry,
)
from eaplan_drake.simulation import Simulate


class IdealBatteryModel(BatteryModel):
    """A lossless battery: ḃ = −y / E with E = Q_c·V·3600 / k_b' [J], never a brown-out (the toy
    model of CONTRIBUTING.md; k_b' = 1, so Q_c is a real capacity in Ah)."""

    def _Energy(self):
        return self.params.capacity * self.params.voltage * 3600.0

    def SocRate(self, power):
        return -np.asarray(power, dtype=float) / self._Energy()

    def SocRateSlope(self, power):
        return np.full(np.shape(power), -1.0 / self._Energy())

    def SocAfter(self, soc, power, duration):
        return float(np.clip(soc - power * duration / self._Energy(), 0.0, 1.0))

    def Current(self, power):
        return power / self.params.voltage

    def IsBrownout(self, power):
        return np.zeros(np.shape(power), dtype=bool) if np.ndim(power) else False

    def PowerBudget(self, soc):
        return np.multiply(soc, self.params.capacity * self.params.voltage)


class HoldLowestPolicy(PlannerPolicy):
    """Flies the lowest plan from the first planner step on (the toy policy of CONTRIBUTING.md)."""

    name = "hold_lowest"
    observes_remaining_time = False

    def __init__(self, planner, table):
        self._c1 = float(planner.path_parameter_bounds[0])
        self._c2 = np.asarray(table.lower, dtype=float)

    def Plan(self, observation, memory):
        return PlannerDecision(self._c1, self._c2.copy(), memory)


def MakeHoldLowestPolicy(planner, table, order, battery, **_):
    return HoldLowestPolicy(planner, table)


def test_a_registry_checks_builds_and_extends():
    registry = Registry("thing.kind", {"a": "eaplan_drake.errors:ScenarioError"})
    assert registry.Names() == ("a",) and "a" in registry and list(registry) == ["a"]
    with pytest.raises(ScenarioError, match=r"^thing\.kind: must be one of a, got 'b'$"):
        registry.Check("b")
    with pytest.raises(ScenarioError, match=r"^x\.y: must be one of a, got 3$"):
        registry.Check(3, "x.y")
    assert registry.Factory("a") is ScenarioError
    registry.Register("b", dict)
    assert registry.Make("b", k=1) == {"k": 1}
    registry.Unregister("b")
    assert registry.Names() == ("a",)
    with pytest.raises(ValueError, match="identifier"):
        registry.Register("not a name", dict)


def test_the_shipped_tables_name_every_choice():
    assert POLICIES.Names() == (
        "mpc",
        "paper",
        "greedy",
        "greedy_authors",
        "static",
        "hindsight",
        "static_takeoff",
        "mdp",
    )
    assert AIRCRAFT_MODELS.Names() == ("continuous", "exact_arc")
    assert PLAN_SOURCES.Names() == ("zamboni", "plan_file", "field")
    assert BATTERY_MODELS.Names() == ("rint",)
    assert POWER_LOG_READERS.Names() == ("csv", "ulog")
    for registry in (POLICIES, AIRCRAFT_MODELS, PLAN_SOURCES, BATTERY_MODELS, POWER_LOG_READERS):
        for name in registry:
            assert callable(registry.Factory(name)), (registry.key, name)
    # every shipped policy says what its infeasible steps mean and how it plans
    for name in POLICIES:
        info = POLICIES.Info(name)
        assert isinstance(info, PolicyInfo) and info.infeasible_why and info.feasible_means
    assert [n for n in POLICIES if POLICIES.Info(n).holds_parameters] == ["static", "hindsight"]
    assert [n for n in POLICIES if POLICIES.Info(n).power_budget] == ["paper", "greedy_authors"]
    with pytest.raises(ScenarioError, match=r"^battery\.model: must be one of rint, got 'lipo'"):
        BatteryParams(model="lipo").Validate()
    with pytest.raises(ScenarioError, match=r"^planner\.policy: must be one of mpc, paper"):
        PlannerParams(policy="best").Validate()
    with pytest.raises(ScenarioError, match=r"^simulation\.plant: must be one of continuous"):
        SimulationParams(plant="rk4").Validate()


def test_the_rint_model_is_the_rint_functions():
    from eaplan_drake.energy.battery import IsBrownout, SocAfter, SocDerivative

    params = BatteryParams()
    model = AsBatteryModel(params)
    assert isinstance(model, RintBatteryModel) and AsBatteryModel(model) is model
    y = np.array([0.0, 20.0, 45.0, 1e6])
    assert np.array_equal(model.SocRate(y), SocDerivative(y, params))
    assert model.SocAfter(0.8, 45.0, 0.01) == SocAfter(0.8, 45.0, 0.01, params)
    assert np.array_equal(
        model.IsBrownout(y), IsBrownout(y, params.voltage, params.internal_resistance)
    )
    assert model.reserve_soc == params.reserve_soc


@pytest.fixture
def ideal_battery():
    BATTERY_MODELS.Register("ideal", IdealBatteryModel)
    yield
    BATTERY_MODELS.Unregister("ideal")


@pytest.fixture
def hold_lowest():
    POLICIES.Register("hold_lowest", MakeHoldLowestPolicy)
    assert POLICIES.Info("hold_lowest") == PolicyInfo()  # the default texts
    POLICIES.Register("hold_lowest", MakeHoldLowestPolicy, PolicyInfo(infeasible_why="never"))
    assert POLICIES.Info("hold_lowest").infeasible_why == "never"
    yield
    POLICIES.Unregister("hold_lowest")
    assert POLICIES.Info("hold_lowest") == PolicyInfo()


def test_a_new_battery_model_is_one_registry_line_and_flies(ideal_battery):
    short = ["simulation: {time_limit: 30.0}"]
    ideal = LoadNamedScenario("plan_ii", short + ["battery: {model: ideal}"])
    log = Simulate(ideal)
    # SoC by the toy model: b(t) = 1 − ∫ y dt / E over the held load of each step (one step late)
    y = log["true_power"][:, 0]
    energy = ideal.battery.capacity * ideal.battery.voltage * 3600.0
    used = np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(log.times)) / energy
    assert log["soc"][-1, 0] == pytest.approx(1.0 - used, abs=2e-5)
    rint = Simulate(LoadNamedScenario("plan_ii", short))
    # the reference k_b absorbs the Ah-to-seconds conversion: Rint drains several times faster
    assert 1.0 - rint["soc"][-1, 0] > 3.0 * (1.0 - log["soc"][-1, 0])
    with pytest.raises(ScenarioError, match="battery.model: must be one of"):
        LoadNamedScenario("plan_ii", ["battery: {model: lossless}"])


def test_a_new_policy_is_one_registry_line_and_flies(hold_lowest):
    scenario = LoadNamedScenario(
        "plan_i", ["planner: {policy: hold_lowest, warmup: 0.0}", "simulation: {time_limit: 20}"]
    )
    log = Simulate(scenario)
    assert log.summary["policy"] == "hold_lowest"
    after = log.times > scenario.planner.period + 1e-9
    assert np.all(log["path_parameters"][after, 0] == scenario.planner.path_parameter_bounds[0])
    assert np.all(log["computation_parameters"][after, 0] == 2.0)
