"""A synthetic stand-in for certify's flights whose excess-failure rate is known in closed form
(for tests and benchmarks of the sampling modes and bounds, at no flight's cost).

A stand-in world holds the drops of the window [0, τ*] of a fault model (uniform sizes on [a, b];
:func:`~eaplan_drake.studies.sampling.DrawWindows`), S [-] their total. The lowest plan completes
when S <= m_0 (``lowest_margin``); the policy, which spends more, is lost when S > m_1
(``policy_margin`` < m_0), and also, whatever the drops, with probability r_0 (``other_loss``:
losses no fault explains, so that no stratum is safe). With p_n the Poisson counts and
Q_n(m) = P(X_1 + … + X_n > m) (Irwin–Hall, :class:`~eaplan_drake.planning.risk.UniformDrops`)::

    P(S <= m) = Σ_n p_n (1 − Q_n(m)),
    ρ = [P(m_1 < S <= m_0) + r_0 P(S <= m_1)] / P(S <= m_0).
"""

import dataclasses as dc

import numpy as np

from eaplan_drake.params import FaultModelParams
from eaplan_drake.planning.risk import UniformDrops
from eaplan_drake.studies.sampling import CountProbabilities, DrawWindows, FaultProposal

__all__ = ["StandIn", "StandInRate", "StandInWorlds"]


@dc.dataclass(frozen=True)
class StandIn:
    """The stand-in's margins [-] and its window [s]."""

    window: float = 330.0
    lowest_margin: float = 0.3
    policy_margin: float = 0.2496
    other_loss: float = 0.003
    model: FaultModelParams = dc.field(default_factory=FaultModelParams)


def _AtMost(s: StandIn, margin: float) -> float:
    p = CountProbabilities(s.model, s.window)
    q = UniformDrops(*s.model.size_bounds).sum_tail(p.size - 1, margin)
    return float(np.sum(p * (1.0 - q)))


def StandInRate(s: StandIn) -> float:
    """ρ, the stand-in's excess-failure rate (exact to 1e-12)."""
    low, pol = _AtMost(s, s.lowest_margin), _AtMost(s, s.policy_margin)
    return (low - pol + s.other_loss * pol) / low


def StandInWorlds(rng, s: StandIn, proposal: FaultProposal | None, worlds: int):
    """(W, E, F, stratum) of ``worlds`` stand-in worlds drawn from ``proposal`` (None: as
    declared)."""
    proposal = proposal or FaultProposal(window=s.window, mix=1.0)
    n, sizes, w = DrawWindows(rng, s.model, dc.replace(proposal, window=s.window), worlds)
    total = np.nansum(sizes, axis=1)
    feasible = total <= s.lowest_margin
    lost = (total > s.policy_margin) | (rng.uniform(size=worlds) < s.other_loss)
    return w, (feasible & lost).astype(float), feasible.astype(float), n
