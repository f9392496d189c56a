"""The smooth model of one planner step that the mpc's NLP relaxation
(:class:`~eaplan_drake.planning.relaxation.MissionProgram`) evaluates (:doc:`/planner`, "the
NLP"): the remaining time T(c̃1) as the PCHIP interpolant of the lower convex hull of the
staircase, and the SoC b(t; g) as a C¹ cubic Hermite interpolant of the Simpson nodes with their
rates and sensitivities."""

import math

import numpy as np

from eaplan_drake.planning.interpolation import (
    HermiteBasis,
    HermiteBasisSlope,
    LowerHull,
    PchipSlopes,
)
from eaplan_drake.planning.prediction import SimpsonSocOfRates, SimpsonSteps

__all__ = ["SmoothModel"]


class SmoothModel:
    """The NLP's smooth model of a :class:`~eaplan_drake.planning.mpc.MissionStep` (``step``):
    built from the step's public data (the grid's c̃1 and t_rem, the free response, the battery
    model, h_T, the margin), its nodes computed when first read and kept with it."""

    def __init__(self, step):
        pb, prediction = step.problem, step.prediction
        self.step = step
        self.margin = step.margin
        self.step_length = pb.step_length
        self.battery_model = prediction.battery_model
        self.lowest_power = pb.lowest_power
        self.f_half = prediction.f_half
        self.g_now = prediction.g_now
        self.soc0 = prediction.soc0
        self.t_rem = prediction.t_rem
        hull = LowerHull(pb.u1, self.t_rem)
        self._hull_u = pb.u1[hull]
        self._hull_t = self.t_rem[hull]
        self._hull_slopes = PchipSlopes(self._hull_u, self._hull_t)
        self._nodes: dict = {}
        self._lowest = None

    def RemainingTime(self, u1: float) -> tuple[float, float]:
        """(T(c̃1), dT/dc̃1) [s] of the relaxation: the lower convex hull of the staircase
        (c̃1_j, t_rem_j) (the tightest convex under-estimate; its vertices are the ends of the
        staircase's plateaus), interpolated by a monotone C¹ cubic (PCHIP, Fritsch–Carlson)."""
        u, t, slopes = self._hull_u, self._hull_t, self._hull_slopes
        if u.size == 1:
            return float(t[0]), 0.0
        i = min(max(int(np.searchsorted(u, u1, side="right")) - 1, 0), u.size - 2)
        h = u[i + 1] - u[i]
        s = (u1 - u[i]) / h
        d0, d1 = slopes[i], slopes[i + 1]
        h00, h10, h01, h11 = HermiteBasis(s)
        value = h00 * t[i] + h10 * h * d0 + h01 * t[i + 1] + h11 * h * d1
        dh00, dh10, dh01, dh11 = HermiteBasisSlope(s)
        dh00, dh10, dh01, dh11 = dh00 / h, dh10 / h, dh01 / h, dh11 / h
        slope = dh00 * t[i] + dh10 * h * d0 + dh01 * t[i + 1] + dh11 * h * d1
        return float(value), float(slope)

    def _Nodes(self, power: float):
        """(b, ḃ, ∂b/∂g, ∂ḃ/∂g) at the nodes k·h_T under the held computation power ``power``
        [W]: :func:`~eaplan_drake.planning.prediction.SimpsonSoc` and its sensitivity
        (:func:`~eaplan_drake.planning.prediction.SimpsonSocSensitivity`), kept per power;
        unlike the step's SoC curves, no −inf after a brown-out: the NLP needs a smooth model."""
        key = float(power)
        nodes = self._nodes.get(key)
        if nodes is None:
            y = self.f_half + (key - self.g_now)
            # ḃ and ∂ḃ/∂y once per sample (element-wise: the node values are every other one)
            rate = np.asarray(self.battery_model.SocRate(y))
            slope = np.asarray(self.battery_model.SocRateSlope(y))
            dsoc = np.concatenate(([0.0], np.cumsum(SimpsonSteps(slope, self.step_length))))
            nodes = (
                SimpsonSocOfRates(rate, self.soc0, self.step_length),
                rate[0::2],
                dsoc,
                slope[0::2],
            )
            # as Python floats for SmoothSoc (the solver reads a few nodes at a time, thousands
            # of times a flight; a float is read faster than an array's element)
            nodes = tuple(v.tolist() for v in nodes)
            self._nodes[key] = nodes
        return nodes

    def LowestTerms(self) -> tuple[float, float, float]:
        """(b(h_T), b(t_rem(c̲1)), the margin (2) asks at t_rem(c̲1)) [-] of the lowest plan in
        the smooth model: the terms of the NLP's constraint (2) that do not depend on the plan."""
        if self._lowest is None:
            t_low = float(self.t_rem[0])
            self._lowest = (
                self.Soc(self.lowest_power, self.step_length)[0],
                self.Soc(self.lowest_power, t_low)[0],
                float(self.margin.Recursive(t_low)),
            )
        return self._lowest

    def Soc(self, power: float, t: float) -> tuple[float, float, float]:
        """(b(t), ∂b/∂t, ∂b/∂g) at the held computation power ``power`` [W].

        Cubic Hermite interpolation of the Simpson node values with the node rates ḃ(t_k) (and
        likewise for ∂b/∂g), so that b is continuously differentiable in t for IPOPT.
        """
        h = self.step_length
        soc, rate, dsoc, drate = self._Nodes(power)
        k = min(max(math.floor(t / h), 0), len(soc) - 2)
        a = min(max(t / h - k, 0.0), 1.0) if t <= (len(soc) - 1) * h else t / h - k
        h00, h10, h01, h11 = HermiteBasis(a)
        dh00, dh10, dh01, dh11 = HermiteBasisSlope(a)
        r0, r1 = rate[k], rate[k + 1]
        value = h00 * soc[k] + h10 * h * r0 + h01 * soc[k + 1] + h11 * h * r1
        slope = (dh00 * soc[k] + dh01 * soc[k + 1]) / h + dh10 * r0 + dh11 * r1
        dg = h00 * dsoc[k] + h10 * h * drate[k] + h01 * dsoc[k + 1] + h11 * h * drate[k + 1]
        return float(value), float(slope), float(dg)
