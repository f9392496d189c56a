"""The guidance loop alone: aircraft, guiding vector field and stage sequencer, no energy side.

::

    wind ─► FixedWingPlant ─► StageSequencer ─► VectorFieldGuidance ─► (plant)
                 ▲ path_parameters: a constant c1

For studying coverage and path following (notebook 02): :func:`MakeTrackingDiagram` builds the
diagram with its loggers, :func:`FlyTracking` flies it until the sequencer reports the survey
complete (or ``t_max``) and returns the logged signals with the path error φ(p)
(:func:`PathError`: with ‖∇φ‖ = 1 on the path, the magnitude of φ is the distance to the active
path to first order, paper 001 Eq. 8).
"""

import time

import numpy as np

from eaplan_drake.params import Scenario

__all__ = ["FlyTracking", "MakeTrackingDiagram", "PathError", "TRACKING_SIGNALS"]

TRACKING_SIGNALS = {
    # log name: (system name, output port name)
    "position": ("plant", "position"),
    "motion_power": ("plant", "motion_power"),
    "path": ("sequencer", "path"),
    "period": ("sequencer", "period"),
}
"""Signals logged by :func:`MakeTrackingDiagram` (``VectorLogSink`` named ``log_<name>``)."""


def PathError(positions, descriptors) -> np.ndarray:
    """φ(p) = a‖p‖² + bᵀp + c [m] per sample, from positions (k × 2) [m] and the path
    descriptors ``[a, b_x, b_y, c, s, k_e]`` (k × 6) of the sequencer's ``path`` port."""
    p = np.asarray(positions, dtype=float).reshape(-1, 2)
    d = np.asarray(descriptors, dtype=float).reshape(len(p), -1)
    return d[:, 0] * np.sum(p * p, axis=1) + d[:, 1] * p[:, 0] + d[:, 2] * p[:, 1] + d[:, 3]


def MakeTrackingDiagram(scenario: Scenario, plan, c1: float, *, log_period: float | None = None):
    """The guidance loop flying ``plan`` (a :class:`~eaplan_drake.flight.coverage.PlanSource`) at
    the constant path parameter ``c1`` [m²], with the scenario's vehicle, guidance gains, wind
    (constant unless ``wind.gusts`` or ``wind.drift`` is on), ``coverage.trigger_radius`` and
    plant (``simulation.plant``, :func:`~eaplan_drake.flight.plant.MakeFixedWingPlant`).
    Systems are named ``plant``, ``guidance``, ``sequencer``, ``wind``, ``path_parameters``; the
    signals of :data:`TRACKING_SIGNALS` are logged every ``log_period`` [s] (default
    ``simulation.log_period``) and ``mission_complete`` is exported."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import LogVectorOutput

    from eaplan_drake.diagram import AddGuidedAircraft, GuidedAircraftArguments

    scenario.wind.Validate("wind")
    scenario.simulation.Validate("simulation")
    if not np.isfinite(c1):
        raise ValueError(f"c1 must be finite, got {c1}")
    if log_period is None:
        log_period = scenario.simulation.log_period
    builder = DiagramBuilder()
    aircraft = AddGuidedAircraft(
        builder,
        plan,
        **GuidedAircraftArguments(scenario),
        initial_path_parameter=c1,
        path_parameter=float(c1),
    )
    plant, seq = aircraft.plant, aircraft.sequencer
    systems = {"plant": plant, "sequencer": seq}
    for name, (system, port) in TRACKING_SIGNALS.items():
        logger = LogVectorOutput(
            systems[system].GetOutputPort(port), builder, publish_period=log_period
        )
        logger.set_name(f"log_{name}")
    builder.ExportOutput(seq.GetOutputPort("mission_complete"), "mission_complete")
    diagram = builder.Build()
    diagram.set_name("tracking")
    return diagram


def FlyTracking(
    scenario: Scenario,
    plan,
    c1: float,
    *,
    t_max: float | None = None,
    log_period: float | None = None,
) -> dict:
    """Flies :func:`MakeTrackingDiagram` until the survey is complete or ``t_max`` [s] (default
    ``simulation.time_limit``), the continuous plant with the scenario's ``integrator`` and
    ``max_step``. Returns the logged signals (``t`` [s] and one array per signal, samples along
    axis 0), ``phi`` (:func:`PathError`) [m], ``t_end`` [s], ``complete`` and ``wall`` (the wall
    time [s], for information only)."""
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator

    # The sequencer ends the simulation itself when the survey completes.
    diagram = MakeTrackingDiagram(scenario, plan, c1, log_period=log_period)
    simulator = Simulator(diagram)
    ResetIntegratorFromFlags(
        simulator, scenario.simulation.integrator, scenario.simulation.max_step
    )
    done = diagram.GetOutputPort("mission_complete")

    wall = time.perf_counter()
    simulator.AdvanceTo(scenario.simulation.time_limit if t_max is None else t_max)
    wall = time.perf_counter() - wall
    ctx = simulator.get_context()
    flight = {}
    for name in TRACKING_SIGNALS:
        log = diagram.GetSubsystemByName(f"log_{name}").FindLog(ctx)
        flight[name] = np.array(log.data()).T
        flight["t"] = np.array(log.sample_times())
    flight["phi"] = PathError(flight["position"], flight["path"])
    flight.update(t_end=ctx.get_time(), wall=wall, complete=bool(done.Eval(ctx)[0] > 0.5))
    return flight
