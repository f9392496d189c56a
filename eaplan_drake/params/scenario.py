"""One flight's parameters: the simulation's, and the :class:`Scenario` tree that holds every
subtree, with the cross-field checks."""

import dataclasses as dc
import re

import numpy as np

from eaplan_drake.params.bounds import (
    MAX_EXPECTED_DROPS,
    MAX_LOG_PERIOD,
    MAX_LOG_SAMPLES,
    MAX_MAX_STEP,
    MAX_NAME_LENGTH,
    MAX_PLANNER_STEPS,
    MAX_STEPS,
    MAX_TIME_LIMIT,
    MIN_LOG_PERIOD,
    MIN_MAX_STEP,
)
from eaplan_drake.params.checks import _at_most, _check, _in_range, _positive
from eaplan_drake.params.energy import (
    BatteryParams,
    ComputationParams,
    EnergyModelParams,
    EstimatorParams,
    SensorParams,
)
from eaplan_drake.params.flight import CoverageParams, GuidanceParams, VehicleParams, WindParams
from eaplan_drake.params.periods import _CheckRates
from eaplan_drake.params.planner import PlannerParams, _CheckPathParameterBounds
from eaplan_drake.params.walk import _Params, _Walk
from eaplan_drake.registry import AIRCRAFT_MODELS

_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")


@dc.dataclass
class SimulationParams(_Params):
    """How long and how finely to simulate."""

    time_limit: float = 1500.0
    """Stop after this much simulated time [s] if nothing else ended the flight."""
    log_period: float = 0.1
    """Sampling period of the flight log [s]."""
    integrator: str = "runge_kutta2"
    """Drake integrator scheme of the aircraft's continuous state (``ResetIntegratorFromFlags``
    names: runge_kutta2, runge_kutta3, runge_kutta5, explicit_euler, ...)."""
    max_step: float = 0.01
    """Integrator (maximum) step [s]; the 100 Hz sensor events cap the step at 0.01 s anyway.
    With ``plant: exact_arc`` it is the plant's fixed update period h [s] instead."""
    plant: str = "exact_arc"
    """Aircraft model, one of :data:`~eaplan_drake.registry.AIRCRAFT_MODELS`: ``exact_arc`` (the
    default), the unicycle stepped exactly every ``max_step`` with the turn rate held over the
    step, as a 100 Hz autopilot holds its command (plant and guidance run once per step;
    ``integrator`` is then unused), or
    ``continuous``, the unicycle integrated by ``integrator`` with the guidance re-evaluated inside
    the step (the loop of releases before 0.2, bit for bit). The two differ by the hold of the
    command, first order in the step: ≤ 0.2 m of track and ≤ 2e-5 of final SoC at 0.01 s on the
    reference flights."""

    def Validate(self, key: str = "simulation") -> None:
        _positive(self.time_limit, f"{key}.time_limit")
        _at_most(self.time_limit, f"{key}.time_limit", MAX_TIME_LIMIT, "s", "bounds a flight")
        _in_range(self.log_period, f"{key}.log_period", MIN_LOG_PERIOD, MAX_LOG_PERIOD)
        _check(
            self.time_limit / self.log_period <= MAX_LOG_SAMPLES,
            f"{key}.log_period",
            f"time_limit / log_period must be <= {MAX_LOG_SAMPLES:g} log samples, got "
            f"{self.time_limit / self.log_period:g}",
        )
        from pydrake.systems.analysis import GetIntegrationSchemes

        schemes = GetIntegrationSchemes()
        _check(
            self.integrator in schemes,
            f"{key}.integrator",
            f"must be one of {', '.join(schemes)}, got {self.integrator!r}",
        )
        _in_range(self.max_step, f"{key}.max_step", MIN_MAX_STEP, MAX_MAX_STEP)
        AIRCRAFT_MODELS.Check(self.plant, f"{key}.plant")


@dc.dataclass
class Scenario(_Params):
    """One flight: every parameter of the closed loop."""

    name: str = "reference"
    description: str = ""
    random_seed: int = -1
    """Seed every random stream of the flight derives from (today: the sensor's noise and
    dropouts), so that a Monte Carlo study varies one key; −1 (default) keeps ``sensor.seed`` as
    given. With a seed s ≥ 0 the sensor uses :meth:`SensorSeed` = a hash of (s, "sensor")."""
    vehicle: VehicleParams = dc.field(default_factory=VehicleParams)
    wind: WindParams = dc.field(default_factory=WindParams)
    coverage: CoverageParams = dc.field(default_factory=CoverageParams)
    guidance: GuidanceParams = dc.field(default_factory=GuidanceParams)
    computation: ComputationParams = dc.field(default_factory=ComputationParams)
    energy_model: EnergyModelParams = dc.field(default_factory=EnergyModelParams)
    battery: BatteryParams = dc.field(default_factory=BatteryParams)
    sensor: SensorParams = dc.field(default_factory=SensorParams)
    estimator: EstimatorParams = dc.field(default_factory=EstimatorParams)
    planner: PlannerParams = dc.field(default_factory=PlannerParams)
    simulation: SimulationParams = dc.field(default_factory=SimulationParams)

    def SensorSeed(self) -> int:
        """The seed the power sensor uses: ``sensor.seed``, or derived from ``random_seed``."""
        if self.random_seed < 0:
            return int(self.sensor.seed)
        return int(np.random.SeedSequence([int(self.random_seed), 1]).generate_state(1)[0])

    def WindSeed(self) -> int:
        """The seed of the gusts' and the drift's draws: ``wind.seed``, or derived from
        ``random_seed`` (a hash of (s, "wind"), independent of the sensor's)."""
        if self.random_seed < 0:
            return int(self.wind.seed)
        return int(np.random.SeedSequence([int(self.random_seed), 2]).generate_state(1)[0])

    def Validate(self) -> "Scenario":
        """Checks every field; raises ScenarioError naming the first bad key. Returns self.

        Types first (a params dataclass where one belongs, lists, booleans that are ``bool``,
        numbers that are numbers; numpy integers become ``int``), then ranges, then the
        cross-field constraints that need no file (those that do: :func:`ResolveScenario
        <eaplan_drake.resolve.ResolveScenario>`)."""
        _Walk(Scenario, self, "", raw=False)
        _check(
            isinstance(self.name, str) and bool(_NAME.fullmatch(self.name)),
            "name",
            "must be a plain file name (letters, digits, _ . + -, not starting with . + -), "
            f"got {self.name!r}",
        )
        _check(
            len(self.name) <= MAX_NAME_LENGTH,
            "name",
            f"at most {MAX_NAME_LENGTH} characters, got {len(self.name)}",
        )
        _check(
            self.random_seed >= -1,
            "random_seed",
            f"must be an integer >= -1, got {self.random_seed!r}",
        )
        for f in dc.fields(self):
            value = getattr(self, f.name)
            if hasattr(value, "Validate"):
                value.Validate(f.name)
        _check(
            self.battery.reserve_soc < self.battery.initial_soc,
            "battery.reserve_soc",
            f"must be below battery.initial_soc = {self.battery.initial_soc:g} (the flight would "
            f"end at once), got {self.battery.reserve_soc:g}",
        )
        sim = self.simulation
        fastest = max(self.sensor.rate, self.estimator.rate, 1.0 / sim.max_step)
        _check(
            sim.time_limit * fastest <= MAX_STEPS,
            "simulation.time_limit",
            f"time_limit × max(sensor.rate, estimator.rate, 1 / max_step) must be <= "
            f"{MAX_STEPS:g} steps, got {sim.time_limit:g} s × {fastest:g} Hz",
        )
        _CheckRates(self)
        expected = self.planner.fault_model.rate * sim.time_limit
        _check(
            self.planner.reserve != "risk" or expected <= MAX_EXPECTED_DROPS,
            "planner.fault_model.rate",
            f"with planner.reserve: risk, rate × simulation.time_limit (the drops expected in a "
            f"flight) must be <= {MAX_EXPECTED_DROPS:g}, got {self.planner.fault_model.rate:g} "
            f"1/s × {sim.time_limit:g} s",
        )
        _check(
            sim.time_limit / self.planner.period <= MAX_PLANNER_STEPS,
            "planner.period",
            f"simulation.time_limit / planner.period must be <= {MAX_PLANNER_STEPS:g} planner "
            f"steps, got {sim.time_limit / self.planner.period:g}",
        )
        _check(
            self.wind.speed < self.vehicle.airspeed,
            "wind.speed",
            f"must be below vehicle.airspeed = {self.vehicle.airspeed:g} m/s, "
            f"got {self.wind.speed:g}",
        )
        _CheckDrift(self)
        c1_min = self.coverage.min_turning_radius**2 - self.coverage.turning_radius**2
        _CheckPathParameterBounds(
            self.planner.path_parameter_bounds, "planner.path_parameter_bounds", c1_min
        )
        return self


def _CheckDrift(scenario: Scenario) -> None:
    """With the wind drifting, its bound ``wind.drift.max_speed`` is below the airspeed and at
    least the starting speed."""
    wind = scenario.wind
    if not wind.drift.on:
        return
    airspeed = scenario.vehicle.airspeed
    _check(
        wind.drift.max_speed < airspeed,
        "wind.drift.max_speed",
        f"must be below vehicle.airspeed = {airspeed:g} m/s, got {wind.drift.max_speed:g}",
    )
    _check(
        wind.speed <= wind.drift.max_speed,
        "wind.drift.max_speed",
        f"must be >= wind.speed = {wind.speed:g} m/s, got {wind.drift.max_speed:g}",
    )
