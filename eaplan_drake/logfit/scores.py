"""How well the fitted model predicts a power log: the three baselines (last value, one-period
moving average, seasonal naive) and the prediction scores against them.

:func:`ScorePredictions` scores RMSE and MAE [W] of the predictions made from origins in the
second half of a log (the model fitted on the first half), at 1 step, T/4, T/2 and T ahead,
against the baselines (:func:`BaselinePrediction`: last value, one-period moving average, and
the value one period before the target, seasonal naive; both with the period in force at the
origin when it varies). :func:`FormatScores` prints the table.
"""

import numpy as np

from eaplan_drake.logfit.filtering import (
    FilterPowerSeries,
    HorizonSteps,
    PeriodSeries,
    PredictAhead,
    PredictionErrors,
)
from eaplan_drake.logfit.result import PowerModelFit

__all__ = [
    "BASELINES",
    "BaselinePrediction",
    "FormatScores",
    "HORIZON_NAMES",
    "ScorePredictions",
]


BASELINES = ("last value", "moving average", "seasonal naive")
"""The three baselines of :func:`ScorePredictions`."""

HORIZON_NAMES = ("1 step", "T/4", "T/2", "T")
"""The horizons of the score table, in the order of
:func:`~eaplan_drake.logfit.filtering.HorizonSteps`."""


def BaselinePrediction(name: str, z, period_steps, steps: int) -> np.ndarray:
    """Baseline prediction of z_{k+H} made at k (NaN where it needs samples before the log).

    ``period_steps`` P: one period in samples, or P_k per origin (the period in force at k; the
    moving average then spans the last P_k samples). Seasonal naive is z_{k+H−jP} with
    j = ⌈H/P⌉ whole periods back (j = 1 for H ≤ P), so it never uses a sample after k.
    """
    z = np.asarray(z, dtype=float)
    n, H = z.size, int(steps)
    P = np.broadcast_to(np.asarray(period_steps, dtype=int), (n,))
    k = np.arange(n)
    out = np.full(n, np.nan)
    if name == "last value":
        out[:] = z
    elif name == "moving average":
        c = np.concatenate(([0.0], np.cumsum(z)))
        ok = k + 1 - P >= 0
        out[ok] = (c[k[ok] + 1] - c[k[ok] + 1 - P[ok]]) / P[ok]
    elif name == "seasonal naive":
        back = P * -(-H // P)  # ⌈H/P⌉ periods
        ok = k + H - back >= 0
        out[ok] = z[k[ok] + H - back[ok]]
    else:
        raise ValueError(f"baseline: one of {BASELINES}, got {name!r}")
    return out


def ScorePredictions(z, time_step: float, period, fit: PowerModelFit):
    """RMSE and MAE [W] at 1 step, T/4, T/2, T ahead from origins in the second half of z.

    The filter with ``fit``'s model runs over the whole record (it has seen only samples up to each
    origin). ``period``: T [s] or T_k per sample
    (:func:`~eaplan_drake.logfit.filtering.PeriodSeries`; the horizons are those of the nominal T,
    the model and the baselines use the period in force at each origin). Returns {predictor:
    {horizon name: (RMSE, MAE)}}, predictors "model" and :data:`BASELINES`.
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    nominal, Ts = PeriodSeries(period, z.size)
    states, _, _ = FilterPowerSeries(z, time_step, fit.order, period, fit.noise)
    P = max(1, int(round(nominal / time_step)))
    Pk = P if Ts is None else np.maximum(1, np.round(Ts / time_step).astype(int))
    table = {name: {} for name in ("model",) + BASELINES}
    for label, H in zip(HORIZON_NAMES, HorizonSteps(nominal, time_step), strict=True):
        origins = np.arange(max(z.size // 2, int(np.max(Pk))), z.size - H)
        if origins.size == 0:
            raise ValueError(f"power log: too short to score {label} ahead in its second half")
        pred = PredictAhead(states, fit.order, period, time_step, fit.noise, H)
        table["model"][label] = PredictionErrors(pred, z, origins, H)
        for name in BASELINES:
            table[name][label] = PredictionErrors(BaselinePrediction(name, z, Pk, H), z, origins, H)
    return table


def FormatScores(scores: dict) -> str:
    """The score table as text: RMSE / MAE [W] per predictor and horizon."""
    horizons = list(next(iter(scores.values())))
    lines = [f"{'predictor':16s}" + "".join(f"{h:>16s}" for h in horizons)]
    for name, row in scores.items():
        lines.append(
            f"{name:16s}" + "".join(f"{row[h][0]:8.3f} /{row[h][1]:6.3f}" for h in horizons)
        )
    return "\n".join(lines) + "\n(RMSE / MAE [W], origins in the second half, fit on the first)"
