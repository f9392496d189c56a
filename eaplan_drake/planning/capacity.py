"""The pack's usable capacity, estimated in flight from the SoC the planner reads against the
fall it predicted (``planner.capacity: estimated``).

A pack of health h ∈ (0, 1] (``battery.health``: age, temperature) holds h·Q_c of its label's
Q_c [Ah]. Its SoC b [-] is the fraction of what it holds, so under the same load it falls 1/h
times as fast as the planner's nominal model predicts (Rint, paper 003 Lemma III.3):

    ḃ = −k_b I(y) / (h Q_c) = ḃ_nom / h.

Every planner step k the mpc predicts, with the pack it believes (health ĥ_k), the SoC one period
h_T ahead under the plan it chose; ĥ_k times that predicted fall is the fall Δ̂_k [-] of the
nominal pack. One period later it reads the fall Δ_k = b_k − b_{k+1} that happened. Over steps
without a drop Δ_k = Δ̂_k / h + e_k, with e_k the energy model's one-step error (zero-mean: the
Kalman filter's estimate of the power is unbiased), so the ratio of the sums

    ĥ = (Σ Δ̂_k + w) / (Σ Δ_k + w)

is a consistent estimate of h, with the nominal pack as a prior worth w = :data:`PRIOR_FALL` of
SoC fall (about 2 s of the survey). A step whose fall exceeds its prediction by more than the drop
threshold is a drop (a fault, not the capacity): it is left out of both sums. A drop smaller than
the threshold is counted as fall, which makes ĥ low: on the safe side.

What the planner does with it: it prices every plan on the pack :func:`PlannedPack` of health
ĥ (the battery model of capacity ĥ·Q_c, :func:`~eaplan_drake.energy.battery.UsablePack`): the
SoC it predicts falls 1/ĥ times as fast, and the drops it is told to expect stay fractions of what
the pack holds. ĥ is clipped to [MIN_BATTERY_HEALTH, 1] (a pack is never believed to hold more
than its label says) and rounded to :data:`HEALTH_RESOLUTION`, so a healthy pack is priced exactly
as the nominal one.

Measured on the survey (``battery.health`` 0.85 and 1, with and without gusts, drift and a payload
offset; the flights of ``tests/test_capacity.py``): the ratio of the sums is within 0.005 of 1/h
after 30 s of flight, and the one-step ratio Δ_k / Δ̂_k scatters by 1–4 % per step.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.common.containers import namedview

from eaplan_drake.energy.battery import UsablePack
from eaplan_drake.energy.battery_model import AsBatteryModel, BatteryModel
from eaplan_drake.params import BatteryParams
from eaplan_drake.params.bounds import MIN_BATTERY_HEALTH

__all__ = [
    "HEALTH_RESOLUTION",
    "PRIOR_FALL",
    "CapacityMemory",
    "HealthEstimate",
    "InitialPack",
    "ObservePack",
    "PlannedPack",
    "PredictPack",
    "UNSET",
]

PRIOR_FALL = 0.003
"""w [-]: the SoC fall the nominal pack counts as in :func:`HealthEstimate` (the prior)."""

HEALTH_RESOLUTION = 0.01
"""The grid ĥ is rounded to [-]."""


def HealthEstimate(predicted_fall: float, observed_fall: float, prior_fall: float = PRIOR_FALL):
    """ĥ [-] from the nominal pack's predicted SoC fall Σ Δ̂ [-] and the fall read Σ Δ [-] over
    the same drop-free steps (module docstring): (Σ Δ̂ + w) / (Σ Δ + w), clipped to
    [MIN_BATTERY_HEALTH, 1] and rounded to :data:`HEALTH_RESOLUTION`. ValueError for a negative
    ``prior_fall`` or a sum that is not finite."""
    values = (float(predicted_fall), float(observed_fall), float(prior_fall))
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"HealthEstimate: the falls must be finite numbers [-], got {values}")
    if values[2] <= 0.0:
        raise ValueError(f"prior_fall: must be > 0 [-], got {prior_fall!r}")
    predicted, observed, w = values
    if observed + w <= 0.0:  # the SoC rose more than the prior weighs: nothing fell
        return 1.0
    ratio = (predicted + w) / (observed + w)
    clipped = min(max(ratio, MIN_BATTERY_HEALTH), 1.0)
    rounded = round(round(clipped / HEALTH_RESOLUTION) * HEALTH_RESOLUTION, 12)
    return min(max(rounded, MIN_BATTERY_HEALTH), 1.0)


def PlannedPack(battery: BatteryParams, health: float) -> BatteryModel:
    """The battery model of the pack the planner believes: ``battery``'s label with the usable
    fraction ``health`` of its capacity (:func:`~eaplan_drake.energy.battery.UsablePack`; the
    pack's own ``battery.health``, the truth, is not read)."""
    return AsBatteryModel(UsablePack(dc.replace(battery, health=float(health))))


UNSET = -1.0
"""A planner memory entry nothing has set yet (of :data:`CapacityMemory` and the risk reserve's
:data:`~eaplan_drake.planning.margins.RiskMemory`: their times, SoCs and falls are ≥ 0)."""

CapacityMemory = namedview(
    "CapacityMemory", ["last_soc", "nominal_fall", "health", "predicted_fall", "observed_fall"]
)
"""The estimator's state (a planner's memory, so a flight depends on its scenario only):
``last_soc`` b [-] read at the last step and ``nominal_fall`` Δ̂ [-], the fall the nominal pack
would show one period later under the plan chosen then (both ``UNSET`` (−1) before the first
step); ``health`` ĥ [-], the estimate of the last :func:`ObservePack`; the sums Σ Δ̂ and Σ Δ [-]
of :func:`HealthEstimate` over the drop-free steps so far."""


def InitialPack() -> CapacityMemory:
    """The state before the first step: nothing read, the label believed (ĥ = 1)."""
    pack = CapacityMemory.Zero()
    pack.last_soc, pack.nominal_fall, pack.health = UNSET, UNSET, 1.0
    return pack


def ObservePack(memory, soc: float, drop: float) -> CapacityMemory:
    """The state ``memory`` (a :data:`CapacityMemory` vector) after reading the SoC ``soc`` [-]:
    the fall since the last step Δ = b_last − b and the fall predicted for it, Δ̂, join the sums
    unless Δ exceeds the fall predicted on the believed pack, Δ̂ / ĥ, by more than ``drop`` [-]
    (a drop); ``health`` is the new :func:`HealthEstimate`. Returns a new state."""
    pack = CapacityMemory(np.array(memory, dtype=float))
    if pack.last_soc >= 0.0 and pack.nominal_fall >= 0.0:
        fall = pack.last_soc - float(soc)
        if fall <= pack.nominal_fall / pack.health + float(drop):
            pack.predicted_fall += pack.nominal_fall
            pack.observed_fall += fall
    pack.health = HealthEstimate(pack.predicted_fall, pack.observed_fall)
    return pack


def PredictPack(pack: CapacityMemory, soc: float, ahead: float) -> CapacityMemory:
    """``pack`` after a step that read ``soc`` [-] and predicts ``ahead`` [-] one period later on
    the believed pack (health ``pack.health``): the nominal pack's fall Δ̂ = ĥ (b − b_ahead)
    (``UNSET`` (−1) for a prediction past a brown-out). Returns a new state."""
    pack = CapacityMemory(np.array(pack[:], dtype=float))
    fall = (float(soc) - float(ahead)) * pack.health
    pack.last_soc = float(soc)
    pack.nominal_fall = fall if math.isfinite(fall) else UNSET
    return pack
