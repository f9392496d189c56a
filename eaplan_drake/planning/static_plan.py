"""The pilot's baseline: the best static plan chosen once, at take-off (``planner.policy:
static_takeoff``; :doc:`/planner`, "the pilot's baseline").

A careful pilot with a planning tool picks one pair (c1, c2) before the survey from the wind and
the battery as they stand, and flies it unchanged. From the state of the first planner step (the
estimate of the power settled, the remaining-time staircase in the current wind), the static plan
(c1_j, c2_k) has t_j = t_rem(c1_j) [s] of survey left and the fault-free margin

    m_jk = b(t_j; c2_k) − b_res − m_floor − z s_b σ_α0 t_j                                  (S1)

(the mpc's prediction and uncertainty term, :class:`~eaplan_drake.planning.mpc.MissionStep`). It
never re-plans, so a drop is not followed by a fallback: it fails when the drops during t_j
total more than m_jk, and its excess risk over the static lowest plan (t_0, m_0) is

    R_jk = P(S(t_j) > m_jk) − P(S(t_0) > m_0)                                              (S2)

(t_j ≥ t_0 and m_jk ≤ m_0 for every plan that spends more, so the lowest plan's failures are
among its own; :meth:`~eaplan_drake.planning.margins.RiskReserve.DropTail`: the stated point
model of ``planner.fault_model``).
The baseline is the highest-quality plan with m_jk ≥ 0 and R_jk ≤ ε = ``planner.risk`` (ties:
the larger end SoC), the lowest plan when none is; the same rule as ``eaplan-drake plan``'s best
static plan, on the scenario's own coverage and the in-flight estimate.
"""

import numpy as np

__all__ = ["BestStaticPlan"]


def BestStaticPlan(step, eps: float):
    """The best static plan of ``step`` (a :class:`~eaplan_drake.planning.mpc.MissionStep` of a
    problem with a risk reserve) at excess risk ε = ``eps`` [-] by (S1)–(S2): a
    :class:`~eaplan_drake.planning.mpc.MissionDecision` (its ``margin`` is the step's m(t_j), as
    for the mpc's decisions), or the lowest plan with ``feasible`` False when not even the lowest
    keeps m ≥ 0 within what the fault model's tables price."""
    pb = step.problem
    reserve = pb.reserve_soc
    t = step.t_rem
    beyond = step.prediction.beyond | (t > pb.risk_reserve.max_exposure)
    uncertainty = step.margin.floor + step.margin.rate * t

    def Tail(times, margins, beyond):
        out = np.ones_like(margins)  # a negative margin fails surely
        ok = (margins >= 0.0) & np.isfinite(margins) & ~beyond
        if np.any(ok):
            out[ok] = pb.risk_reserve.DropTail(times[ok], margins[ok])
        return out

    end_low = step.SocAt(pb.lowest_power, t)
    m_low = end_low - reserve - uncertainty
    if not (np.isfinite(m_low[0]) and m_low[0] >= 0.0 and not beyond[0]):
        low = pb.lowest_candidate
        return step.Decision(0, low, pb.candidates[low], float(end_low[0]), False)
    tail_0 = float(Tail(t[:1], m_low[:1], beyond[:1])[0])
    best, best_key = None, None
    for k, (c2, g) in enumerate(zip(pb.candidates, pb.candidate_power, strict=True)):
        end = step.SocAt(float(g), t)
        m = end - reserve - uncertainty
        ok = (m >= 0.0) & ~beyond
        ok &= Tail(t, m, beyond) - tail_0 <= eps
        for j in np.flatnonzero(ok):
            key = (round(pb.Quality(int(j), pb.RowValues(c2)[1]), 12), float(end[j]))
            if best_key is None or key > best_key:
                best, best_key = (int(j), k, float(end[j])), key
    j, k, end = best if best is not None else (0, pb.lowest_candidate, float(end_low[0]))
    return step.Decision(j, k, pb.candidates[k], end, True)
