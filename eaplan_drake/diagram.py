"""The closed loop: every system of the planner-scheduler wired into one Drake ``Diagram``.

::

    wind ─► FixedWingPlant ─► StageSequencer ─► VectorFieldGuidance ─► (plant)
                 │ motion_power                       ▲ path
                 ▼                                    │
    ComputationLoad ─► PowerSensor ─► EnergyEstimator ─► PlannerScheduler ─► path_parameters
         ▲  power        │ true_power                 ▲ soc        │
         │               └────────► Battery ──────────┘            │ computation_parameters
         └─────────────────────────────────────────────────────────┘

The planner's policy is ``scenario.planner.policy`` (:func:`~eaplan_drake.policies.MakePolicy`)
or any :class:`~eaplan_drake.planner.PlannerPolicy` passed as ``policy``; a static plan (paper 003
plans I and II) is the same diagram with ``planner.policy: static``. Every system is named
(``plant``, ``sequencer``, ``guidance``, ``computation``, ``sensor``, ``estimator``, ``battery``,
``planner``, ``wind``), the key signals are exported as diagram output ports of the same names,
and each logged signal has a ``VectorLogSink`` named ``log_<signal>`` (see :data:`LOGGED_SIGNALS`).
"""

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.battery import Battery
from eaplan_drake.computation import ComputationLoad
from eaplan_drake.estimator import EnergyEstimator
from eaplan_drake.guidance import VectorFieldGuidance
from eaplan_drake.params import Scenario
from eaplan_drake.planner import PlannerPolicy, PlannerScheduler
from eaplan_drake.plant import FixedWingPlant, MaxHeadingRate
from eaplan_drake.policies import MakePolicy
from eaplan_drake.resolve import ResolvedScenario, ResolveScenario, StartParameters
from eaplan_drake.sensor import PowerSensor
from eaplan_drake.sequencer import StageSequencer

__all__ = [
    "LOGGED_SIGNALS",
    "MakeEaplanDiagram",
    "MakeScenarioPolicy",
    "WindVector",
]

LOGGED_SIGNALS = {
    # log name: (system name, output port name)
    "position": ("plant", "position"),
    "heading": ("plant", "heading"),
    "motion_power": ("plant", "motion_power"),
    "stage": ("sequencer", "stage"),
    "period": ("sequencer", "period"),
    "coverage_remaining": ("sequencer", "coverage_remaining"),
    "computation_power": ("computation", "power"),
    "measured_power": ("sensor", "measured_power"),
    "true_power": ("sensor", "true_power"),
    "estimated_power": ("estimator", "estimated_power"),
    "energy_coefficients": ("estimator", "energy_coefficients"),
    "soc": ("battery", "soc"),
    "power_budget": ("battery", "power_budget"),
    "brownout": ("battery", "brownout"),
    "path_parameters": ("planner", "path_parameters"),
    "computation_parameters": ("planner", "computation_parameters"),
    "mission_feasible": ("planner", "mission_feasible"),
}
"""Signals logged by :func:`MakeEaplanDiagram` (``VectorLogSink`` named ``log_<name>``)."""


def WindVector(speed: float, direction_deg: float) -> np.ndarray:
    """w = speed · [cos θ_w, sin θ_w] [m/s], θ_w the direction the wind blows towards."""
    theta = np.deg2rad(direction_deg)
    return speed * np.array([np.cos(theta), np.sin(theta)])


def MakeEaplanDiagram(
    scenario: Scenario | ResolvedScenario,
    log_period: float | None = None,
    *,
    policy: PlannerPolicy | None = None,
) -> Diagram:
    """Builds the closed-loop diagram of ``scenario``, resolved first
    (:func:`~eaplan_drake.resolve.ResolveScenario`: table and plan loaded, every cross-field
    constraint checked; or pass a :class:`~eaplan_drake.resolve.ResolvedScenario`).

    ``log_period`` [s] overrides ``scenario.simulation.log_period``; 0 disables the loggers.
    ``policy`` replaces the policy that ``scenario.planner.policy`` names (a Python user's own
    :class:`~eaplan_drake.planner.PlannerPolicy`).
    """
    resolved = scenario if isinstance(scenario, ResolvedScenario) else ResolveScenario(scenario)
    scenario, table, plan = resolved.scenario, resolved.table, resolved.plan
    builder = DiagramBuilder()
    c1_0, c2_0 = StartParameters(scenario, table)

    w = WindVector(scenario.wind.speed, scenario.wind.direction_deg)
    grid = scenario.planner.PathParameterGrid()
    if policy is None:
        policy = MakeScenarioPolicy(scenario, table, plan)
    wind = builder.AddNamedSystem("wind", ConstantVectorSource(w))
    plant = builder.AddNamedSystem("plant", FixedWingPlant(scenario.vehicle))
    sequencer = builder.AddNamedSystem(
        "sequencer",
        StageSequencer(
            plan,
            initial_c1=c1_0,
            trigger_radius=scenario.coverage.trigger_radius,
            initial_period=scenario.energy_model.initial_period,
            wind=w,
            time_step=1.0 / scenario.sensor.rate,
            path_parameter_grid=grid,
        ),
    )
    guidance = builder.AddNamedSystem(
        "guidance",
        VectorFieldGuidance(
            airspeed=scenario.vehicle.airspeed,
            guidance=scenario.guidance,
            max_heading_rate=MaxHeadingRate(scenario.vehicle),
            wind_speed=scenario.wind.speed,
        ),
    )
    computation = builder.AddNamedSystem("computation", ComputationLoad(table))
    sensor = builder.AddNamedSystem(
        "sensor", PowerSensor(dc.replace(scenario.sensor, seed=scenario.SensorSeed()))
    )
    estimator = builder.AddNamedSystem(
        "estimator",
        EnergyEstimator(
            order=scenario.energy_model.order,
            initial_period=scenario.energy_model.initial_period,
            estimator=scenario.estimator,
            initial_q=_InitialCoefficients(scenario),
        ),
    )
    battery = builder.AddNamedSystem("battery", Battery(scenario.battery))
    planner = builder.AddNamedSystem(
        "planner",
        PlannerScheduler(
            policy,
            table=table,
            order=scenario.estimator.ModelOrder(scenario.energy_model.order),
            period=scenario.planner.period,
            warmup=scenario.planner.warmup,
            initial_path_parameter=c1_0,
            initial_computation_parameters=c2_0,
            path_parameter_grid_size=grid.size,
        ),
    )

    connect = builder.Connect
    connect(wind.get_output_port(), plant.GetInputPort("wind"))
    connect(plant.GetOutputPort("position"), sequencer.GetInputPort("position"))
    connect(plant.GetOutputPort("position"), guidance.GetInputPort("position"))
    connect(plant.GetOutputPort("ground_velocity"), guidance.GetInputPort("ground_velocity"))
    connect(plant.GetOutputPort("heading"), guidance.GetInputPort("heading"))
    connect(sequencer.GetOutputPort("path"), guidance.GetInputPort("path"))
    connect(
        guidance.GetOutputPort("heading_rate_command"), plant.GetInputPort("heading_rate_command")
    )
    connect(
        planner.GetOutputPort("computation_parameters"),
        computation.GetInputPort("computation_parameters"),
    )
    connect(plant.GetOutputPort("motion_power"), sensor.GetInputPort("motion_power"))
    connect(computation.GetOutputPort("power"), sensor.GetInputPort("computation_power"))
    connect(computation.GetOutputPort("power"), estimator.GetInputPort("computation_power"))
    connect(sensor.GetOutputPort("measured_power"), estimator.GetInputPort("measured_power"))
    connect(sequencer.GetOutputPort("period"), estimator.GetInputPort("period"))
    connect(sensor.GetOutputPort("true_power"), battery.GetInputPort("power"))
    connect(
        estimator.GetOutputPort("energy_coefficients"), planner.GetInputPort("energy_coefficients")
    )
    connect(
        estimator.GetOutputPort("mean_power_variance"), planner.GetInputPort("mean_power_variance")
    )
    connect(battery.GetOutputPort("soc"), planner.GetInputPort("soc"))
    connect(sequencer.GetOutputPort("remaining_time"), planner.GetInputPort("remaining_time"))
    connect(sequencer.GetOutputPort("period"), planner.GetInputPort("period"))
    connect(
        sequencer.GetOutputPort("coverage_remaining"), planner.GetInputPort("coverage_remaining")
    )
    connect(planner.GetOutputPort("path_parameters"), sequencer.GetInputPort("path_parameters"))

    systems = {
        s.get_name(): s
        for s in (plant, sequencer, guidance, computation, sensor, estimator, battery, planner)
    }
    for name, (system_name, port_name) in LOGGED_SIGNALS.items():
        builder.ExportOutput(systems[system_name].GetOutputPort(port_name), name)
    builder.ExportOutput(sequencer.GetOutputPort("mission_complete"), "mission_complete")

    period = scenario.simulation.log_period if log_period is None else log_period
    if period > 0.0:
        for name, (system_name, port_name) in LOGGED_SIGNALS.items():
            logger = LogVectorOutput(
                systems[system_name].GetOutputPort(port_name), builder, publish_period=period
            )
            logger.set_name(f"log_{name}")

    diagram = builder.Build()
    diagram.set_name("eaplan")
    return diagram


def MakeScenarioPolicy(scenario: Scenario, table, plan) -> PlannerPolicy:
    """The policy ``scenario.planner.policy`` names, as :func:`MakeEaplanDiagram` builds it for
    ``table`` (:class:`~eaplan_drake.computation.ComputationTable`) and ``plan`` (the plan
    source): the Eq. 10 line through t(c1) at the bounds in the scenario's wind, and the c1 grid
    of the sequencer's ``remaining_time``."""
    w = WindVector(scenario.wind.speed, scenario.wind.direction_deg)
    return MakePolicy(
        scenario.planner,
        table,
        scenario.estimator.ModelOrder(scenario.energy_model.order),
        scenario.battery,
        coverage_time_bounds=plan.CoverageTimeBounds(
            scenario.planner.path_parameter_bounds, scenario.vehicle.airspeed, w
        ),
        path_parameter_grid=scenario.planner.PathParameterGrid(),
        integer=scenario.computation.integer,
    )


def _InitialCoefficients(scenario: Scenario) -> np.ndarray:
    """q(0) [W]: the configured coefficients, or α0 = initial mean power and zero harmonics."""
    m = 2 * scenario.energy_model.order + 1
    if scenario.energy_model.initial_coefficients:
        return np.asarray(scenario.energy_model.initial_coefficients, dtype=float)
    q0 = np.zeros(m)
    q0[0] = scenario.energy_model.initial_mean_power
    return q0
