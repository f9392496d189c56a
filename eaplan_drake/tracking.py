"""The guidance loop alone: aircraft, guiding vector field and stage sequencer, no energy side.

::

    wind ─► FixedWingPlant ─► StageSequencer ─► VectorFieldGuidance ─► (plant)
                 ▲ path_parameters: a constant c1

For studying coverage and path following (notebook 02): :func:`MakeTrackingDiagram` builds the
diagram with its loggers, :func:`FlyTracking` flies it until the sequencer reports the survey
complete (or ``t_max``) and returns the logged signals with the path error φ(p)
(:func:`PathError`: with ‖∇φ‖ = 1 on the path, |φ| is the distance to the active path to first
order, paper 001 Eq. 8).
"""

import time

import numpy as np

from eaplan_drake.params import CoverageParams, EnergyModelParams, GuidanceParams, VehicleParams

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


def MakeTrackingDiagram(
    plan,
    c1: float,
    wind,
    vehicle: VehicleParams | None = None,
    guidance: GuidanceParams | None = None,
    trigger_radius: float | None = None,
    log_period: float = 0.1,
):
    """The guidance loop flying ``plan`` (a :class:`~eaplan_drake.coverage.PlanSource`) at the
    constant path parameter ``c1`` [m²] in the constant ``wind`` [m/s] (2-vector). Systems are
    named ``plant``, ``guidance``, ``sequencer``, ``wind``, ``path_parameters``; the signals of
    :data:`TRACKING_SIGNALS` are logged every ``log_period`` [s] and ``mission_complete`` is
    exported."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

    from eaplan_drake.guidance import VectorFieldGuidance
    from eaplan_drake.plant import FixedWingPlant, MaxHeadingRate
    from eaplan_drake.sequencer import StageSequencer

    vehicle = vehicle or VehicleParams()
    guidance = guidance or GuidanceParams()
    if trigger_radius is None:
        trigger_radius = CoverageParams().trigger_radius
    w = np.asarray(wind, dtype=float).reshape(2)
    if not np.all(np.isfinite(w)) or not np.isfinite(c1):
        raise ValueError(f"wind and c1 must be finite, got {w.tolist()}, {c1}")
    builder = DiagramBuilder()
    plant = builder.AddNamedSystem("plant", FixedWingPlant(vehicle))
    ctrl = builder.AddNamedSystem(
        "guidance",
        VectorFieldGuidance(
            vehicle.airspeed,
            guidance,
            MaxHeadingRate(vehicle),
            wind_speed=float(np.hypot(*w)),
        ),
    )
    seq = builder.AddNamedSystem(
        "sequencer",
        StageSequencer(
            plan,
            initial_c1=c1,
            trigger_radius=trigger_radius,
            initial_period=EnergyModelParams().initial_period,
            wind=w,
        ),
    )
    wind_source = builder.AddNamedSystem("wind", ConstantVectorSource(w))
    c1_source = builder.AddNamedSystem("path_parameters", ConstantVectorSource([float(c1)]))
    builder.Connect(wind_source.get_output_port(), plant.GetInputPort("wind"))
    for name in ("position", "ground_velocity", "heading"):
        builder.Connect(plant.GetOutputPort(name), ctrl.GetInputPort(name))
    builder.Connect(plant.GetOutputPort("position"), seq.GetInputPort("position"))
    builder.Connect(seq.GetOutputPort("path"), ctrl.GetInputPort("path"))
    builder.Connect(
        ctrl.GetOutputPort("heading_rate_command"), plant.GetInputPort("heading_rate_command")
    )
    builder.Connect(c1_source.get_output_port(), seq.GetInputPort("path_parameters"))
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


def FlyTracking(plan, c1: float, wind, t_max: float = 1200.0, **kwargs) -> dict:
    """Flies :func:`MakeTrackingDiagram` (``kwargs`` go to it) until the survey is complete or
    ``t_max`` [s]. Returns the logged signals (``t`` [s] and one array per signal, samples along
    axis 0), ``phi`` (:func:`PathError`) [m], ``t_end`` [s], ``complete`` and ``wall`` (the wall
    time [s], for information only)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import EventStatus

    diagram = MakeTrackingDiagram(plan, c1, wind, **kwargs)
    simulator = Simulator(diagram)
    done = diagram.GetOutputPort("mission_complete")

    def monitor(root):
        if done.Eval(root)[0] > 0.5:
            return EventStatus.ReachedTermination(diagram, "survey complete")
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    wall = time.perf_counter()
    simulator.AdvanceTo(t_max)
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
