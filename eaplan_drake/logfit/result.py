"""What a fit of the energy model found: :class:`PowerModelFit` (order, period, noise and every
candidate tried), the model's name in words (:func:`ModelName`), and the scenario fragment
(``fit.yaml``) that ``simulate`` layers over a scenario (:meth:`PowerModelFit.ScenarioFragment`).
"""

import dataclasses as dc
import math

from eaplan_drake.logfit.filtering import NoiseParameters
from eaplan_drake.rates import RescaledProcessNoise

__all__ = [
    "HORIZONS_SUFFIX",
    "ModelName",
    "NOISE_CRITERIA_TEXT",
    "PowerModelFit",
    "SCENARIO_MAX_ORDER",
]


SCENARIO_MAX_ORDER = 20
"""The largest Fourier order a scenario accepts (``energy_model.order`` in
:mod:`eaplan_drake.params`), hence the largest of a :meth:`PowerModelFit.ScenarioFragment`."""


HORIZONS_SUFFIX = " (noise for the horizons)"
"""Appended to a candidate's name in :attr:`PowerModelFit.candidates` when its noise was fitted by
the multi-step error (``criterion="horizons"``)."""


NOISE_CRITERIA_TEXT = {
    "likelihood": "innovation likelihood",
    "horizons": "multi-step error",
    "level": "likelihood, q_0 by multi-step error",
}
""":attr:`PowerModelFit.noise_criterion` in words (printed by ``fit``, in ``fit.yaml``'s header)."""


@dc.dataclass
class PowerModelFit:
    """Result of :func:`~eaplan_drake.logfit.fit.FitPowerModel`."""

    order: int
    """r [-]."""
    period: float
    """T [s] (with a time-varying period: the last one in force in the training record)."""
    time_step: float
    """Δt of the log (after resampling) [s]."""
    noise: NoiseParameters
    """Fitted noise at Δt."""
    log_likelihood: float
    """ℓ on the training record [-]."""
    mean_power: float
    """Mean of the training record [W]."""
    candidates: list
    """(order r, level intensity q_0 [W²/step], held-out score [W²], name) of every candidate
    tried, in order: the orders, the best order without q_0, the best structure with its noise
    fitted for the horizons (its name ends in :data:`HORIZONS_SUFFIX`), then the levels fitted
    for the horizons (local level, then r = 0 with its q_0 re-chosen); name as
    :attr:`model_name`."""
    model_name: str = ""
    """The chosen model in words (:func:`ModelName`): "r=4+AR(1)", "level", "level+AR(1)", …;
    the two levels fitted for the horizons have r = 0 like the ordinary r = 0 model."""
    noise_criterion: str = "likelihood"
    """How the chosen noise was fitted, a key of :data:`NOISE_CRITERIA_TEXT`: "likelihood"
    (innovation likelihood), "horizons" (multi-step error,
    :func:`~eaplan_drake.logfit.noise.FitNoise`) or "level" (one of the two levels of
    :func:`~eaplan_drake.logfit.noise.FitLevelNoise`: q_0 by the multi-step error, the rest by
    likelihood)."""

    def ScenarioFragment(self, estimator_rate: float = 100.0) -> str:
        """YAML for ``simulate`` with the fitted model (energy_model and estimator keys);
        ValueError for an order above :data:`SCENARIO_MAX_ORDER`.

        q_n and q_0 are random-walk variances per step, rescaled from the log's step to the
        estimator's step 1/rate (:func:`~eaplan_drake.rates.RescaledProcessNoise`); R is the log's
        per-sample noise (also the simulated sensor's σ = √R); τ and q_d are rate independent.
        """
        if self.order > SCENARIO_MAX_ORDER:
            raise ValueError(
                f"scenario fragment: order r = {self.order} is above energy_model.order's "
                f"largest, {SCENARIO_MAX_ORDER}; fit with orders up to {SCENARIO_MAX_ORDER} "
                "(FRAGMENT_ORDERS)"
            )
        log_rate = 1.0 / self.time_step
        qn = RescaledProcessNoise(self.noise.process_noise, log_rate, estimator_rate)
        q0 = RescaledProcessNoise(self.noise.mean_process_noise, log_rate, estimator_rate)
        tau = self.noise.aperiodic_time_constant
        name = self.model_name or ModelName(self.order, self.noise)
        lines = [
            "# fitted by eaplan-drake fit (order by held-out error; noise by "
            + NOISE_CRITERIA_TEXT[self.noise_criterion]
            + ")",
            f"# model: {name}",
            "sensor:",
            f"  noise_std: {_YamlFloat(math.sqrt(self.noise.measurement_noise))}",
            "energy_model:",
            f"  order: {self.order}",
            f"  initial_period: {_YamlFloat(self.period)}",
            f"  initial_mean_power: {_YamlFloat(max(self.mean_power, 0.0))}",
            "estimator:",
            f"  process_noise: {_YamlFloat(qn)}",
            f"  measurement_noise: {_YamlFloat(self.noise.measurement_noise)}",
            f"  mean_process_noise: {_YamlFloat(q0)}",
        ]
        if tau > 0.0:
            lines += [
                f"  aperiodic_time_constant: {_YamlFloat(tau)}",
                f"  aperiodic_noise: {_YamlFloat(self.noise.aperiodic_noise)}",
            ]
        return "\n".join(lines) + "\n"


def ModelName(order: int, noise: NoiseParameters, horizon: str = "none") -> str:
    """The model in words: "r=<r>" for the Fourier model of order r, with "+AR(1)" when it has the
    aperiodic load (τ > 0) and "+walk" when its level α0 has the random walk q_0 > 0; ``horizon``
    "local" (the local level of :func:`~eaplan_drake.logfit.noise.FitLevelNoise`) is "level", "r0"
    (the r = 0 model with q_0 re-chosen for the horizons) "level+AR(1)" (or "level" without τ)."""
    aperiodic = "+AR(1)" if noise.aperiodic_time_constant > 0.0 else ""
    if horizon in ("local", "r0"):
        return "level" + aperiodic
    if horizon != "none":
        raise ValueError(f"horizon: one of none, local, r0, got {horizon!r}")
    walk = "+walk" if noise.mean_process_noise > 0.0 else ""
    return f"r={int(order)}{aperiodic}{walk}"


def _YamlFloat(x: float) -> str:
    """A float YAML 1.1 reads as a float (a dot, a signed exponent), ``.inf`` for ∞."""
    x = float(x)
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    if x == 0.0 or 1e-3 <= abs(x) < 1e6:
        text = f"{x:.6g}"
        return text if "." in text else text + ".0"
    return f"{x:.6e}"
