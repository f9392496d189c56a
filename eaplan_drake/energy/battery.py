"""Battery state of charge with the "Rint" equivalent circuit (paper 003 Lemma III.3, App. C).

The battery is an ideal voltage source V [V] in series with a resistance R_r [Ω]. A load that draws
the power y [W] at the terminals needs the internal current (paper 003 Eq. 22)

    I(y) = (V − sqrt(V² − 4 R_r y)) / (2 R_r) = 2 y / (V + sqrt(V² − 4 R_r y))   [A]

(the second form is the same number without the cancellation for small R_r y), and the state of
charge b [-] falls as (Lemma III.3)

    ḃ = −k_b I(y) / Q_c   [1/s],

with Q_c the nominal capacity [Ah] and k_b the Ah-to-seconds conversion [h/s]: the physical 1/3600
by default, the authors' scaling 0.00183 in the reference scenarios
(:ref:`design-reference-scenario`). Q_c and V come from the pack's label
(:meth:`BatteryParams.Capacity <eaplan_drake.params.BatteryParams.Capacity>`,
:meth:`BatteryParams.Voltage <eaplan_drake.params.BatteryParams.Voltage>`). V is constant here, so
under a constant load ḃ is constant and b(t) is linear in t (closed forms below).

Brown-out. The circuit cannot deliver more than MaxDeliverablePower = V² / (4 R_r) [W] (the square
root becomes imaginary). A larger load is a brown-out, never a NaN: the functions then use the
current at the maximum power, I = V / (2 R_r), and :func:`IsBrownout` / the ``brownout`` output of
:class:`Battery` say so.

Health (``battery.health``, 1 by default). A pack delivers a fraction h ∈ [0.1, 1] of its
nominal capacity (age, temperature): the :class:`Battery` system discharges the capacity h·Q_c
(:func:`UsablePack`), so its SoC, the fraction of what the pack holds, falls 1/h times as fast
under the same load; the planner's prediction keeps the nominal Q_c.

Power budget (Def. III.3, "output constraint" y ≤ b Q_c V). The papers call b·Q_c·V a power [W];
dimensionally Q_c·V is an energy (Ah·V = Wh). We keep the papers' number and name it the power
budget: "the power budget at full charge (Q_c·V, read as watts) times b".
"""

import copy
import dataclasses as dc
import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import EventStatus, LeafSystem

from eaplan_drake.energy.battery_model import AsBatteryModel, BatteryModel
from eaplan_drake.params import BatteryParams

__all__ = [
    "STATUS_BROWNOUT",
    "STATUS_RESERVE",
    "Battery",
    "BatteryState",
    "IsBrownout",
    "MaxDeliverablePower",
    "PowerBudget",
    "RintCurrent",
    "SocAfter",
    "SocDerivative",
    "SocDerivativeSlope",
    "RintBatteryModel",
    "TimeToSoc",
    "UsablePack",
]


def MaxDeliverablePower(V, R_r):
    """Largest power the Rint circuit can deliver, V² / (4 R_r) [W] (at I = V / (2 R_r))."""
    return V * V / (4.0 * R_r)


def IsBrownout(power, V, R_r):
    """True where the load power [W] exceeds :func:`MaxDeliverablePower` (a brown-out).

    Returns a bool for scalar input, else a bool array of the broadcast shape.
    """
    y, scalar = _Operand(power)
    out = y > MaxDeliverablePower(V, R_r)
    return bool(out) if scalar else out


def RintCurrent(power, V, R_r):
    """Internal current I(y) [A] for the terminal power y = ``power`` [W] (paper 003 Eq. 22).

    Evaluated as 2y / (V + sqrt(V² − 4 R_r y)) (no cancellation). A negative power (charging) gives
    a negative current. Above :func:`MaxDeliverablePower` (brown-out) it returns the current at the
    maximum power, 2 y_max / V = V / (2 R_r), never NaN; use :func:`IsBrownout` to detect that
    case. A NaN power gives NaN. Scalars give a float; arrays are handled element-wise (numpy
    broadcasting). This is the one implementation of the Rint current (the :class:`Battery`
    system calls it at every update): the same expression is evaluated with ``math`` for a
    scalar (well under a µs) and with numpy for an array.
    """
    y, scalar = _Operand(power)
    sqrt, minimum, maximum = _SCALAR_OPS if scalar else _ARRAY_OPS
    disc = maximum(V * V - 4.0 * R_r * y, 0.0)
    return 2.0 * minimum(y, MaxDeliverablePower(V, R_r)) / (V + sqrt(disc))


def SocDerivative(power, params: BatteryParams):
    """ḃ = −k_b I(y) / Q_c [1/s] for the load power y = ``power`` [W] (Lemma III.3).

    Brown-out loads use the current at the maximum power (see :func:`RintCurrent`).
    """
    current = RintCurrent(power, params.Voltage(), params.internal_resistance)
    return -params.k_b * current / params.Capacity()


def SocDerivativeSlope(power, params: BatteryParams):
    """∂ḃ/∂y = −k_b I'(y)/Q_c [1/(W s)] of :func:`SocDerivative`.

    I'(y) = 1/sqrt(V² − 4 R_r y) below :func:`MaxDeliverablePower`; 0 at
    and above it, where the current saturates at V/(2 R_r).
    """
    V, R = params.Voltage(), float(params.internal_resistance)
    y = np.asarray(power, dtype=float)
    below = y < MaxDeliverablePower(V, R)
    disc = np.where(below, V * V - 4.0 * R * y, 1.0)
    slope = np.where(below, 1.0 / np.sqrt(disc), 0.0)
    return -params.k_b * slope / params.Capacity()


def SocAfter(b0, power, duration, params: BatteryParams):
    """Exact state of charge after ``duration`` [s] at constant ``power`` [W] from ``b0`` [-].

    b = clip(b0 − I(y) · (k_b · duration / Q_c), 0, 1) (Lemma III.3 integrated over a constant
    load; the battery neither goes below empty nor above full). This is the step of the
    :class:`Battery` system (``duration`` = its time step h). Scalars give a float; arrays
    broadcast element-wise.
    """
    b0, _ = _Operand(b0)
    current = RintCurrent(power, params.Voltage(), params.internal_resistance)
    b, scalar = _Operand(b0 - current * (params.k_b / params.Capacity() * duration))
    _, minimum, maximum = _SCALAR_OPS if scalar else _ARRAY_OPS
    return minimum(maximum(b, 0.0), 1.0)


_SCALAR_OPS = (math.sqrt, min, max)
_ARRAY_OPS = (np.sqrt, np.minimum, np.maximum)
_SCALAR_TYPES = (float, int)


def _Operand(value) -> tuple:
    """(value as a float, True) for a Python or numpy scalar, else (a float array, False): the
    functions above evaluate one expression with ``math`` for scalars and numpy for arrays."""
    if type(value) is float:  # the Battery's update: no conversion
        return value, True
    if isinstance(value, _SCALAR_TYPES):
        return float(value), True
    array = np.asarray(value, dtype=float)
    if array.ndim == 0:
        return float(array), True
    return array, False


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
    budget = np.multiply(b, params.Capacity() * params.Voltage())
    return float(budget) if budget.ndim == 0 else budget


class RintBatteryModel(BatteryModel):
    """``battery.model: rint``: the functions above as a
    :class:`~eaplan_drake.energy.battery_model.BatteryModel` (each method calls one of them with
    these parameters, so the battery system and the planner compute the same numbers)."""

    def SocRate(self, power):
        return SocDerivative(power, self.params)

    def SocRateSlope(self, power):
        return SocDerivativeSlope(power, self.params)

    def SocAfter(self, soc, power, duration):
        return SocAfter(soc, power, duration, self.params)

    def Current(self, power):
        return RintCurrent(power, self.params.Voltage(), self.params.internal_resistance)

    def IsBrownout(self, power):
        return IsBrownout(power, self.params.Voltage(), self.params.internal_resistance)

    def PowerBudget(self, soc):
        return PowerBudget(soc, self.params)


def UsablePack(params: BatteryParams) -> BatteryParams:
    """The pack as it is: ``params`` with the capacity health · Q_c [Ah] (and health 1), however
    its label gave Q_c (``capacity``, ``capacity_mah`` or ``energy_wh``); ``params`` itself when
    its health is 1."""
    if params.health == 1.0:
        return params
    return dc.replace(
        params,
        capacity=params.Capacity() * params.health,
        capacity_mah=0.0,
        energy_wh=0.0,
        health=1.0,
    )


# -- Drake system -------------------------------------------------------------------------------


BatteryState = namedview("BatteryState", ["soc", "held_power", "next_fault"])
"""The Battery's discrete state: b [-], the load y(t_{k−1}) [W] held over the step, and the
index of the next fault (in time order) [-]."""

STATUS_BROWNOUT = "brownout"
"""Message of the ``ReachedTermination`` event status when the load exceeds V²/(4R_r)."""
STATUS_RESERVE = "reserve_reached"
"""Message of the ``ReachedTermination`` event status when b reaches the reserve SoC."""


class Battery(LeafSystem):
    """State of charge b of a Rint battery under a load power y (paper 003 Lemma III.3).

    Discrete state, updated every ``time_step`` h [s] at t_k = k·h (the load is sampled and held,
    so the step is exact for a piecewise-constant load):

        b(t_k) = SocAfter(b(t_{k−1}), y(t_{k−1}), h) − Σ_{τ ∈ (t_{k−1}, t_k]} Δb

    (clipped at 0 after each fault Δb), with :func:`SocAfter` = clip(b − k_b I(y) h / Q_c, 0, 1)
    and I(y) of :func:`RintCurrent`. A fault (τ, Δb) is applied exactly once, by the first update
    at t_k ≥ τ (1e-9 s tolerance for the floating-point event times); Δb is an absolute drop
    (0.06 = −6 % of full charge). The very first update (t = 0) only samples the load and applies
    faults with τ ≤ 0. The SoC never goes below 0.

    Health: the system steps the usable pack (:func:`UsablePack`, capacity health · Q_c); its
    ``params`` are the nominal ones, its ``model`` the usable pack's.

    Termination: the update at t_k ends the simulation (it returns
    ``EventStatus.ReachedTermination(self, message)``, its state update still applied) with the
    message :data:`STATUS_BROWNOUT` ("brownout") when the sampled load y(t_k) exceeds V²/(4R_r),
    else :data:`STATUS_RESERVE` ("reserve_reached") when b(t_k) ≤ ``params.reserve_soc``.
    ``Simulator.AdvanceTo`` then returns a status whose ``message()`` is that string.

    Outputs: ``soc`` b(t_k) [-] and ``power_budget`` b·Q_c·V (Def. III.3, see :func:`PowerBudget`)
    depend on the state only (``state`` is the whole discrete state, :data:`BatteryState`, as a
    state output port: no Python call per read); ``current`` I(y(t)) [A] and ``brownout`` (1.0 when
    y(t) > V²/(4R_r), else 0.0, :func:`IsBrownout`) are direct feedthrough of ``power``. Above
    V²/(4R_r) the current is V/(2R_r) and the SoC falls at that current (never NaN). A non-finite
    ``power`` raises RuntimeError.

    The discrete state is :data:`BatteryState`. The system keeps a copy of ``params``.

    .. pydrake_system::

        name: Battery
        input_ports:
        - power
        output_ports:
        - soc
        - current
        - power_budget
        - brownout
        - state
    """

    def __init__(self, params: BatteryParams, *, time_step: float):
        super().__init__()
        params.Validate("battery")
        h = float(time_step) if isinstance(time_step, (int, float)) else math.nan
        if not (math.isfinite(h) and h > 0.0):
            raise ValueError(f"time_step: must be a finite number > 0 [s], got {time_step!r}")
        self._params = copy.deepcopy(params)
        self._model = AsBatteryModel(UsablePack(self._params))
        self._time_step = h
        self._faults = sorted(self._params.faults, key=lambda f: f.time)
        self._fault_times = [float(f.time) - 1e-9 for f in self._faults]

        self._power_port = self.DeclareVectorInputPort("power", 1)
        x0 = BatteryState.Zero()
        x0.soc = float(params.initial_soc)
        self._state_index = self.DeclareDiscreteState(x0[:])
        self.DeclarePeriodicDiscreteUpdateEvent(h, 0.0, self._Update)
        state_only = {self.xd_ticket()}
        from_input = {self._power_port.ticket()}
        self._soc_port = self.DeclareVectorOutputPort(
            "soc", 1, self._CalcSoc, prerequisites_of_calc=state_only
        )
        self._current_port = self.DeclareVectorOutputPort(
            "current", 1, self._CalcCurrent, prerequisites_of_calc=from_input
        )
        self._power_budget_port = self.DeclareVectorOutputPort(
            "power_budget", 1, self._CalcPowerBudget, prerequisites_of_calc=state_only
        )
        self._brownout_port = self.DeclareVectorOutputPort(
            "brownout", 1, self._CalcBrownout, prerequisites_of_calc=from_input
        )
        self._state_port = self.DeclareStateOutputPort("state", self._state_index)

    @property
    def time_step(self) -> float:
        """Update period h [s]."""
        return self._time_step

    @property
    def params(self) -> BatteryParams:
        """The battery's own copy of its parameters."""
        return self._params

    @property
    def model(self) -> BatteryModel:
        """The battery model it steps (``params.model`` of the usable pack)."""
        return self._model

    # -- hot path ------------------------------------------------------------------------------

    def _Power(self, context) -> float:
        y = self._power_port.Eval(context).item(0)
        if not math.isfinite(y):
            raise RuntimeError(
                f"Battery: input 'power' is not finite ({y}) at t = {context.get_time()}"
            )
        if y < 0.0:  # the pack is drained, never charged, in flight
            raise RuntimeError(
                f"Battery: input 'power' must be >= 0 W (a load), got {y:g} W at t = "
                f"{context.get_time()}"
            )
        return y

    def _Update(self, context, discrete_state):
        # Drake fills discrete_state with the context's values before this handler
        # (LeafSystem::DispatchDiscreteVariableUpdateHandler): one numpy view, read and written
        # in place, in the order of BatteryState (soc, held_power, next_fault).
        x = discrete_state.get_mutable_value()
        soc, held_power, next_fault = x.tolist()
        y = self._Power(context)
        b = self._model.SocAfter(soc, held_power, self._time_step)
        k = int(next_fault)
        if k < len(self._fault_times):
            t = context.get_time()
            while k < len(self._fault_times) and self._fault_times[k] <= t:
                b = max(b - self._faults[k].soc_drop, 0.0)
                k += 1
        x[0] = b
        x[1] = y
        x[2] = k
        if self._model.IsBrownout(y):
            return EventStatus.ReachedTermination(self, STATUS_BROWNOUT)
        if b <= self._params.reserve_soc:
            return EventStatus.ReachedTermination(self, STATUS_RESERVE)
        return None

    def _CalcSoc(self, context, output) -> None:
        output.SetAtIndex(0, context.get_discrete_state_vector().GetAtIndex(0))

    def _CalcPowerBudget(self, context, output) -> None:
        b = context.get_discrete_state_vector().GetAtIndex(0)
        output.SetAtIndex(0, self._model.PowerBudget(b))

    def _CalcCurrent(self, context, output) -> None:
        output.SetAtIndex(0, self._model.Current(self._Power(context)))

    def _CalcBrownout(self, context, output) -> None:
        brownout = self._model.IsBrownout(self._Power(context))
        output.SetAtIndex(0, 1.0 if brownout else 0.0)
