"""The smooth model the mpc's NLP relaxation (:mod:`eaplan_drake.planning.relaxation`) evaluates:
the remaining time T(c̃1) and the SoC b(t; g) as C¹ interpolants, methods of
:class:`~eaplan_drake.planning.mpc.MissionProblem` (derivation in
:mod:`eaplan_drake.planning.mpc`)."""

import math

import numpy as np

from eaplan_drake.planning.prediction import SimpsonSocOfRates, SimpsonSteps
from eaplan_drake.planning.relaxation import _LowerHull, _PchipSlopes

__all__ = ["SmoothModel"]


class SmoothModel:
    """The NLP's smooth model of one planner step; mixed into
    :class:`~eaplan_drake.planning.mpc.MissionProblem`, whose step data it reads (u1 and t_rem,
    whose lower convex hull it builds on first use in a step; f_half, g_now, soc0, the battery
    model and the step h_T)."""

    def RemainingTime(self, u1: float) -> tuple[float, float]:
        """(T(c̃1), dT/dc̃1) [s] of the relaxation: the lower convex hull of the staircase
        (c̃1_j, t_rem_j) (the tightest convex under-estimate; its vertices are the ends of the
        staircase's plateaus), interpolated by a monotone C¹ cubic (PCHIP, Fritsch–Carlson)."""
        if self._hull_slopes is None:  # once per step, when the NLP first asks
            hull = _LowerHull(self.u1, self.t_rem)
            self._hull_slopes = (hull, _PchipSlopes(self.u1[hull], self.t_rem[hull]))
        hull, slopes = self._hull_slopes
        u, t = self.u1[hull], self.t_rem[hull]
        if u.size == 1:
            return float(t[0]), 0.0
        i = min(max(int(np.searchsorted(u, u1, side="right")) - 1, 0), u.size - 2)
        h = u[i + 1] - u[i]
        s = (u1 - u[i]) / h
        d0, d1 = slopes[i], slopes[i + 1]
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        value = h00 * t[i] + h10 * h * d0 + h01 * t[i + 1] + h11 * h * d1
        dh00, dh10 = (6 * s**2 - 6 * s) / h, (3 * s**2 - 4 * s + 1) / h
        dh01, dh11 = (-6 * s**2 + 6 * s) / h, (3 * s**2 - 2 * s) / h
        slope = dh00 * t[i] + dh10 * h * d0 + dh01 * t[i + 1] + dh11 * h * d1
        return float(value), float(slope)

    def _SmoothNodes(self, power: float):
        """(b, ḃ, ∂b/∂g, ∂ḃ/∂g) at the nodes k·h_T under the held computation power ``power``
        [W]: :func:`~eaplan_drake.planning.prediction.SimpsonSoc` and its sensitivity
        (:func:`~eaplan_drake.planning.prediction.SimpsonSocSensitivity`), cached per power for
        the step; unlike :meth:`SocCurve`, no −inf after a brown-out: the NLP needs a smooth
        model)."""
        key = float(power)
        nodes = self._smooth_cache.get(key)
        if nodes is None:
            y = self.f_half + (key - self.g_now)
            # ḃ and ∂ḃ/∂y once per sample (element-wise: the node values are every other one)
            rate = np.asarray(self.battery_model.SocRate(y))
            slope = np.asarray(self.battery_model.SocRateSlope(y))
            dsoc = np.concatenate(([0.0], np.cumsum(SimpsonSteps(slope, self.step))))
            nodes = (
                SimpsonSocOfRates(rate, self.soc0, self.step),
                rate[0::2],
                dsoc,
                slope[0::2],
            )
            # as Python floats for SmoothSoc (the solver reads a few nodes at a time, thousands
            # of times a flight; a float is read faster than an array's element)
            nodes = tuple(v.tolist() for v in nodes)
            self._smooth_cache[key] = nodes
        return nodes

    def SmoothLowestTerms(self) -> tuple[float, float, float]:
        """(b(h_T), b(t_rem(c̲1)), the margin (2) asks at t_rem(c̲1)) [-] of the lowest plan in the
        smooth model: the terms of the NLP's constraint (2) that do not depend on the plan,
        computed once per step and margin setting."""
        key = ("lowest", self._margin_rate, self._faults_counted)
        terms = self._smooth_cache.get(key)
        if terms is None:
            g_low = float(self.candidate_power[self.lowest_candidate])
            t_low = float(self.t_rem[0])
            terms = self._smooth_cache[key] = (
                self.SmoothSoc(g_low, self.step)[0],
                self.SmoothSoc(g_low, t_low)[0],
                float(self.RecursiveMargin(t_low)),
            )
        return terms

    def SmoothSoc(self, power: float, t: float) -> tuple[float, float, float]:
        """(b(t), ∂b/∂t, ∂b/∂g) at the held computation power ``power`` [W].

        Cubic Hermite interpolation of the Simpson node values with the node rates ḃ(t_k) (and
        likewise for ∂b/∂g), so that b is continuously differentiable in t for IPOPT.
        """
        h = self.step
        soc, rate, dsoc, drate = self._SmoothNodes(power)
        k = min(max(math.floor(t / h), 0), len(soc) - 2)
        a = min(max(t / h - k, 0.0), 1.0) if t <= (len(soc) - 1) * h else t / h - k
        h00, h10 = 2 * a**3 - 3 * a**2 + 1, a**3 - 2 * a**2 + a
        h01, h11 = -2 * a**3 + 3 * a**2, a**3 - a**2
        dh00, dh10 = 6 * a**2 - 6 * a, 3 * a**2 - 4 * a + 1
        dh01, dh11 = -6 * a**2 + 6 * a, 3 * a**2 - 2 * a
        r0, r1 = rate[k], rate[k + 1]
        value = h00 * soc[k] + h10 * h * r0 + h01 * soc[k + 1] + h11 * h * r1
        slope = (dh00 * soc[k] + dh01 * soc[k + 1]) / h + dh10 * r0 + dh11 * r1
        dg = h00 * dsoc[k] + h10 * h * drate[k] + h01 * dsoc[k + 1] + h11 * h * drate[k + 1]
        return float(value), float(slope), float(dg)
