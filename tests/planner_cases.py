"""Shared cases of the planner tests (test_prediction, test_paper, test_planner): a
reference-like energy state, the reference survey's coverage times and closed-form oracles."""

import math

import numpy as np

from eaplan_drake.energy.battery import PowerBudget
from eaplan_drake.params import BatteryParams
from eaplan_drake.planning.prediction import SimpsonSoc

ORDER = 3
PERIOD = 46.0
COVERAGE_TIMES = (270.0, 706.0)  # reference: full survey at c1 = −1000 and at c1 = 0 [s]
# A reference-like energy state: mean 30 W with harmonics (q = [α0, α1, β1, α2, β2, α3, β3]).
Q_REF = np.array([30.0, 3.0, 1.0, 1.5, -0.5, 0.3, 0.2])


def Fourier(q, t, period):
    """Closed-form y(t) of the scaled model: α0 + Σ α_j cos(ωjt) + β_j sin(ωjt)."""
    w = 2.0 * math.pi / period
    y = np.full_like(t, q[0])
    for j in range(1, (len(q) - 1) // 2 + 1):
        y += q[2 * j - 1] * np.cos(w * j * t) + q[2 * j] * np.sin(w * j * t)
    return y


def BruteForceC2(table, q, soc, c_prev, battery=None, h=1.0):
    """Largest grid value whose exact y ≤ b·Q_c·V holds at the start and end of the first step."""
    battery = battery or BatteryParams()
    f = Fourier(q, np.array([0.0, 0.5 * h, h]), PERIOD)
    best = table.lower[0]
    for c in table.parameter_grids[0]:
        y = f + table.power([c]) - table.power(c_prev)
        b1 = SimpsonSoc(y, soc, battery, h)[1]
        if y[0] <= PowerBudget(soc, battery) and y[2] <= PowerBudget(b1, battery):
            best = max(best, c)
    return best
