"""Runs a scenario's closed loop with Drake's ``Simulator`` and returns a flight log.

The flight ends when the survey is complete, the battery reaches its reserve SoC, the battery
browns out (each decided by the system concerned at its own update, which returns
``EventStatus.ReachedTermination``), or at the scenario's time limit. The
:class:`~eaplan_drake.flightlog.FlightLog` holds the logged time series and a summary with the
paper's quality metric (:mod:`eaplan_drake.flightlog`). If a state or the heading-rate command
becomes NaN or infinite, the flight ends with status ``numerical_failure``.
:func:`FlyHindsight` is the hindsight yardstick: the best constant plan on the same world.
"""

import copy
import itertools
import math
import time
from collections.abc import Callable

import numpy as np
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator, SimulatorStatus

from eaplan_drake.diagram import LoggedSignals, MakeEaplanDiagram
from eaplan_drake.energy.battery import STATUS_BROWNOUT, STATUS_RESERVE
from eaplan_drake.errors import ScenarioError
from eaplan_drake.files import JsonSafe
from eaplan_drake.flight.plant import NonFiniteCommandError
from eaplan_drake.flightlog import FlightLog, NormaliseParameters, Quality, QualityMetric
from eaplan_drake.params import CheckType, Scenario
from eaplan_drake.planning.planner import PlannerPolicy
from eaplan_drake.resolve import ResolvedScenario, ResolveScenario

__all__ = [
    "EndReason",
    "FlyHindsight",
    "HindsightGrid",
    "REFERENCE_SCENARIOS",
    "Simulate",
]

REFERENCE_SCENARIOS = ("plan_I", "plan_II", "plan_i", "plan_ii")
"""The four reference flights of paper 003 Sec. V, shipped as YAML scenarios."""

STATUS_COMPLETE = "complete"
STATUS_TIME_LIMIT = "time_limit"
STATUS_NUMERICAL = "numerical_failure"


def Simulate(
    scenario: Scenario | ResolvedScenario,
    progress: Callable[[float, float, float], None] | None = None,
    progress_interval: float = 60.0,
    *,
    policy: PlannerPolicy | None = None,
) -> FlightLog:
    """Simulates ``scenario`` until the survey completes, the reserve is reached, the battery
    browns out or ``scenario.simulation.time_limit``; returns the :class:`FlightLog`.

    ``progress(t, soc, covered)`` (covered = the survey fraction flown, 1 − coverage_remaining)
    is called about every ``progress_interval`` simulated seconds
    (:class:`~eaplan_drake.output.progress.FlightProgress` draws it).
    ``policy`` replaces the planner policy the scenario names (see
    :func:`~eaplan_drake.diagram.MakeEaplanDiagram`). With ``planner.policy: hindsight`` the
    result is the best flight of :func:`FlyHindsight` (several static flights).

    The scenario is resolved first (:func:`~eaplan_drake.resolve.ResolveScenario`; a caller that
    has resolved it already passes the :class:`~eaplan_drake.resolve.ResolvedScenario`); a bad
    scenario or argument raises :class:`ScenarioError` (one line naming the key or argument)
    before anything is flown. A state or command that becomes NaN or infinite ends the flight
    with status ``numerical_failure``.

    The flight ends at the update that decides it (the sequencer's for "complete", the battery's
    for "brownout" and "reserve_reached", all updates at that time applied), so ``duration`` is
    that update's time and ``final_soc`` the battery's SoC after it.
    """
    if isinstance(scenario, ResolvedScenario):
        resolved, scenario = scenario, scenario.scenario
        _CheckSimulateArguments(scenario, progress, progress_interval, policy)
    else:
        _CheckSimulateArguments(scenario, progress, progress_interval, policy)
        resolved = ResolveScenario(scenario)  # validated once, every file loaded, values derived
    if policy is None and scenario.planner.policy == "hindsight":
        return FlyHindsight(scenario, progress, progress_interval)
    wall_start = time.perf_counter()
    diagram = MakeEaplanDiagram(resolved, policy=policy)
    simulator = Simulator(diagram)
    ResetIntegratorFromFlags(
        simulator, scenario.simulation.integrator, scenario.simulation.max_step
    )
    context = simulator.get_mutable_context()
    try:
        simulator.Initialize()
        status = _AdvanceInChunks(
            simulator, diagram, scenario.simulation.time_limit, progress, progress_interval
        )
    except NonFiniteCommandError:
        status = STATUS_NUMERICAL
    wall_time = time.perf_counter() - wall_start

    log = _CollectLog(diagram, context)
    log.summary = _Summary(log, diagram, context, scenario, status)
    log.summary["wall_time"] = wall_time
    log.summary["realtime_factor"] = log.summary["duration"] / wall_time if wall_time > 0 else None
    return log


def _Summary(log: FlightLog, diagram, context, scenario: Scenario, status: str) -> dict:
    """The summary of a flown log: status and end, SoC, the quality and the paper's metric P
    (:func:`~eaplan_drake.flightlog.QualityMetric`) with the bounds they were measured by, and
    the planner's statistics."""
    reserve = scenario.battery.reserve_soc
    final_time = context.get_time()
    final_soc = float(diagram.GetOutputPort("soc").Eval(context)[0])
    planner = diagram.GetSubsystemByName("planner")
    stats = planner.statistics() if hasattr(planner, "statistics") else {}
    table_lo = np.asarray(planner.table.lower, dtype=float)
    table_hi = np.asarray(planner.table.upper, dtype=float)
    completed = status == STATUS_COMPLETE
    metric, mean_c1, mean_c2 = QualityMetric(
        log.times,
        log["path_parameters"],
        log["computation_parameters"],
        tuple(scenario.planner.path_parameter_bounds),
        (table_lo, table_hi),
        final_soc,
        reserve,
        completed,
    )
    sequencer = diagram.GetSubsystemByName("sequencer")
    # the share of the plan being flown still to fly (0 when complete; the logged
    # coverage_remaining, which the paper's planner reads, is the work left at the finest c1)
    remaining = float(sequencer.SurveyRemaining(sequencer.GetMyContextFromRoot(context)))
    infeasible_at = np.flatnonzero(log["mission_feasible"][:, 0] < 0.5)
    return {
        "scenario": scenario.name,
        "policy": stats.get("policy", scenario.planner.policy),
        "status": status,
        "end_reason": EndReason(status, final_time, scenario, remaining),
        "coverage_remaining": remaining,
        "completed": completed,
        "duration": final_time,
        "final_soc": final_soc,
        "reserve_soc": reserve,
        "path_parameter_bounds": [float(v) for v in scenario.planner.path_parameter_bounds],
        "computation_parameter_bounds": [table_lo.tolist(), table_hi.tolist()],
        "final_margin": final_soc - reserve,
        "quality": Quality(mean_c1, mean_c2),
        "mean_path_parameter_normalised": mean_c1,
        "mean_computation_parameter_normalised": mean_c2,
        "metric": metric,
        "first_infeasible_time": float(log.times[infeasible_at[0]]) if infeasible_at.size else None,
        "planner": JsonSafe(stats),
    }


NUMERICS_CHECK_PERIOD = 1.0
"""How often :func:`Simulate` checks that every state of the diagram is finite [s of flight]."""


def _AdvanceInChunks(simulator, diagram, time_limit, progress, progress_interval) -> str:
    """Advances an initialised flight until a system ends it or ``time_limit``; returns the
    status.

    The systems end the flight themselves: their periodic updates return
    ``EventStatus.ReachedTermination`` with the status as message (the sequencer "complete",
    the battery "brownout" or "reserve_reached"); ``AdvanceTo`` then stops at that update and its
    ``SimulatorStatus`` carries the message. If the survey completed at the same update as a
    battery event, "complete" wins. Another system's termination gives the status
    "ended by <system name>: <message>". Between such events the flight advances in chunks that end
    every :data:`NUMERICS_CHECK_PERIOD` (the states are checked to be finite) and at the
    progress times. Every chunk boundary is an update time k·h of the battery (h its time step,
    computed as Drake computes periodic event times), where a step ends anyway, so the chunks do
    not change the flight.
    """
    context = simulator.get_mutable_context()
    h = diagram.GetSubsystemByName("battery").time_step
    complete_port = diagram.GetOutputPort("mission_complete")
    soc_port = diagram.GetOutputPort("soc")
    remaining_port = diagram.GetOutputPort("coverage_remaining")
    next_check = 0.0
    next_progress = progress_interval if progress is not None else math.inf
    while True:
        t = context.get_time()
        if t >= next_check:
            if not _StatesFinite(diagram, context):
                return STATUS_NUMERICAL
            next_check += NUMERICS_CHECK_PERIOD
        if t >= next_progress:
            next_progress += progress_interval
            covered = 1.0 - float(remaining_port.Eval(context)[0])
            progress(t, float(soc_port.Eval(context)[0]), covered)
        if t >= time_limit:
            return STATUS_TIME_LIMIT
        boundary = min(_EventTime(min(next_check, next_progress), h), time_limit)
        status = simulator.AdvanceTo(boundary)
        if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            if complete_port.Eval(context)[0] > 0.5:
                return STATUS_COMPLETE
            if status.message() in (STATUS_BROWNOUT, STATUS_RESERVE, STATUS_COMPLETE):
                return status.message()
            system = status.system()
            name = system.get_name() if system is not None else "a system"
            return f"ended by {name}: {status.message()}"


def _EventTime(t: float, period: float) -> float:
    """The first time k·period ≥ t (k an integer), computed as Drake computes the times of a
    periodic event with zero offset (``offset + k · period``)."""
    k = round(t / period)
    if k * period < t:
        k += 1
    return k * period


def _StatesFinite(diagram, root_context) -> bool:
    """Whether the aircraft's state (x, y, ψ), the estimator's q̂ and P and the SoC are finite
    (the sensor's NaN of a dropped sample is not a failure)."""
    plant = diagram.GetSubsystemByName("plant")
    plant_context = plant.GetMyContextFromRoot(root_context)
    x = np.concatenate(
        [
            port.Eval(plant_context)
            for port in (plant.GetOutputPort("position"), plant.GetOutputPort("heading"))
        ]
    )
    estimator = diagram.GetSubsystemByName("estimator")
    context = estimator.GetMyContextFromRoot(root_context)
    q = estimator.GetOutputPort("energy_coefficients").Eval(context)
    soc = diagram.GetOutputPort("soc").Eval(root_context)
    return bool(
        np.all(np.isfinite(x))
        and np.all(np.isfinite(q))
        and np.all(np.isfinite(estimator.Covariance(context)))
        and np.all(np.isfinite(soc))
    )


def _CheckSimulateArguments(scenario, progress, progress_interval, policy) -> None:
    CheckType(
        scenario, Scenario, "Simulate: scenario", "a Scenario (e.g. LoadNamedScenario('plan_i'))"
    )
    if progress is not None and not callable(progress):
        raise ScenarioError(
            f"Simulate: progress: expected a callable (t, soc, covered) or None, got "
            f"{type(progress).__name__}"
        )
    if isinstance(progress_interval, bool) or not (
        isinstance(progress_interval, int | float)
        and math.isfinite(progress_interval)
        and progress_interval > 0
    ):
        raise ScenarioError(
            f"Simulate: progress_interval: expected a number of seconds > 0, got "
            f"{progress_interval!r}"
        )
    if policy is not None and not isinstance(policy, PlannerPolicy):
        raise ScenarioError(
            f"Simulate: policy: expected a PlannerPolicy or None, got {type(policy).__name__}"
        )


def EndReason(status: str, time: float, scenario: Scenario, coverage_remaining: float) -> str:
    """One sentence on why a flight ended (``status`` as in the summary, at ``time`` [s], with
    the survey fraction ``coverage_remaining`` still to fly)."""
    left = f"{100 * coverage_remaining:.0f} % of the survey left"
    if status == STATUS_COMPLETE:
        return f"survey complete at {time:.1f} s"
    if status == STATUS_RESERVE:
        return (
            f"battery reached the reserve SoC {scenario.battery.reserve_soc:g} at {time:.1f} s, "
            + left
        )
    if status == STATUS_BROWNOUT:
        return f"battery browned out (load above V²/(4 R_r)) at {time:.1f} s, {left}"
    if status == STATUS_NUMERICAL:
        return f"a state became non-finite at {time:.1f} s (numerical failure), {left}"
    if status == STATUS_TIME_LIMIT:
        return f"time limit {scenario.simulation.time_limit:g} s reached, {left}"
    return f"{status} at {time:.1f} s, {left}"


def _CollectLog(diagram, context) -> FlightLog:
    times, signals = LoggedSignals(diagram, context)
    return FlightLog(times=times, signals=signals, summary={})


def HindsightGrid(scenario: Scenario) -> list[tuple[float, np.ndarray]]:
    """The constant pairs (c1 [m²], c2 [table units]) of the hindsight reference, best quality
    first: ``planner.hindsight_path_parameters`` values of c1 equally spaced over its bounds ×
    every grid point of the computation table (ties: the lower power first)."""
    from eaplan_drake.energy.computation import LoadComputationTable

    table = LoadComputationTable(scenario.computation.table)
    lo, hi = (float(v) for v in scenario.planner.path_parameter_bounds)
    c1_values = np.linspace(lo, hi, scenario.planner.hindsight_path_parameters)
    span = np.where(table.upper > table.lower, table.upper - table.lower, 1.0)
    pairs = []
    for c1 in c1_values:
        for c2 in itertools.product(*table.parameter_grids):
            c2 = np.array(c2, dtype=float)
            q1 = float(NormaliseParameters(c1, lo, hi))
            q2 = float(np.mean((c2 - table.lower) / span))
            pairs.append((-Quality(q1, q2), table.power(c2), float(c1), c2))
    pairs.sort(key=lambda p: (p[0], p[1], -p[2]))
    return [(c1, c2) for _, _, c1, c2 in pairs]


def FlyHindsight(
    scenario: Scenario,
    progress: Callable[[float, float, float], None] | None = None,
    progress_interval: float = 60.0,
) -> FlightLog:
    """The best constant (c1, c2) in hindsight on the world of ``scenario`` (wind, faults, seeds).

    The pairs of :func:`HindsightGrid` are flown as static plans in order of decreasing quality
    ½c̃1 + ½c̃2; the first that completes above the reserve is the answer. A pair is not flown
    when a pair with c1 and every c2 no higher already failed (more coverage time or more
    power cannot complete where less did not). Returns that flight's log, with
    ``summary["hindsight"]`` listing every pair flown; if none completes, the log of the last
    pair flown (the lowest), which failed.
    """
    scenario.Validate()
    failed: list[tuple[float, np.ndarray]] = []
    flown = []
    log = None
    for c1, c2 in HindsightGrid(scenario):
        if any(c1 >= f1 - 1e-9 and np.all(c2 >= f2 - 1e-9) for f1, f2 in failed):
            continue
        static = copy.deepcopy(scenario)
        static.planner.policy = "static"
        static.planner.initial_path_parameters = [c1]
        static.computation.initial_parameters = [float(v) for v in c2]
        log = Simulate(static, progress, progress_interval)
        flown.append(
            {
                "path_parameter": c1,
                "computation_parameters": c2.tolist(),
                "status": log.summary["status"],
                "quality": log.summary["quality"],
                "final_soc": log.summary["final_soc"],
            }
        )
        if log.summary["completed"]:
            break
        failed.append((c1, c2))
    log.summary["scenario"] = scenario.name
    log.summary["policy"] = "hindsight"
    log.summary["hindsight"] = flown
    return log
