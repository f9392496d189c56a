"""Battery state of charge with the "Rint" equivalent circuit (paper 003 Lemma III.3, App. C).

The battery is an ideal voltage source V [V] in series with a resistance R_r [Ω]. A load that draws
the power y [W] at the terminals needs the internal current (paper 003 Eq. 22)

    I(y) = (V − sqrt(V² − 4 R_r y)) / (2 R_r) = 2 y / (V + sqrt(V² − 4 R_r y))   [A]

(the second form is the same number without the cancellation for small R_r y), and the state of
charge b [-] falls as (Lemma III.3)

    ḃ = −k_b I(y) / Q_c   [1/s],

with Q_c the nominal capacity [Ah] and k_b a coefficient [-] that absorbs the Ah-to-seconds
conversion of the reference numbers (DESIGN.md section 3). V is constant here, so under a constant
load ḃ is constant and b(t) is linear in t (closed forms below).

Brown-out. The circuit cannot deliver more than MaxDeliverablePower = V² / (4 R_r) [W] (the square
root becomes imaginary). A larger load is a brown-out, never a NaN: the functions then use the
current at the maximum power, I = V / (2 R_r), and :func:`IsBrownout` / the ``brownout`` output of
:class:`Battery` say so.

Power budget (Def. III.3, "output constraint" y ≤ b Q_c V). The papers call b·Q_c·V a power [W];
dimensionally Q_c·V is an energy (Ah·V = Wh). We keep the papers' number and name it the power
budget: "the power budget at full charge (Q_c·V, read as watts) times b".
"""

import numpy as np

from eaplan_drake.params import BatteryParams

__all__ = [
    "IsBrownout",
    "MaxDeliverablePower",
    "PowerBudget",
    "RintCurrent",
    "SocAfter",
    "SocDerivative",
    "TimeToSoc",
]


def MaxDeliverablePower(V, R_r):
    """Largest power the Rint circuit can deliver, V² / (4 R_r) [W] (at I = V / (2 R_r))."""
    return V * V / (4.0 * R_r)


def IsBrownout(power, V, R_r):
    """True where the load power [W] exceeds :func:`MaxDeliverablePower` (a brown-out).

    Returns a bool for scalar input, else a bool array of the broadcast shape.
    """
    out = np.asarray(power) > MaxDeliverablePower(V, R_r)
    return bool(out) if out.ndim == 0 else out


def RintCurrent(power, V, R_r):
    """Internal current I(y) [A] for the terminal power y = ``power`` [W] (paper 003 Eq. 22).

    Evaluated as 2y / (V + sqrt(V² − 4 R_r y)) (no cancellation). A negative power (charging) gives
    a negative current. Above :func:`MaxDeliverablePower` (brown-out) it returns the current at the
    maximum power, V / (2 R_r), never NaN; use :func:`IsBrownout` to detect that case. A NaN power
    gives NaN. Scalars give a float; arrays are handled element-wise (numpy broadcasting).
    """
    y = np.asarray(power, dtype=float)
    disc = np.maximum(V * V - 4.0 * R_r * y, 0.0)
    y_eff = np.minimum(y, MaxDeliverablePower(V, R_r))
    current = 2.0 * y_eff / (V + np.sqrt(disc))
    return float(current) if current.ndim == 0 else current


def SocDerivative(power, params: BatteryParams):
    """ḃ = −k_b I(y) / Q_c [1/s] for the load power y = ``power`` [W] (Lemma III.3).

    Brown-out loads use the current at the maximum power (see :func:`RintCurrent`).
    """
    current = RintCurrent(power, params.voltage, params.internal_resistance)
    return -params.k_b * current / params.capacity


def SocAfter(b0, power, duration, params: BatteryParams):
    """Exact state of charge after ``duration`` [s] at constant ``power`` [W] from ``b0`` [-].

    b = b0 + ḃ·duration, clipped to [0, 1] (the battery neither goes below empty nor above full).
    """
    b = np.clip(np.asarray(b0, dtype=float) + SocDerivative(power, params) * duration, 0.0, 1.0)
    return float(b) if b.ndim == 0 else b


def TimeToSoc(b0, b_target, power, params: BatteryParams):
    """Time [s] for the SoC to fall from ``b0`` to ``b_target`` at constant ``power`` [W].

    Closed form t = (b0 − b_target) · Q_c / (k_b I(y)). Returns 0 when b_target ≥ b0 (already
    there) and +inf when the battery does not discharge (power ≤ 0). Brown-out loads use the
    current at the maximum power. Scalars give a float; arrays broadcast element-wise.
    """
    b0 = np.asarray(b0, dtype=float)
    b_target = np.asarray(b_target, dtype=float)
    rate = -np.asarray(SocDerivative(power, params), dtype=float)  # ≥ 0 while discharging
    drop = b0 - b_target
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(drop <= 0.0, 0.0, np.where(rate > 0.0, drop / rate, np.inf))
    return float(t) if t.ndim == 0 else t


def PowerBudget(b, params: BatteryParams):
    """Output constraint bound b·Q_c·V (paper 003 Def. III.3) [W as the papers read it].

    The papers call this a power; Q_c·V [Ah·V] is the budget at full charge, scaled by b.
    """
    budget = np.asarray(b, dtype=float) * (params.capacity * params.voltage)
    return float(budget) if budget.ndim == 0 else budget
