"""Fit the energy model to a recorded power log: the order and the noise by a held-out
criterion (:func:`FitPowerModel`), the whole log fitted on its first half and scored on its
second (:func:`FitPowerLog`), and its figure (:func:`PlotLogFit`).

The parts it is made of: the model's filter and predictions over a series
(:mod:`eaplan_drake.logfit.filtering`), the noise identification (:mod:`eaplan_drake.logfit.noise`),
the fitted model and its scenario fragment (:mod:`eaplan_drake.logfit.result`), and the baselines
and prediction scores (:mod:`eaplan_drake.logfit.scores`).

**Order by a held-out criterion.** :func:`FitPowerModel` fits every candidate order (noise by
likelihood, :func:`~eaplan_drake.logfit.noise.FitNoise`, Nelder–Mead from the default start and
from the previous order's optimum: two local optima, both candidates) on the first 70 % of the
training record and keeps the one whose predictions at 1 step, T/4, T/2 and T ahead have the
smallest mean squared error, summed over the four horizons, for the targets in the remaining
30 % (:func:`~eaplan_drake.logfit.noise.MultiStepError`; origins before the split count, so
every horizon has the same held-out targets). The same criterion decides whether the level
random walk q_0 is kept (a structural choice like r: the likelihood prefers a quickly adapting
level, best one step ahead but not always T ahead), whether the chosen structure's noise fitted
for the horizons (``criterion="horizons"``) beats its likelihood noise, and compares two levels
fitted for the horizons (:func:`~eaplan_drake.logfit.noise.FitLevelNoise`: the local level,
y = α0 a random walk, and the r = 0 model with its q_0 re-chosen), whose q_0 is chosen by the
multi-step error on the first 70 % itself. The chosen structure's noise is then refitted on the
whole training record, by the criterion that won
(:attr:`~eaplan_drake.logfit.result.PowerModelFit.noise_criterion`). The model and the estimator
are the same whichever wins; only the noise values differ.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.logfit.filtering import (
    FilterPowerSeries,
    HorizonSteps,
    PeriodInForce,
    PeriodSeries,
    PredictAhead,
    UniformPowerSeries,
)
from eaplan_drake.logfit.noise import (
    FitLevelNoise,
    FitNoise,
    InnovationLogLikelihood,
    MultiStepError,
)
from eaplan_drake.logfit.result import HORIZONS_SUFFIX, SCENARIO_MAX_ORDER, ModelName, PowerModelFit
from eaplan_drake.logfit.scores import ScorePredictions

__all__ = [
    "CheckLogLength",
    "FitPowerLog",
    "FitPowerModel",
    "FRAGMENT_ORDERS",
    "HELD_OUT_SPLIT",
    "LogFit",
    "MinimumSamples",
    "ORDERS",
    "PlotLogFit",
    "SyntheticPower",
]


def SyntheticPower(
    seed: int,
    tau: float = 15.0,
    sigma: float = 3.0,
    noise: float = 0.5,
    dt: float = 0.5,
    duration: float = 1200.0,
    period: float = 46.0,
):
    """(t [s], y [W]) on a uniform grid of step ``dt``: periodic power (``period`` T, mean 30 W,
    three harmonics) + an AR(1) load of time constant ``tau`` [s] and standard deviation
    ``sigma`` [W] + white noise of ``noise`` [W]; the test signal of the fit and its benchmark."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, dt)
    w = 2.0 * math.pi / period
    y = 30.0 + 3.0 * np.cos(w * t) + 2.0 * np.sin(2 * w * t) + np.cos(3 * w * t + 1.0)
    phi = math.exp(-dt / tau)
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), t.size)
    d = np.zeros(t.size)
    for k in range(1, t.size):
        d[k] = phi * d[k - 1] + e[k]
    return t, y + d + rng.normal(0.0, noise, t.size)


HELD_OUT_SPLIT = 0.7
"""The fraction of the training record on which :func:`FitPowerModel` fits its candidates (the
rest scores them); it must hold one period."""

ORDERS = (0, 1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
"""Candidate Fourier orders of :func:`FitPowerModel` (those with 2r + 1 ≤ samples per period)."""

FRAGMENT_ORDERS = tuple(r for r in ORDERS if r <= SCENARIO_MAX_ORDER)
"""The candidate orders of ``eaplan-drake fit``, whose ``fit.yaml`` must load as a scenario
fragment: those of :data:`ORDERS` up to :data:`~eaplan_drake.logfit.result.SCENARIO_MAX_ORDER`."""


@dc.dataclass
class _HeldOut:
    """The held-out choice of :func:`FitPowerModel`: each candidate's noise is fitted on the first
    ``split`` samples of z and the candidate is scored by
    :func:`~eaplan_drake.logfit.noise.MultiStepError` on the targets after them."""

    z: np.ndarray
    time_step: float
    period: object
    """T [s] or T_k per sample of z (:func:`~eaplan_drake.logfit.filtering.PeriodSeries`)."""
    head: object
    """The period of the first ``split`` samples: T, or their T_k."""
    nominal: float
    split: int
    aperiodic: bool
    max_evaluations: int
    candidates: list = dc.field(default_factory=list)
    """As :attr:`~eaplan_drake.logfit.result.PowerModelFit.candidates`."""
    best: tuple | None = None
    """(order r, held-out score, noise) of the best candidate so far."""

    def Train(self, order, evaluations, start=None, level=True, criterion="likelihood"):
        """(noise, ℓ) of :func:`~eaplan_drake.logfit.noise.FitNoise` on the first ``split``
        samples."""
        z, dt = self.z[: self.split], self.time_step
        return FitNoise(
            z, dt, order, self.head, self.aperiodic, evaluations, start, level, criterion
        )

    def Score(self, order, noise, name, period=None) -> float:
        """The held-out score of a candidate (``period``: the record's by default), recorded."""
        period = self.period if period is None else period
        score = MultiStepError(self.z, self.time_step, order, period, noise, self.split)
        self.candidates.append((order, noise.mean_process_noise, score, name))
        return score

    def Offer(self, order, noise, name, period=None) -> bool:
        """:meth:`Score` a candidate and keep it when it beats the best so far (True then)."""
        score = self.Score(order, noise, name, period)
        if self.best is None or score < self.best[1]:
            self.best = (order, score, noise)
            return True
        return False

    def FitOrders(self, orders, period_steps: int):
        """Every order that one period of ``period_steps`` samples resolves (2r + 1 ≤ P), from the
        default start and from the previous order's higher-likelihood optimum (both optima are
        candidates). Returns the r = 0 optimum, the start of the r = 0 level (None without
        r = 0)."""
        warm = level_start = None
        for r in sorted({int(r) for r in orders}):
            if 2 * r + 1 > period_steps:  # more harmonics than one period of samples resolves
                continue
            fits = [self.Train(r, self.max_evaluations)]
            if warm is not None:  # the previous order's optimum as a second start
                fits.append(self.Train(r, self.max_evaluations // 2, warm))
            warm = max(fits, key=lambda fit: fit[1])[0]
            if r == 0:
                level_start = warm
            for noise, _ in fits:  # both likelihood optima are candidates of the held-out choice
                self.Offer(r, noise, ModelName(r, noise))
        if self.best is None:
            raise ValueError(
                f"orders: no candidate in {list(orders)} fits a period of {period_steps} samples"
            )
        return level_start

    def FitNoiseVariants(self):
        """The best order without the level random walk q_0, then the best structure with its
        noise fitted for the horizons. Returns (order r, level, criterion): whether q_0 is
        searched, and the noise criterion that won."""
        r, best_score, start = self.best
        fixed, _ = self.Train(r, self.max_evaluations // 3, start, level=False)
        score = self.Score(r, fixed, ModelName(r, fixed))
        level = score >= best_score
        if not level:
            self.best = (r, score, fixed)
        horizons, _ = self.Train(r, self.max_evaluations // 3, self.best[2], level, "horizons")
        won = self.Offer(r, horizons, ModelName(r, horizons) + HORIZONS_SUFFIX)
        return r, level, "horizons" if won else "likelihood"

    def FitLevels(self, level_start) -> str:
        """The levels fitted for the horizons (:func:`~eaplan_drake.logfit.noise.FitLevelNoise`):
        the local level, and the r = 0 model's q_0 re-chosen (from ``level_start``, when r = 0
        was tried). Returns the one that won, "local" or "r0", or "none"."""
        bases = {"local": None, "r0": level_start} if level_start is not None else {"local": None}
        horizon = "none"
        for name, base in bases.items():
            walk = FitLevelNoise(self.z[: self.split], self.time_step, self.nominal, base)
            if self.Offer(0, walk, ModelName(0, walk, name), self.nominal):
                horizon = name
        return horizon

    def Refit(self, order, level, criterion, horizon, level_start) -> PowerModelFit:
        """The chosen structure's noise refitted on the whole record, from the chosen optimum
        (likelihood or horizons; the levels: :func:`~eaplan_drake.logfit.noise.FitLevelNoise`)."""
        z, dt, nominal, aperiodic = self.z, self.time_step, self.nominal, self.aperiodic
        evals = self.max_evaluations // 3
        if horizon == "none":
            start = self.best[2]
            noise, ll = FitNoise(
                z, dt, order, self.period, aperiodic, evals, start, level, criterion
            )
            name = ModelName(order, noise)
        else:
            base = None
            if horizon == "r0":
                base, _ = FitNoise(z, dt, 0, nominal, aperiodic, evals, level_start)
            noise = FitLevelNoise(z, dt, nominal, base)
            ll = InnovationLogLikelihood(z, dt, 0, nominal, noise)
            order, name, criterion = 0, ModelName(0, noise, horizon), "level"
        mean = float(z.mean())
        return PowerModelFit(
            order, nominal, float(dt), noise, ll, mean, self.candidates, name, criterion
        )


def FitPowerModel(
    z,
    time_step: float,
    period,
    orders=ORDERS,
    aperiodic: bool = True,
    max_evaluations: int = 120,
    local_level: bool = True,
) -> PowerModelFit:
    """Fit order and noise to a uniform power series z [W] (step Δt [s], period T [s]).

    ``period`` is T [s] or T_k per sample (:func:`~eaplan_drake.logfit.filtering.PeriodSeries`; the
    nominal T sets the horizons). Every order of ``orders`` with 2r + 1 ≤ T/Δt has its noise fitted
    by likelihood on the first 70 % (from the default start and from the previous order's
    higher-likelihood optimum; both optima are candidates) and is scored by
    :func:`~eaplan_drake.logfit.noise.MultiStepError` on the last 30 % (the held-out criterion of
    the module docstring); then whether the level random walk q_0 helps the best order (held out
    too); with ``local_level`` the two levels of :func:`~eaplan_drake.logfit.noise.FitLevelNoise`
    (the local level, and r = 0 with q_0 re-chosen; fitted on the first 70 %) are candidates scored
    the same way. The chosen structure's noise is refitted on the whole record, from the chosen
    optimum (likelihood; the levels: :func:`~eaplan_drake.logfit.noise.FitLevelNoise`).
    ``aperiodic`` adds the AR(1) load state to the Fourier candidates (False: the paper's model).
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    nominal, Ts = PeriodSeries(period, z.size)
    P = int(round(nominal / time_step))
    split = int(HELD_OUT_SPLIT * z.size)
    if split < P:
        raise ValueError(
            f"power log: the first {100 * HELD_OUT_SPLIT:.0f} % of the {z.size} samples at "
            f"{time_step:.4g} s hold {split * time_step / nominal:.2f} periods of {nominal:.4g} s, "
            "less than the one the fit needs; record longer or check the period"
        )
    head = nominal if Ts is None else Ts[:split]
    search = _HeldOut(z, time_step, period, head, nominal, split, aperiodic, max_evaluations)
    level_start = search.FitOrders(orders, P)
    order, level, criterion = search.FitNoiseVariants()
    horizon = search.FitLevels(level_start) if local_level else "none"
    return search.Refit(order, level, criterion, horizon, level_start)


@dc.dataclass
class LogFit:
    """Everything :func:`FitPowerLog` found for one log."""

    fit: PowerModelFit
    """Model fitted on the first half."""
    scores: dict
    """:func:`~eaplan_drake.logfit.scores.ScorePredictions` on the second half."""
    times: np.ndarray
    """Uniform grid t [s]."""
    power: np.ndarray
    """z on that grid [W]."""
    period_source: str
    """Where T came from (given, a period log, or the estimate and its confidence)."""
    periods: np.ndarray | None = None
    """T_k [s] in force at each grid time (from a period log), or None: one T."""

    def Period(self):
        """T [s], or T_k [s] per grid sample: the ``period`` argument of the fit functions."""
        return self.fit.period if self.periods is None else self.periods


def FitPowerLog(
    times,
    power,
    period: float | None = None,
    orders=ORDERS,
    aperiodic: bool = True,
    min_confidence: float = 0.5,
    period_log=None,
) -> LogFit:
    """Fit on the first half of a power log and score on the second (module docstring).

    T is ``period`` [s] when given (the plan's period: ground truth for the motion part), else
    :func:`~eaplan_drake.energy.fourier.EstimatePeriodWithConfidence`; a log without a clear period
    raises ValueError saying so (give the period). ``period_log`` = (times [s], T [s]) on the log's
    clock instead gives a time-varying period: T_k =
    :func:`~eaplan_drake.logfit.filtering.PeriodInForce` at each sample, for the model and the
    baselines alike (the horizons: the last T in force).
    """
    from eaplan_drake.energy.fourier import EstimatePeriodWithConfidence

    t, z = UniformPowerSeries(times, power)
    dt = float(t[1] - t[0])
    if period_log is not None:
        if period is not None:
            raise ValueError("period: give either a period or a period log, not both")
        Ts = PeriodInForce(t, *period_log)
        nominal, varying = PeriodSeries(Ts, z.size)
        CheckLogLength(z.size, dt, nominal, "period log")
        half = z.size // 2
        period = Ts if varying is not None else nominal
        head = Ts[:half] if varying is not None else nominal
        fit = FitPowerModel(z[:half], dt, head, orders, aperiodic)
        source = f"period log ({np.min(Ts):.2f}–{np.max(Ts):.2f} s in force)"
        return LogFit(fit, ScorePredictions(z, dt, period, fit), t, z, source, varying)
    if period is None:
        estimate = EstimatePeriodWithConfidence(t, z, min_confidence=min_confidence)
        if estimate.period is None:
            raise ValueError(f"{estimate.message}; give the plan's period (--period SECONDS)")
        period, source = float(estimate.period), f"estimated: {estimate.message}"
    else:
        period = float(period)
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"--period: must be finite and > 0 [s], got {period!r}")
        source = "given"
    CheckLogLength(z.size, dt, period, source)
    half = z.size // 2
    fit = FitPowerModel(z[:half], dt, period, orders, aperiodic)
    return LogFit(fit, ScorePredictions(z, dt, period, fit), t, z, source)


def MinimumSamples(time_step: float, period: float) -> int:
    """The fewest samples of step Δt [s] that :func:`FitPowerLog` fits and scores with period
    T [s]: the first half (the training record) has one period in its first
    :data:`HELD_OUT_SPLIT`, and the second half has origins T ahead of a target (after the
    first period). About 2.9 periods."""
    P = max(1, int(round(period / time_step)))
    n = 2 * P + 1
    while int(HELD_OUT_SPLIT * (n // 2)) < P or n - P <= max(n // 2, P):
        n += 1
    return n


def CheckLogLength(samples: int, time_step: float, period: float, source: str = "given") -> None:
    """ValueError (one line) when a log of ``samples`` at Δt [s] is too short for the period T
    [s] (:func:`MinimumSamples`); ``source`` says where T came from (``given``, ``estimated``,
    ``period log``; what follows a colon or a parenthesis is left out)."""
    need = MinimumSamples(time_step, period)
    if samples < need:
        where = source.split(":")[0].split(" (")[0]
        raise ValueError(
            f"power log: {samples} samples at {time_step:.4g} s ({samples * time_step:.4g} s) "
            f"cover {samples * time_step / period:.2f} periods of T = {period:.4g} s ({where}); "
            f"fit needs {need} samples ({need * time_step / period:.2f} periods: it fits on the "
            "first half and scores up to T ahead on the second); record longer or check the "
            "period"
        )


def PlotLogFit(result: LogFit):
    """Figure: RMSE per horizon of the model and the baselines; the scored half with the model's
    T/4-ahead prediction."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fit, scores = result.fit, result.scores
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 6.5))
    horizons = list(scores["model"])
    x = np.arange(len(horizons))
    width = 0.8 / len(scores)
    for i, (name, row) in enumerate(scores.items()):
        a.bar(x + (i - 1.5) * width, [row[h][0] for h in horizons], width, label=name)
    a.set_xticks(x, horizons)
    a.set_ylabel("RMSE [W]")
    name = fit.model_name or ModelName(fit.order, fit.noise)
    a.set_title(f"prediction error, model {name}, T = {fit.period:.1f} s")
    a.legend(fontsize=8)
    dt = fit.time_step
    period = result.Period()
    H = HorizonSteps(PeriodSeries(period, result.power.size)[0], dt)[1]
    states, _, _ = FilterPowerSeries(result.power, dt, fit.order, period, fit.noise)
    pred = PredictAhead(states, fit.order, period, dt, fit.noise, H)
    k = np.arange(result.power.size // 2, result.power.size - H)
    b.plot(result.times, result.power, color="0.6", lw=0.6, label="measured")
    b.plot(result.times[k + H], pred[k], color="tab:orange", lw=0.9, label="model, T/4 ahead")
    b.set_xlabel("t [s]")
    b.set_ylabel("power [W]")
    b.legend(fontsize=8)
    fig.tight_layout()
    return fig
