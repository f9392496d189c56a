"""The aircraft's wind estimate from its ground velocity and air data (``wind.estimator``).

An autopilot does not know the wind: it measures its ground velocity ṗ [m/s] (GNSS) and its air
data, the airspeed v_a [m/s] and the heading ψ [rad], and the wind is the difference,

    m_k = ṗ(t_k) − v_a [cos ψ(t_k), sin ψ(t_k)]   [m/s],

which holds the gusts as well as the mean wind. The estimate is its first-order low-pass with the
time constant τ [s] (``wind.estimator.time_constant``), stepped every h [s] and exact for a
measurement held over the step:

    ŵ_{k+1} = ŵ_k + α (m_k − ŵ_k),   α = 1 − e^{−h/τ}.

Its error, analytically: a constant wind is reached as (1 − α)^k of the initial error; a wind
ramping at r [m/s²] is followed with the steady lag e∞ = r h / α (≈ r (τ + h/2)); gusts pass
through it attenuated by the low-pass (the error's variance is the stationary solution of the
joint linear system of the Dryden states and ŵ; tests/test_wind_estimator.py checks all three).
ŵ(0) is the scenario's wind (``wind.speed``, ``wind.direction_deg``), the forecast at take-off.
In a flight (:func:`AddWindEstimator`) h is :func:`EstimatorStep` of the plant's step: 0.08 s
at the default 0.01 s, a power of two times the plant's step so that its update times are the
plant's, bit for bit (a Python update at every plant step would cost ≈ 10 % of a static
flight's CPU for a filter of τ = 10 s).
The air data here is exact (no sensor noise).

:class:`WindEstimator` is the system; :func:`AddWindEstimator` adds it to a
diagram, and with ``wind.staircase: estimated`` the sequencer prices its remaining-time
staircase in ŵ instead of the scenario's constant wind.
"""

import math

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from eaplan_drake.params import WindEstimatorParams

__all__ = [
    "AddWindEstimator",
    "EstimatorStep",
    "MAX_ESTIMATOR_STEP",
    "WindEstimateStep",
    "WindEstimator",
    "WindFilterGain",
    "WindMeasurement",
]


MAX_ESTIMATOR_STEP = 0.1
"""The longest step of the wind estimate in a flight [s] (:func:`EstimatorStep`)."""


def EstimatorStep(base_step: float) -> float:
    """h·2^n [s], n ≥ 0 the largest with h·2^n <= :data:`MAX_ESTIMATOR_STEP` (h itself when it
    is longer), for the plant's step h [s]: k·(h·2^n) is then (k·2^n)·h to the bit (scaling by
    a power of two is exact), so the estimate updates at the plant's update times."""
    h = float(base_step)
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"EstimatorStep: base_step must be > 0 s, got {base_step!r}")
    step = h
    while 2.0 * step <= MAX_ESTIMATOR_STEP:
        step *= 2.0
    return step


def WindMeasurement(ground_velocity, heading: float, airspeed: float) -> tuple[float, float]:
    """m = ṗ − v_a [cos ψ, sin ψ] [m/s] of the ground velocity ṗ [m/s], the heading ψ [rad] and
    the airspeed v_a [m/s]."""
    return (
        ground_velocity[0] - airspeed * math.cos(heading),
        ground_velocity[1] - airspeed * math.sin(heading),
    )


def WindFilterGain(time_constant: float, step: float) -> float:
    """α = 1 − e^{−h/τ} [-] of the time constant τ [s] and the step h [s] (both > 0)."""
    tau, h = float(time_constant), float(step)
    if not (math.isfinite(tau) and tau > 0.0 and math.isfinite(h) and h > 0.0):
        raise ValueError(f"WindFilterGain: need tau > 0 and h > 0 s, got {time_constant}, {step}")
    return -math.expm1(-h / tau)


def WindEstimateStep(estimate, measurement, gain: float) -> tuple[float, float]:
    """ŵ_{k+1} = ŵ_k + α (m_k − ŵ_k) [m/s] of the estimate ŵ_k, the measurement m_k and α."""
    return (
        estimate[0] + gain * (measurement[0] - estimate[0]),
        estimate[1] + gain * (measurement[1] - estimate[1]),
    )


class WindEstimator(LeafSystem):
    """ŵ [m/s], the aircraft's wind estimate (module docstring), stepped every ``time_step``.

    Args:
        airspeed: v_a [m/s], > 0.
        time_constant: τ [s], > 0.
        time_step: h [s], > 0 (a power-of-two multiple of the plant's step,
            :func:`EstimatorStep`).
        initial_wind: ŵ(0) [m/s] (east, north).

    Input ``kinematics`` (x, y, ψ, ṗ_x, ṗ_y) [m, m, rad, m/s, m/s] (the plant's); output
    ``wind_estimate`` ŵ (2), its discrete state (a state output port). A non-finite measurement
    (before the plant's first update) leaves ŵ unchanged.

    .. pydrake_system::

        name: WindEstimator
        input_ports:
        - kinematics
        output_ports:
        - wind_estimate
    """

    def __init__(self, *, airspeed: float, time_constant: float, time_step: float, initial_wind):
        super().__init__()
        if not (math.isfinite(airspeed) and airspeed > 0.0):
            raise ValueError(f"WindEstimator: airspeed must be > 0 m/s, got {airspeed!r}")
        self._airspeed = float(airspeed)
        self._gain = WindFilterGain(time_constant, time_step)
        w0 = np.asarray(initial_wind, dtype=float).reshape(2)
        if not np.all(np.isfinite(w0)):
            raise ValueError(f"WindEstimator: initial_wind must be finite, got {initial_wind!r}")
        self._kinematics_port = self.DeclareVectorInputPort("kinematics", 5)
        self._index = self.DeclareDiscreteState(w0)
        self.DeclarePeriodicDiscreteUpdateEvent(float(time_step), 0.0, self._Update)
        self.DeclareStateOutputPort("wind_estimate", self._index)

    @property
    def gain(self) -> float:
        """α [-]."""
        return self._gain

    def _Update(self, context, discrete_state):
        _, _, heading, vx, vy = self._kinematics_port.Eval(context).tolist()
        m = WindMeasurement((vx, vy), heading, self._airspeed)
        if not (math.isfinite(m[0]) and math.isfinite(m[1])):
            return
        w = discrete_state.get_mutable_value(self._index)
        w[0], w[1] = WindEstimateStep(w.tolist(), m, self._gain)


def AddWindEstimator(
    builder: DiagramBuilder,
    plant,
    *,
    params: WindEstimatorParams,
    time_step: float,
    initial_wind,
) -> WindEstimator:
    """Adds the aircraft's wind estimate ``wind_estimator``
    (:class:`~eaplan_drake.flight.wind_estimator.WindEstimator`, time constant
    ``params.time_constant`` [s], stepped every
    :func:`~eaplan_drake.flight.wind_estimator.EstimatorStep` of the plant's step
    ``time_step`` [s], from ``initial_wind``
    ŵ(0) [m/s]) reading the ``kinematics`` of ``plant`` (its ground velocity and heading, with
    the plant's airspeed as the air data); its ``wind_estimate`` output is left for the caller."""
    estimator = builder.AddNamedSystem(
        "wind_estimator",
        WindEstimator(
            airspeed=plant.airspeed(),
            time_constant=params.time_constant,
            time_step=EstimatorStep(time_step),
            initial_wind=initial_wind,
        ),
    )
    builder.Connect(plant.GetOutputPort("kinematics"), estimator.GetInputPort("kinematics"))
    return estimator
