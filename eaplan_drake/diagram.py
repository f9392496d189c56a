"""The closed loop: every system of the planner-scheduler wired into one Drake ``Diagram``.

::

    wind ─► FixedWingPlant ─► StageSequencer ─► VectorFieldGuidance ─► (plant)
                 │ motion_power                       ▲ path
                 └──────────┐                         │
    ComputationLoad ─► total_power (Adder) ─► PowerSensor ─► EnergyEstimator ─► PlannerScheduler
         ▲  power           │ y                                 ▲ soc           │ c1 (sequencer)
         │                  └──────────► Battery ───────────────┘               │ c2
         └──────────────────────────────────────────────────────────────────────┘

The planner's policy is ``scenario.planner.policy``
(:func:`~eaplan_drake.planning.policies.MakePolicy`) or
any :class:`~eaplan_drake.planning.planner.PlannerPolicy` passed as ``policy``; a static plan
(paper 003
plans I and II) is the same diagram with ``planner.policy: static``. Every system is named
(``plant``, ``sequencer``, ``guidance``, ``computation``, ``total_power``, ``sensor``,
``estimator``, ``battery``, ``planner``, ``wind``, ``kinematics_demux``, and ``wind_estimator``
with ``wind.staircase: estimated``), the key signals are
exported as diagram output ports of the same names, and the logged signals (:data:`LOGGED_SIGNALS`)
go through one ``Multiplexer`` named ``log_mux`` into one ``VectorLogSink`` named ``log``;
:func:`LoggedSignals` splits its rows by signal and computes the few (:data:`LOG_DERIVED`) that
are functions of other logged signals."""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort
from pydrake.systems.primitives import (
    Adder,
    ConstantVectorSource,
    Demultiplexer,
    LogVectorOutput,
    Multiplexer,
)

from eaplan_drake.energy.battery import Battery
from eaplan_drake.energy.computation import ComputationLoad
from eaplan_drake.energy.estimator import EnergyEstimator
from eaplan_drake.energy.fourier import AugmentedOrder
from eaplan_drake.energy.sensor import AveragedVariance, PowerSensor
from eaplan_drake.flight.guidance import VectorFieldGuidance
from eaplan_drake.flight.plant import FixedWingPlant, MakeFixedWingPlant, MaxHeadingRate
from eaplan_drake.flight.sequencer import StageSequencer
from eaplan_drake.flight.wind import AddWindSource, WindSource
from eaplan_drake.flight.wind_estimator import AddWindEstimator, WindEstimator
from eaplan_drake.params import (
    BatteryParams,
    EstimatorParams,
    GuidanceParams,
    PlannerParams,
    Scenario,
    SensorParams,
    SimulationParams,
    VehicleParams,
    WindParams,
)
from eaplan_drake.planning.planner import PlannerPolicy, PlannerScheduler
from eaplan_drake.planning.policies import MakePolicy
from eaplan_drake.resolve import Derive, ResolvedScenario, ResolveScenario

__all__ = [
    "LOGGED_SIGNALS",
    "LOG_DERIVED",
    "LOG_SOURCES",
    "AddEnergyLoop",
    "AddGuidedAircraft",
    "AddPlannerScheduler",
    "AddSignalLoggers",
    "AddWindEstimator",
    "AddWindSource",
    "WireWind",
    "EnergyLoop",
    "EnergyLoopArguments",
    "EstimatorOfSensor",
    "GuidedAircraft",
    "GuidedAircraftArguments",
    "LoggedSignals",
    "MakeEaplanDiagram",
    "MakeResolvedPolicy",
    "MakeScenarioPolicy",
]

LOGGED_SIGNALS = {
    # log name: (system name, output port name)
    "position": ("plant", "position"),
    "heading": ("plant", "heading"),
    "motion_power": ("plant", "motion_power"),
    "stage": ("sequencer", "stage"),
    "flown_path_parameter": ("sequencer", "flown_path_parameter"),  # c1 of the plan flown [m²]
    "period": ("sequencer", "period"),
    "coverage_remaining": ("sequencer", "coverage_remaining"),
    "computation_power": ("computation", "power"),
    "measured_power": ("sensor", "measured_power"),
    "true_power": ("total_power", "sum"),
    "estimated_power": ("estimator", "estimated_power"),
    "energy_coefficients": ("estimator", "energy_coefficients"),
    "soc": ("battery", "soc"),
    "power_budget": ("battery", "power_budget"),
    "brownout": ("battery", "brownout"),
    "path_parameters": ("planner", "path_parameters"),
    "computation_parameters": ("planner", "computation_parameters"),
    "mission_feasible": ("planner", "mission_feasible"),
    "predicted_soc": ("planner", "predicted_soc"),  # [predicted end SoC, required end SoC]
}
"""Signals logged by :func:`MakeEaplanDiagram` and exported as diagram output ports of the same
names (:func:`LoggedSignals` returns them in this order)."""

LOG_SOURCES = {
    # log name: (system name, state output port, first element)
    "position": ("plant", "kinematics", 0),
    "heading": ("plant", "kinematics", 2),
    "stage": ("sequencer", "mode", 0),
    "flown_path_parameter": ("sequencer", "mode", 1),
    "coverage_remaining": ("sequencer", "mode", 2),
    "soc": ("battery", "state", 0),
}
"""Logged signals that the ``log`` sink reads as elements of a state output port instead of the
signal's own (calculated) port: the same values, without a Python call per sample. E.g. the
plant's ``position`` is (x, y) of its ``kinematics`` state (x, y, ψ, ṗ_x, ṗ_y)."""


def _EstimatedPower(diagram: Diagram, signals: dict) -> np.ndarray:
    estimator = diagram.GetSubsystemByName("estimator")
    coefficients = signals["energy_coefficients"]
    return np.array([estimator.EstimatedPower(q) for q in coefficients]).reshape(-1, 1)


def _PowerBudget(diagram: Diagram, signals: dict) -> np.ndarray:
    return diagram.GetSubsystemByName("battery").model.PowerBudget(signals["soc"])


def _Brownout(diagram: Diagram, signals: dict) -> np.ndarray:
    model = diagram.GetSubsystemByName("battery").model
    return np.asarray(model.IsBrownout(signals["true_power"])).astype(float)


LOG_DERIVED = {
    "estimated_power": _EstimatedPower,  # ŷ = C q̂ of the logged energy_coefficients
    "power_budget": _PowerBudget,  # b·Q_c·V of the logged soc
    "brownout": _Brownout,  # 1.0 where the logged true_power y > V²/(4R_r)
}
"""Logged signals that the ``log`` sink does not sample: :func:`LoggedSignals` computes them
from other logged signals with the function the system's output port calls (the same values to
the bit; the sink spares a Python call per signal and sample)."""


@dc.dataclass(frozen=True)
class GuidedAircraft:
    """The flight side added by :func:`AddGuidedAircraft`: the systems, and the sequencer's
    ``path_parameters`` input (c1 [m²]) that a planner or a constant drives."""

    wind: ConstantVectorSource | WindSource
    plant: FixedWingPlant
    sequencer: StageSequencer
    guidance: VectorFieldGuidance
    wind_estimator: WindEstimator | None = None
    """The aircraft's wind estimate (with ``wind.staircase: estimated``), else None."""


@dc.dataclass(frozen=True)
class EnergyLoop:
    """The energy side added by :func:`AddEnergyLoop`: the systems, and the computation load's
    ``computation_parameters`` input (c2) that a planner or a constant drives."""

    computation: ComputationLoad
    sensor: PowerSensor
    estimator: EnergyEstimator
    battery: Battery
    total_power: Adder
    """y = P_motion + g [W], the sensor's and the battery's ``power`` input."""


def AddGuidedAircraft(
    builder: DiagramBuilder,
    plan,
    *,
    vehicle: VehicleParams,
    simulation: SimulationParams,
    guidance: GuidanceParams,
    wind: np.ndarray,
    trigger_radius: float,
    initial_period: float,
    path_parameter_grid: np.ndarray,
    initial_path_parameter: float,
    path_parameter: float | None = None,
    wind_params: WindParams | None = None,
    wind_seed: int = 0,
) -> GuidedAircraft:
    """Adds and wires the flight side to ``builder``: ``wind`` (the constant ``wind`` w [m/s],
    (east, north), :attr:`~eaplan_drake.resolve.ResolvedScenario.wind`, or the changing wind of
    ``wind_params`` seeded by ``wind_seed``: :func:`AddWindSource`), ``plant``
    (:class:`~eaplan_drake.flight.plant.FixedWingPlant` of ``vehicle``, the kind
    ``simulation.plant`` names, :func:`~eaplan_drake.flight.plant.MakeFixedWingPlant`),
    ``sequencer`` (:class:`~eaplan_drake.flight.sequencer.StageSequencer` over ``plan``, a plan
    source), ``guidance`` (:class:`~eaplan_drake.flight.guidance.VectorFieldGuidance` with the
    ``guidance`` gains) and ``kinematics_demux`` (a ``Demultiplexer`` handing (x, y) of the
    plant's kinematics to the sequencer)::

        wind ─► plant ─► kinematics_demux ─► sequencer ─► guidance ─► plant
                  └───────────────────────────────────────────┘ (kinematics)

    The sequencer switches stages within ``trigger_radius`` ε [m] of a triggering point, starts
    from the period guess ``initial_period`` T [s], runs on the base step
    ``simulation.max_step`` [s] and predicts its ``remaining_time`` on ``path_parameter_grid``
    (the M values of c1 [m²], :attr:`~eaplan_drake.resolve.ResolvedScenario.path_parameter_grid`).
    ``initial_path_parameter`` is the c1 [m²] the sequencer starts with. The sequencer's
    ``path_parameters`` input is left for the caller (a planner), or fed the constant
    ``path_parameter`` [m²] when given (a flight at one coverage density). The wind of the
    sequencer's ``remaining_time`` is ``wind_params.staircase``'s (:func:`WireWind`).
    """
    source = AddWindSource(builder, wind, wind_params, vehicle, simulation, wind_seed)
    plant = builder.AddNamedSystem("plant", MakeFixedWingPlant(vehicle, simulation))
    sequencer = builder.AddNamedSystem(
        "sequencer",
        StageSequencer(
            plan,
            initial_c1=initial_path_parameter,
            trigger_radius=trigger_radius,
            initial_period=initial_period,
            wind=wind,
            time_step=simulation.max_step,
            path_parameter_grid=path_parameter_grid,
            wind_input=wind_params is not None and wind_params.staircase != "scenario",
        ),
    )
    guidance = builder.AddNamedSystem(
        "guidance",
        VectorFieldGuidance(
            airspeed=vehicle.airspeed,
            guidance=guidance,
            max_heading_rate=MaxHeadingRate(vehicle),
            wind_speed=math.hypot(*wind),
        ),
    )
    estimator = WireWind(builder, source, plant, sequencer, wind_params, wind, simulation)
    connect = builder.Connect
    # The sequencer reads (x, y) as the first two elements of the plant's kinematics (x, y, ψ,
    # ṗ_x, ṗ_y), split in C++ by a Demultiplexer: the same values as the plant's ``position``
    # output, without its Python calculation at every sequencer update.
    split = builder.AddNamedSystem("kinematics_demux", Demultiplexer([2, 3]))
    connect(plant.GetOutputPort("kinematics"), split.get_input_port())
    connect(split.get_output_port(0), sequencer.GetInputPort("position"))
    connect(plant.GetOutputPort("kinematics"), guidance.GetInputPort("kinematics"))
    connect(sequencer.GetOutputPort("path"), guidance.GetInputPort("path"))
    connect(
        guidance.GetOutputPort("heading_rate_command"), plant.GetInputPort("heading_rate_command")
    )
    if path_parameter is not None:
        c1 = builder.AddNamedSystem("path_parameters", ConstantVectorSource([path_parameter]))
        connect(c1.get_output_port(), sequencer.GetInputPort("path_parameters"))
    return GuidedAircraft(source, plant, sequencer, guidance, estimator)


def WireWind(
    builder, source, plant, sequencer, wind_params, wind, simulation
) -> WindEstimator | None:
    """Connects the true wind of ``source`` (the world's wind,
    :func:`~eaplan_drake.flight.wind.AddWindSource`) to ``plant`` (and the plant's kinematics to
    a ``WindSource``) and, as ``wind_params.staircase`` says (``scenario`` when ``wind_params``
    is None), the wind of the ``sequencer``'s staircase, read at every stage switch: the wind
    estimate (``estimated``, :func:`~eaplan_drake.flight.wind_estimator.AddWindEstimator` from
    ŵ(0) = ``wind``, returned), the true mean wind (``truth``) or none (``scenario``: its
    constant wind)."""
    connect = builder.Connect
    if isinstance(source, WindSource):
        true_wind, mean_wind = source.GetOutputPort("wind"), source.GetOutputPort("mean_wind")
        connect(plant.GetOutputPort("kinematics"), source.GetInputPort("kinematics"))
    else:
        true_wind = mean_wind = source.get_output_port()
    connect(true_wind, plant.GetInputPort("wind"))
    staircase = "scenario" if wind_params is None else wind_params.staircase
    if staircase == "estimated":
        estimator = AddWindEstimator(
            builder,
            plant,
            params=wind_params.estimator,
            time_step=simulation.max_step,
            initial_wind=wind,
        )
        connect(estimator.GetOutputPort("wind_estimate"), sequencer.GetInputPort("wind"))
        return estimator
    if staircase == "truth":
        connect(mean_wind, sequencer.GetInputPort("wind"))
    return None


def AddEnergyLoop(
    builder: DiagramBuilder,
    table,
    *,
    motion_power: OutputPort,
    period: OutputPort,
    sensor: SensorParams,
    sensor_seed: int,
    estimator: EstimatorParams,
    battery: BatteryParams,
    order: int,
    initial_period: float,
    initial_coefficients: np.ndarray,
    time_step: float,
    computation_parameters: list[float] | None = None,
    power_offset: float = 0.0,
) -> EnergyLoop:
    """Adds and wires the energy side to ``builder``: ``computation``
    (:class:`~eaplan_drake.energy.computation.ComputationLoad` over ``table``, drawing
    ``power_offset`` ΔP [W] off the table; the estimator reads the table's power),
    ``total_power`` (an ``Adder``: y = motion power + computation power [W]), ``sensor``
    (:class:`~eaplan_drake.energy.sensor.PowerSensor` of ``sensor``, seeded by ``sensor_seed``,
    :attr:`~eaplan_drake.resolve.ResolvedScenario.sensor_seed`), ``estimator``
    (:class:`~eaplan_drake.energy.estimator.EnergyEstimator` with the ``estimator`` parameters)
    and ``battery`` (:class:`~eaplan_drake.energy.battery.Battery` of ``battery``)::

        motion_power ─► total_power ◄─ computation      period ─► estimator
                          │ y (Adder)
                          ├─► sensor ─ measured_power ─► estimator ◄─ computation table_power
                          └─► battery

    The sensor, the estimator and the battery run on the base step ``time_step`` h [s]
    (``simulation.max_step``); behind an averaging sensor (``sensor.averaging``) the estimator's
    R is ``measurement_noise`` / n (:func:`EstimatorOfSensor`). The estimator's Fourier model
    has order ``order`` r (m = 2r + 1 coefficients) and starts from the period guess
    ``initial_period`` T [s] and the coefficients ``initial_coefficients`` q(0) [W]
    (:attr:`~eaplan_drake.resolve.ResolvedScenario.initial_coefficients`).

    ``motion_power`` [W] and ``period`` (T [s]) are output ports already in ``builder`` (the
    plant's and the sequencer's, :func:`AddGuidedAircraft`). The computation load's
    ``computation_parameters`` input is left for the caller (a planner), or fed the constant
    ``computation_parameters`` (table units) when given.
    """
    load = ComputationLoad(table, power_offset=power_offset)
    computation = builder.AddNamedSystem("computation", load)
    total = builder.AddNamedSystem("total_power", Adder(2, 1))  # y = P_motion + g [W]
    power_sensor = builder.AddNamedSystem(
        "sensor", PowerSensor(dc.replace(sensor, seed=sensor_seed), time_step=time_step)
    )
    power_estimator = builder.AddNamedSystem(
        "estimator",
        EnergyEstimator(
            order=order,
            initial_period=initial_period,
            estimator=EstimatorOfSensor(estimator, power_sensor.readings_per_sample),
            initial_q=initial_coefficients,
            time_step=time_step,
        ),
    )
    rint = builder.AddNamedSystem("battery", Battery(battery, time_step=time_step))
    estimator_in = power_estimator.GetInputPort
    for source, sink in (
        (motion_power, total.get_input_port(0)),
        (computation.GetOutputPort("power"), total.get_input_port(1)),
        (total.get_output_port(), power_sensor.GetInputPort("power")),
        (computation.GetOutputPort("table_power"), estimator_in("computation_power")),
        (power_sensor.GetOutputPort("measured_power"), estimator_in("measured_power")),
        (period, estimator_in("period")),
        (total.get_output_port(), rint.GetInputPort("power")),
    ):
        builder.Connect(source, sink)
    if computation_parameters is not None:
        c2 = builder.AddNamedSystem(
            "computation_parameters", ConstantVectorSource(list(computation_parameters))
        )
        builder.Connect(c2.get_output_port(), computation.GetInputPort("computation_parameters"))
    return EnergyLoop(computation, power_sensor, power_estimator, rint, total)


def AddPlannerScheduler(
    builder: DiagramBuilder,
    table,
    aircraft: GuidedAircraft,
    energy: EnergyLoop,
    *,
    planner: PlannerParams,
    policy: PlannerPolicy,
    model_order: int | AugmentedOrder,
    initial_parameters: tuple[float, list[float]],
) -> PlannerScheduler:
    """Adds the ``planner`` (:class:`~eaplan_drake.planning.planner.PlannerScheduler` of the
    ``planner`` parameters running ``policy`` over ``table``) and closes the loop: it reads the
    estimator's coefficients and their variance, the battery's SoC and the sequencer's remaining
    time, period and coverage, and drives the sequencer's c1 and the computation load's c2.
    ``model_order`` is the estimator's model order
    (:attr:`~eaplan_drake.resolve.ResolvedScenario.model_order`: r, or an ``AugmentedOrder``
    with the aperiodic state). ``initial_parameters`` = (c1 [m²], c2) flown until the first
    planner step (:func:`~eaplan_drake.resolve.StartParameters`)."""
    c1_0, c2_0 = initial_parameters
    scheduler = builder.AddNamedSystem(
        "planner",
        PlannerScheduler(
            planner,
            policy=policy,
            table=table,
            order=model_order,
            initial_path_parameter=c1_0,
            initial_computation_parameters=c2_0,
        ),
    )
    sequencer, estimator = aircraft.sequencer, energy.estimator
    connect = builder.Connect
    connect(
        scheduler.GetOutputPort("computation_parameters"),
        energy.computation.GetInputPort("computation_parameters"),
    )
    connect(
        estimator.GetOutputPort("energy_coefficients"),
        scheduler.GetInputPort("energy_coefficients"),
    )
    connect(
        estimator.GetOutputPort("mean_power_variance"),
        scheduler.GetInputPort("mean_power_variance"),
    )
    connect(energy.battery.GetOutputPort("soc"), scheduler.GetInputPort("soc"))
    connect(sequencer.GetOutputPort("remaining_time"), scheduler.GetInputPort("remaining_time"))
    connect(sequencer.GetOutputPort("period"), scheduler.GetInputPort("period"))
    connect(
        sequencer.GetOutputPort("coverage_remaining"), scheduler.GetInputPort("coverage_remaining")
    )
    connect(scheduler.GetOutputPort("path_parameters"), sequencer.GetInputPort("path_parameters"))
    return scheduler


def AddSignalLoggers(builder: DiagramBuilder, systems: dict, log_period: float) -> None:
    """Exports each of :data:`LOGGED_SIGNALS` (and the sequencer's ``mission_complete``) as a
    diagram output port of the same name and, when ``log_period`` [s] > 0, logs them all every
    ``log_period`` through one ``Multiplexer`` named ``log_mux`` (inputs in the order of
    :data:`LOGGED_SIGNALS`) into one ``VectorLogSink`` named ``log`` (:func:`LoggedSignals`
    splits its rows by signal and adds :data:`LOG_DERIVED`). ``systems`` maps system names to
    systems.

    One sink instead of one per signal: a flight at 100 Hz spends ≈ 8 % fewer instructions per
    step (every leaf system costs the simulator its next-event query and event bookkeeping at
    every step); the logged samples are the same. The signals of :data:`LOG_SOURCES` are read
    from the state output port they are part of (each such port once), which spares the sink a
    Python call per signal and sample.
    """
    ports = {
        name: systems[system_name].GetOutputPort(port_name)
        for name, (system_name, port_name) in LOGGED_SIGNALS.items()
    }
    for name, port in ports.items():
        builder.ExportOutput(port, name)
    builder.ExportOutput(systems["sequencer"].GetOutputPort("mission_complete"), "mission_complete")
    if log_period > 0.0:
        sources = [systems[system].GetOutputPort(port) for system, port in _LogInputs()]
        mux = builder.AddSystem(Multiplexer([port.size() for port in sources]))
        mux.set_name("log_mux")
        for i, port in enumerate(sources):
            builder.Connect(port, mux.get_input_port(i))
        logger = LogVectorOutput(mux.get_output_port(), builder, publish_period=log_period)
        logger.set_name("log")


def LoggedSignals(diagram: Diagram, context) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(t, signals) logged by the ``log`` sink of a diagram from :func:`MakeEaplanDiagram`:
    the sample times [s], shape (n,), and each of :data:`LOGGED_SIGNALS` by name, shape
    (n, size of the signal), in its own units. ``context`` is the diagram's root context.
    ValueError for a diagram built without loggers (``log_period`` = 0)."""
    if not diagram.HasSubsystemNamed("log"):
        raise ValueError("LoggedSignals: the diagram has no 'log' sink (built with log_period = 0)")
    log = diagram.GetSubsystemByName("log").FindLog(context)
    data = np.array(log.data())
    mux = diagram.GetSubsystemByName("log_mux")
    first_row, row = {}, 0
    for i, source in enumerate(_LogInputs()):
        first_row[source] = row
        row += mux.get_input_port(i).size()
    signals = {}
    for name in LOGGED_SIGNALS:
        if name in LOG_DERIVED:
            continue
        start = first_row[_LogInput(name)] + (LOG_SOURCES[name][2] if name in LOG_SOURCES else 0)
        size = diagram.GetOutputPort(name).size()
        signals[name] = data[start : start + size].T.copy()
    for name, derive in LOG_DERIVED.items():
        signals[name] = derive(diagram, signals)
    return np.array(log.sample_times()), {name: signals[name] for name in LOGGED_SIGNALS}


def _LogInput(name: str) -> tuple[str, str]:
    """(system name, output port name) the ``log`` sink reads signal ``name`` from."""
    if name in LOG_SOURCES:
        return LOG_SOURCES[name][:2]
    return LOGGED_SIGNALS[name]


def _LogInputs() -> list[tuple[str, str]]:
    """The ``log_mux`` inputs in order: each (system name, output port name) of
    :func:`_LogInput` once, in the order of :data:`LOGGED_SIGNALS` (without
    :data:`LOG_DERIVED`)."""
    return list(
        dict.fromkeys(_LogInput(name) for name in LOGGED_SIGNALS if name not in LOG_DERIVED)
    )


def MakeEaplanDiagram(
    scenario: Scenario | ResolvedScenario,
    *,
    plan_source=None,
    policy: PlannerPolicy | None = None,
    log_period: float | None = None,
) -> Diagram:
    """Builds the closed-loop diagram of ``scenario``, resolved first
    (:func:`~eaplan_drake.resolve.ResolveScenario`: table and plan loaded, every cross-field
    constraint checked; or pass a :class:`~eaplan_drake.resolve.ResolvedScenario`), from
    :func:`AddGuidedAircraft`, :func:`AddEnergyLoop`, :func:`AddPlannerScheduler` and
    :func:`AddSignalLoggers`.

    ``plan_source`` replaces the scenario's plan (any plan source, e.g. a
    :class:`~eaplan_drake.flight.planfile.PlanFile`); ``policy`` replaces the policy that
    ``scenario.planner.policy`` names (a Python user's own
    :class:`~eaplan_drake.planning.planner.PlannerPolicy`); ``log_period`` [s] overrides
    ``scenario.simulation.log_period``, 0 disables the loggers.
    """
    resolved = scenario if isinstance(scenario, ResolvedScenario) else ResolveScenario(scenario)
    if plan_source is not None:
        resolved = Derive(resolved.scenario, resolved.table, plan_source)
    if policy is None:
        policy = MakeResolvedPolicy(resolved)
    builder = DiagramBuilder()
    aircraft, energy, planner = _AddClosedLoop(builder, resolved, policy)
    systems = {
        s.get_name(): s
        for s in (
            aircraft.plant,
            aircraft.sequencer,
            aircraft.guidance,
            energy.computation,
            energy.total_power,
            energy.sensor,
            energy.estimator,
            energy.battery,
            planner,
        )
    }
    if log_period is None:
        log_period = resolved.scenario.simulation.log_period
    AddSignalLoggers(builder, systems, log_period)
    diagram = builder.Build()
    diagram.set_name("eaplan")
    return diagram


def GuidedAircraftArguments(scenario: Scenario | ResolvedScenario) -> dict:
    """The keyword arguments of :func:`AddGuidedAircraft` that a scenario fixes: its
    ``vehicle``, ``simulation`` and ``guidance`` subtrees, ``coverage.trigger_radius`` ε [m],
    ``energy_model.initial_period`` T [s], the wind w [m/s], the ``wind`` subtree and its seed
    (:meth:`~eaplan_drake.params.Scenario.WindSeed`) and the c1 grid [m²] (those of a
    :class:`~eaplan_drake.resolve.ResolvedScenario`, or of a plain scenario computed as
    :func:`~eaplan_drake.resolve.Derive` computes them). The caller adds the plan, the
    ``initial_path_parameter`` and, for a flight at one c1, ``path_parameter``::

        AddGuidedAircraft(builder, plan, **GuidedAircraftArguments(s), initial_path_parameter=0.0)
    """
    if isinstance(scenario, ResolvedScenario):
        s, wind, grid = scenario.scenario, scenario.wind, scenario.path_parameter_grid
    else:
        s, wind, grid = scenario, scenario.wind.Vector(), scenario.planner.PathParameterGrid()
    return dict(
        wind_params=s.wind,
        wind_seed=s.WindSeed(),
        vehicle=s.vehicle,
        simulation=s.simulation,
        guidance=s.guidance,
        wind=wind,
        trigger_radius=s.coverage.trigger_radius,
        initial_period=s.energy_model.initial_period,
        path_parameter_grid=grid,
    )


def EnergyLoopArguments(resolved: ResolvedScenario, aircraft: GuidedAircraft) -> dict:
    """The keyword arguments of :func:`AddEnergyLoop` that a resolved scenario and the flight
    side ``aircraft`` (:func:`AddGuidedAircraft`) fix: the plant's ``motion_power`` and the
    sequencer's ``period`` ports, the ``sensor``, ``estimator`` and ``battery`` subtrees,
    ``computation.power_offset`` ΔP [W], the sensor seed, the model order r, T [s], q(0) [W] and
    the base step h [s] (``simulation.max_step``). The caller adds the table and, for a flight
    at constant c2, ``computation_parameters``."""
    s = resolved.scenario
    return dict(
        motion_power=aircraft.plant.GetOutputPort("motion_power"),
        period=aircraft.sequencer.GetOutputPort("period"),
        sensor=s.sensor,
        sensor_seed=resolved.sensor_seed,
        estimator=s.estimator,
        battery=s.battery,
        power_offset=s.computation.power_offset,
        order=s.energy_model.order,
        initial_period=s.energy_model.initial_period,
        initial_coefficients=resolved.initial_coefficients,
        time_step=s.simulation.max_step,
    )


def _AddClosedLoop(
    builder: DiagramBuilder, resolved: ResolvedScenario, policy: PlannerPolicy
) -> tuple[GuidedAircraft, EnergyLoop, PlannerScheduler]:
    """The three builders of :func:`MakeEaplanDiagram`, each handed its subtrees of
    ``resolved.scenario`` and the derived values of ``resolved``."""
    table, start = resolved.table, resolved.start
    aircraft = AddGuidedAircraft(
        builder,
        resolved.plan,
        **GuidedAircraftArguments(resolved),
        initial_path_parameter=start[0],
    )
    energy = AddEnergyLoop(builder, table, **EnergyLoopArguments(resolved, aircraft))
    planner = AddPlannerScheduler(
        builder,
        table,
        aircraft,
        energy,
        planner=resolved.scenario.planner,
        policy=policy,
        model_order=resolved.model_order,
        initial_parameters=start,
    )
    return aircraft, energy, planner


def MakeScenarioPolicy(scenario: Scenario, table, plan) -> PlannerPolicy:
    """The policy ``scenario.planner.policy`` names, as :func:`MakeEaplanDiagram` builds it for
    ``table`` (:class:`~eaplan_drake.energy.computation.ComputationTable`) and ``plan`` (the plan
    source): the Eq. 10 line through t(c1) at the bounds in the scenario's wind, and the c1 grid
    of the sequencer's ``remaining_time``."""
    return MakeResolvedPolicy(Derive(scenario, table, plan))


def MakeResolvedPolicy(resolved: ResolvedScenario) -> PlannerPolicy:
    """The policy a resolved scenario names, from its derived values
    (:class:`~eaplan_drake.resolve.ResolvedScenario`)."""
    s = resolved.scenario
    return MakePolicy(
        s.planner,
        resolved.table,
        resolved.model_order,
        s.battery,
        coverage_time_bounds=resolved.coverage_time_bounds,
        path_parameter_grid=resolved.path_parameter_grid,
        integer=s.computation.integer,
    )


def EstimatorOfSensor(estimator: EstimatorParams, readings_per_sample: int) -> EstimatorParams:
    """The estimator parameters behind a sensor that averages n = ``readings_per_sample``
    readings per sample: R = ``measurement_noise`` / n [W²]
    (:func:`~eaplan_drake.energy.sensor.AveragedVariance`); ``estimator`` itself when n = 1."""
    if readings_per_sample == 1:
        return estimator
    return dc.replace(
        estimator,
        measurement_noise=AveragedVariance(estimator.measurement_noise, readings_per_sample),
    )
