"""Rate settings of the closed loop: the paper's 100 Hz, and the faster setting the studies fly.

A :class:`RateSetting` names the rates of one flight: the base tick 1/h of the plant, guidance,
battery and sequencer (``simulation.max_step`` h [s]), the sensor's rate and whether it averages
(``sensor.rate``, ``sensor.averaging``) and the Kalman filter's rate (``estimator.rate``).
:func:`WithRates` applies one to a scenario. The filter's process-noise variances are per step
(``estimator.process_noise`` q_n, ``mean_process_noise`` q_0 [W²]), so a new filter step h_e'
rescales them to keep the same random walk per second (:func:`RescaledProcessNoise`, as
``FitResult.ScenarioFragment`` does), and an averaging sensor divides the filter's R by the
number of base steps it averages (:func:`~eaplan_drake.diagram.EstimatorOfSensor`): the same
filter in continuous time, sampled less often.

:data:`RATE_PRESETS`: ``paper`` (100 Hz everywhere, the ``simulate`` default) and ``fast`` (the
studies' default, chosen by ``benchmarks/bench_rates.py`` as the fastest setting whose flights
stay within its stated tolerances of the paper-rate flights; :ref:`rates`).
"""

import copy
import dataclasses as dc

import numpy as np

from eaplan_drake.errors import ScenarioError
from eaplan_drake.params import Scenario

__all__ = [
    "DEFAULT_STUDY_RATES",
    "ESTIMATE_FROM",
    "RATE_PRESETS",
    "RATE_TOLERANCES",
    "FlightDifferences",
    "RateSetting",
    "RescaledProcessNoise",
    "WithRates",
    "WithinRateTolerances",
]


@dc.dataclass(frozen=True)
class RateSetting:
    """The rates of one flight [Hz]."""

    plant: float
    """1/h: plant, guidance, battery and sequencer tick (``simulation.max_step`` = 1/plant)."""
    sensor: float
    """``sensor.rate``."""
    averaging: bool
    """``sensor.averaging``: each sample the mean power over its interval (noise σ/√n)."""
    estimator: float
    """``estimator.rate`` (the Kalman filter)."""

    def Label(self) -> str:
        """E.g. ``P20 S10 avg``: plant, sensor (and filter, when different), ``avg`` for the
        averaging sensor, ``point`` for a point sampler below the paper's 100 Hz."""
        text = f"P{self.plant:g} S{self.sensor:g}"
        if self.estimator != self.sensor:
            text += f" F{self.estimator:g}"
        if self.averaging:
            text += " avg"
        elif self.sensor != 100.0:
            text += " point"
        return text


RATE_PRESETS = {
    "paper": RateSetting(plant=100.0, sensor=100.0, averaging=False, estimator=100.0),
    "fast": RateSetting(plant=20.0, sensor=10.0, averaging=True, estimator=10.0),
}
"""Named rate settings: ``paper`` (the papers' and ``simulate``'s 100 Hz) and ``fast``: plant,
guidance, battery and sequencer at 20 Hz, the averaging sensor (the mean of its ten 100 Hz
readings, σ/√10) and the Kalman filter at 10 Hz: the setting ``benchmarks/bench_rates.py``
chooses, the fastest within :data:`RATE_TOLERANCES` of the paper rates on plans I, i, ii and
the windiest study world (P20 S5 avg is as fast within the measurement's noise, with less ŷ
margin) (P10 S10 avg is within them on the three plans but not in 11.5 m/s
wind: 13 m of track, 0.27 W of ŷ)."""

DEFAULT_STUDY_RATES = "fast"
"""The preset the studies (``eaplan-drake sweep``) and ``benchmarks/bench_policies.py`` fly."""


def RescaledProcessNoise(variance: float, old_rate: float, new_rate: float) -> float:
    """q' = q · f_old / f_new [W²]: a random-walk variance per filter step at f_old [Hz] as the
    variance per step at f_new [Hz], the same variance per second (exactly q when the rates are
    equal)."""
    if old_rate == new_rate:
        return variance
    return variance * (old_rate / new_rate)


def WithRates(scenario: Scenario, rates: str | RateSetting) -> Scenario:
    """A validated copy of ``scenario`` flown at ``rates`` (a :data:`RATE_PRESETS` name or a
    :class:`RateSetting`), the filter's per-step process noise rescaled to its new step
    (:func:`RescaledProcessNoise`). ``paper`` on a scenario at the paper's rates changes nothing.
    Raises :class:`~eaplan_drake.params.ScenarioError` for an unknown name or a bad combination
    (one line naming the field)."""
    if isinstance(rates, str):
        if rates not in RATE_PRESETS:
            raise ScenarioError(f"rates: must be one of {', '.join(RATE_PRESETS)}, got {rates!r}")
        rates = RATE_PRESETS[rates]
    if not isinstance(rates, RateSetting):
        raise ScenarioError(
            f"rates: expected a preset name or a RateSetting, got {type(rates).__name__}"
        )
    s = copy.deepcopy(scenario)
    old = float(s.estimator.rate)
    s.simulation.max_step = 1.0 / rates.plant
    s.sensor.rate = float(rates.sensor)
    s.sensor.averaging = bool(rates.averaging)
    s.estimator.rate = float(rates.estimator)
    s.estimator.process_noise = RescaledProcessNoise(
        s.estimator.process_noise, old, rates.estimator
    )
    s.estimator.mean_process_noise = RescaledProcessNoise(
        s.estimator.mean_process_noise, old, rates.estimator
    )
    return s.Validate()


RATE_TOLERANCES = {
    "completion_time": 0.01,
    "final_soc": 0.005,
    "path_parameter": 10.0,
    "rms_estimate": 0.25,
    "max_track": 10.0,
}
"""How far a flight at other rates may be from the same flight at the paper's rates:
Δt_f / t_f within ±1 % [-], ΔSoC_final within ±0.005 [-], Δc1 within ±10 m² at the end (1 % of
the reference c1 range), RMS Δŷ ≤ 0.25 W (half the reference sensor's σ = 0.5 W), max track distance
≤ 10 m (the swath spacing x_d); plus the same status and the same c2 at the end
(:func:`WithinRateTolerances`)."""

ESTIMATE_FROM = 10.0
"""Start of the ŷ comparison [s] (after the filter's start-up transient)."""


def FlightDifferences(flight: dict, reference: dict) -> dict:
    """The differences of ``flight`` from ``reference`` (the same scenario at the paper's rates).

    Each is a dict with ``status``, ``duration`` t_f [s], ``final_soc`` [-], ``c1`` [m²] and
    ``c2`` (list) at the end, and the logs ``times`` [s], ``position`` (N×2) [m], ``estimated``
    ŷ [W], ``true`` y [W]. Compared at the log times both share: ``max_track``, ``rms_track``
    [m] (distance between the positions), ``rms_estimate`` RMS(ŷ − ŷ_ref) [W] and
    ``own_estimate`` RMS(ŷ − y) [W] from t = :data:`ESTIMATE_FROM` on; ``dt_rel`` Δt_f / t_f,ref,
    ``dsoc`` ΔSoC_final, ``dc1`` [m²], ``same_status``, ``same_c2``."""
    ta = np.round(np.asarray(flight["times"], dtype=float), 6)
    tb = np.round(np.asarray(reference["times"], dtype=float), 6)
    t, ia, ib = np.intersect1d(ta, tb, return_indices=True)
    pa, pb = np.asarray(flight["position"]), np.asarray(reference["position"])
    track = np.linalg.norm(pa[ia] - pb[ib], axis=1)
    late = t >= ESTIMATE_FROM
    ya = np.asarray(flight["estimated"], dtype=float)[ia][late]
    yb = np.asarray(reference["estimated"], dtype=float)[ib][late]
    y = np.asarray(flight["true"], dtype=float)[ia][late]
    return {
        "same_status": flight["status"] == reference["status"],
        "dt_rel": (flight["duration"] - reference["duration"]) / reference["duration"],
        "max_track": float(track.max()),
        "rms_track": float(np.sqrt(np.mean(track**2))),
        "rms_estimate": float(np.sqrt(np.mean((ya - yb) ** 2))),
        "own_estimate": float(np.sqrt(np.mean((ya - y) ** 2))),
        "dsoc": flight["final_soc"] - reference["final_soc"],
        "dc1": flight["c1"] - reference["c1"],
        "same_c2": list(flight["c2"]) == list(reference["c2"]),
    }


def WithinRateTolerances(differences: dict) -> bool:
    """Whether :func:`FlightDifferences` are within :data:`RATE_TOLERANCES`."""
    d, t = differences, RATE_TOLERANCES
    return bool(
        d["same_status"]
        and d["same_c2"]
        and abs(d["dt_rel"]) <= t["completion_time"]
        and abs(d["dsoc"]) <= t["final_soc"]
        and abs(d["dc1"]) <= t["path_parameter"]
        and d["rms_estimate"] <= t["rms_estimate"]
        and d["max_track"] <= t["max_track"]
    )
