"""Stage sequencer: the plan's finite-state machine (paper 003 Def. II.1–II.5) as a Drake system.

Every ``update_period`` the sequencer compares the aircraft's position p with the triggering point
p_Γ of the active stage and moves to the next stage when

    ‖p − p_Γ‖ < ε                       (Def. II.1), or
    (p − p_Γ)ᵀ t̂_Γ ≥ 0                  (p has passed the line through p_Γ normal to the path;
                                         t̂_Γ is the direction of travel at p_Γ)

where, on a circle, "passed" also requires p to be on p_Γ's side of the centre,
(p − o)ᵀ(p_Γ − o) > 0, i.e. within a quarter turn past p_Γ. So a trigger is never missed and the
aircraft never circles forever. The final stage's trigger completes the mission; the last path
stays active afterwards.

The period T [s] is the time between two entries into the same primitive stage (a configured first
guess until one has been measured). A change of ``path_parameters`` (c1, clipped into the plan's
range; NaN ignored) re-plans the stages after the active one (the active line or circle is kept).
``remaining_time`` [s] is the exact nominal time still to fly until the mission completes if the
rest of the plan is flown with c1, for each c1 of a grid c1_1 < … < c1_M: the time left on the
active stage (its share of the stage's time) plus the times of the stages that would follow,
generated with that c1, at the airspeed in the (constant, known) wind. It is the plan's staircase
t(c1) from here (whole repetitions), not the Eq. 10 line; the mpc planner decides on it.
``coverage_remaining`` is the fraction [0, 1] of the survey still to fly: the rest of the current
stage plus the survey length of the remaining stages *as if flown at the reference c1 = c̄1* (the
finest coverage), over the survey length of the whole plan at c̄1. It measures the area left, so it
does not jump when c1 is re-planned (whole repetitions would make a ratio at the current c1 jump),
and fraction · t(c1) estimates the remaining time at any c1 (paper 003 Alg. 2 l. 25).

All of it lives in one discrete state vector (stage index, c1, entry times, period, the active
stage's descriptor and trigger geometry, ...); the plan itself is a pure, cached function of
(stage, c1) held by the plan source, so the context is the whole state. Outputs depend on the state
only (no direct feedthrough). Ports: see :class:`StageSequencer`.
"""

import math

import numpy as np
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from .coverage import (
    ANCHOR_SIZE,
    APPROACH,
    NUM_PRIMITIVES,
    PlanSource,
    Stage,
    StageTime,
    StaticPlan,
)
from .paths import DESCRIPTOR_SIZE

__all__ = ["StageSequencer", "Triggered"]


def Triggered(stage: Stage, position, epsilon: float) -> bool:
    """True when ``position`` is within ε of the stage's triggering point or has passed it
    (pure-function form of the sequencer's test)."""
    p = np.asarray(position, dtype=float)
    pt = np.asarray(stage.trigger)
    if np.linalg.norm(p - pt) < epsilon:
        return True
    if float(np.dot(p - pt, stage.TriggerTangent())) < 0.0:
        return False
    if stage.is_circle:
        o = stage.path.center
        return float(np.dot(p - o, pt - o)) > 0.0
    return True


class _Layout:
    """Offsets into the discrete state vector."""

    def __init__(self, num_primitives: int, num_grid: int):
        names = [
            ("index", 1),
            ("c1", 1),
            ("complete", 1),
            ("period", 1),
            ("remaining", 1),
            ("entries", num_primitives),
            ("descriptor", DESCRIPTOR_SIZE),
            ("trigger", 2),
            ("tangent", 2),
            ("center", 2),
            ("is_circle", 1),
            ("radius", 1),
            ("ccw", 1),
            ("primitive", 1),
            ("length", 1),
            ("anchor", ANCHOR_SIZE),
            ("rest", 1),
            ("total", 1),
            ("stage_time", 1),
            ("stage_left", 1),
            ("rest_times", num_grid),
        ]
        vectors = {"entries", "descriptor", "trigger", "tangent", "center", "anchor", "rest_times"}
        offset = 0
        for name, size in names:
            vector = name in vectors or size != 1
            setattr(self, name, slice(offset, offset + size) if vector else offset)
            offset += size
        self.size = offset


class StageSequencer(LeafSystem):
    """Runs a plan: switches stages at the triggering points, re-plans on c1 changes, measures the
    period (paper 003 Def. II.1–II.5; see the module docstring for the equations).

    Args:
        plan: a :class:`~eaplan_drake.coverage.PlanSource` (e.g. ``ZamboniCoverage``,
            ``PlanFile``) or a sequence of :class:`~eaplan_drake.coverage.Stage` (static plan).
        initial_c1: the path parameter of the initial plan [m²] (default: ``plan.initial_c1``,
            else the upper bound).
        update_period: period of the discrete update [s], > 0.
        trigger_radius: ε [m], ≥ 0 (``CoverageParams.trigger_radius``).
        initial_period: first guess of the period T [s], > 0.
        airspeed: v_a [m/s] of the ``remaining_time`` output (default ``plan.airspeed``).
        wind: constant wind w [m/s] of the ``remaining_time`` output.
        path_parameter_grid: the c1 values [m²] of the ``remaining_time`` output (default: the
            plan's current c1 only).

    .. pydrake_system::

        name: StageSequencer
        input_ports:
        - position
        - path_parameters
        output_ports:
        - path
        - stage
        - period
        - coverage_remaining
        - remaining_time
        - mission_complete
    """

    def __init__(
        self,
        plan,
        *,
        initial_c1: float | None = None,
        update_period: float = 0.05,
        trigger_radius: float = 2.0,
        initial_period: float = 46.0,
        airspeed: float | None = None,
        wind=(0.0, 0.0),
        path_parameter_grid=None,
    ):
        super().__init__()
        if not isinstance(plan, PlanSource):
            plan = StaticPlan(plan)
        for name, value, ok in (
            ("update_period", update_period, update_period > 0),
            ("trigger_radius", trigger_radius, trigger_radius >= 0),
            ("initial_period", initial_period, initial_period > 0),
        ):
            if not (math.isfinite(value) and ok):
                raise ValueError(f"StageSequencer.{name}: out of range, got {value!r}")
        self._plan = plan
        if initial_c1 is None:
            initial_c1 = plan.initial_c1
        c1 = plan.c1_bounds[1] if initial_c1 is None else initial_c1
        try:
            c1 = plan.CheckC1(c1)
        except ValueError as e:
            raise ValueError(f"StageSequencer.initial_c1: {e}") from None
        self._c1_lo, self._c1_hi = plan.c1_bounds
        self._epsilon2 = float(trigger_radius) ** 2
        self._initial_period = float(initial_period)
        self._num_primitives = int(getattr(plan, "num_primitives", NUM_PRIMITIVES))
        self._airspeed = float(plan.airspeed if airspeed is None else airspeed)
        self._wind = np.asarray(wind, dtype=float).reshape(2)
        if not (
            math.isfinite(self._airspeed)
            and np.all(np.isfinite(self._wind))
            and math.hypot(*self._wind) < self._airspeed
        ):
            raise ValueError(
                "StageSequencer: need a finite airspeed above the wind speed, got "
                f"airspeed={airspeed!r}, wind={wind!r}"
            )
        grid = [c1] if path_parameter_grid is None else path_parameter_grid
        self._grid = np.asarray(grid, dtype=float).reshape(-1)
        if self._grid.size < 1 or not np.all(np.isfinite(self._grid)):
            raise ValueError(
                f"StageSequencer.path_parameter_grid: need finite values, got {grid!r}"
            )
        L = self._layout = _Layout(self._num_primitives, self._grid.size)

        stages = plan.Stages(c1)
        x0 = np.zeros(L.size)
        x0[L.c1] = c1
        x0[L.period] = initial_period
        x0[L.entries] = -1.0
        # The remaining fraction is measured in survey lengths at the reference c1 = c̄1 (the
        # finest coverage), so that it does not jump when c1 is re-planned.
        self._c1_ref = self._c1_hi
        self._LoadStage(x0, stages[0], plan.SurveyLength(self._c1_ref))
        x0[L.remaining] = self._Fraction(x0, None)
        self._state_index = self.DeclareDiscreteState(BasicVector(x0))
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=float(update_period), offset_sec=0.0, update=self._Update
        )

        self._position_port = self.DeclareVectorInputPort("position", 2)
        self._path_parameters_port = self.DeclareVectorInputPort("path_parameters", 1)
        xd = {self.xd_ticket()}

        def _Slice(sl, size):
            def calc(context, output):
                output.SetFromVector(context.get_discrete_state(self._state_index).value()[sl])

            return calc

        def _Scalar(i):
            def calc(context, output):
                output.SetAtIndex(0, context.get_discrete_state(self._state_index).GetAtIndex(i))

            return calc

        self._path_port = self.DeclareVectorOutputPort(
            "path", DESCRIPTOR_SIZE, _Slice(L.descriptor, DESCRIPTOR_SIZE), prerequisites_of_calc=xd
        )
        self._stage_port = self.DeclareVectorOutputPort(
            "stage", 1, _Scalar(L.index), prerequisites_of_calc=xd
        )
        self._period_port = self.DeclareVectorOutputPort(
            "period", 1, _Scalar(L.period), prerequisites_of_calc=xd
        )
        self._coverage_remaining_port = self.DeclareVectorOutputPort(
            "coverage_remaining", 1, _Scalar(L.remaining), prerequisites_of_calc=xd
        )
        self._remaining_time_port = self.DeclareVectorOutputPort(
            "remaining_time", self._grid.size, self._CalcRemainingTime, prerequisites_of_calc=xd
        )
        self._mission_complete_port = self.DeclareVectorOutputPort(
            "mission_complete", 1, _Scalar(L.complete), prerequisites_of_calc=xd
        )

    # -- accessors -------------------------------------------------------------------------------

    @property
    def plan(self) -> PlanSource:
        return self._plan

    def get_position_input_port(self):
        return self._position_port

    def get_path_parameters_input_port(self):
        return self._path_parameters_port

    def get_path_output_port(self):
        return self._path_port

    def get_stage_output_port(self):
        return self._stage_port

    def get_period_output_port(self):
        return self._period_port

    def get_coverage_remaining_output_port(self):
        return self._coverage_remaining_port

    def get_remaining_time_output_port(self):
        return self._remaining_time_port

    @property
    def path_parameter_grid(self) -> np.ndarray:
        """The c1 values [m²] of the ``remaining_time`` output."""
        return self._grid.copy()

    def get_mission_complete_output_port(self):
        return self._mission_complete_port

    def EntryTimes(self, context) -> np.ndarray:
        """Last entry time [s] into each primitive stage (−1 = not yet)."""
        return context.get_discrete_state(self._state_index).value()[self._layout.entries].copy()

    def PathParameter(self, context) -> float:
        """The c1 the remaining plan is flown with [m²]."""
        return float(context.get_discrete_state(self._state_index).GetAtIndex(self._layout.c1))

    # -- internals -------------------------------------------------------------------------------

    def _RestLength(self, stage: Stage) -> float:
        """Survey length [m] after ``stage`` if the rest were flown at the reference c1."""
        rest = self._plan.StagesAfter(stage.index, tuple(stage.anchor), self._c1_ref)
        return float(sum(s.length for s in rest if s.primitive != APPROACH))

    def _LoadStage(self, x, stage: Stage, total: float) -> None:
        L = self._layout
        x[L.index] = stage.index
        x[L.descriptor] = stage.path.descriptor()
        x[L.trigger] = stage.trigger
        x[L.tangent] = stage.TriggerTangent()
        if stage.is_circle:
            o = stage.path.center
            x[L.center] = o
            x[L.is_circle] = 1.0
            x[L.radius] = stage.path.radius
            x[L.ccw] = 1.0 if (stage.path.s < 0) == (stage.path.a > 0) else 0.0
        else:
            x[L.center] = 0.0
            x[L.is_circle] = 0.0
            x[L.radius] = 0.0
            x[L.ccw] = 0.0
        x[L.primitive] = stage.primitive
        x[L.length] = stage.length
        x[L.anchor] = stage.anchor
        x[L.rest] = self._RestLength(stage)
        x[L.total] = total
        x[L.stage_time] = StageTime(stage, self._airspeed, self._wind)
        x[L.stage_left] = 1.0
        x[L.rest_times] = [
            self._plan.TimeAfter(stage.index, stage.anchor, c1, self._airspeed, self._wind)
            for c1 in self._grid
        ]

    def _CalcRemainingTime(self, context, output) -> None:
        L = self._layout
        x = context.get_discrete_state(self._state_index).get_value()
        if x[L.complete] > 0.5:
            output.SetFromVector(np.zeros(self._grid.size))
        else:
            output.SetFromVector(x[L.rest_times] + x[L.stage_left] * x[L.stage_time])

    def _StageLeft(self, x, p) -> float:
        """Path length [m] left on the active stage from position p (all of it if None)."""
        L = self._layout
        length = x[L.length]
        if p is None:
            return length
        if x[L.is_circle] > 0.5:
            ox, oy = x[L.center]
            tx, ty = x[L.trigger]
            a_p = math.atan2(p[1] - oy, p[0] - ox)
            a_t = math.atan2(ty - oy, tx - ox)
            d = (a_t - a_p) if x[L.ccw] > 0.5 else (a_p - a_t)
            return min(length, x[L.radius] * (d % (2.0 * math.pi)))
        tx, ty = x[L.trigger]
        ux, uy = x[L.tangent]
        return min(length, max(0.0, (tx - p[0]) * ux + (ty - p[1]) * uy))

    def _Fraction(self, x, p) -> float:
        """Survey fraction still to fly from position p (entry of the stage if None)."""
        L = self._layout
        if x[L.complete] > 0.5:
            return 0.0
        total = x[L.total]
        if total <= 0.0:
            return 0.0
        here = 0.0 if x[L.primitive] == APPROACH else self._StageLeft(x, p)
        return min(1.0, max(0.0, (x[L.rest] + here) / total))

    def _Triggered(self, x, px: float, py: float) -> bool:
        L = self._layout
        tx, ty = x[L.trigger]
        dx, dy = px - tx, py - ty
        if dx * dx + dy * dy < self._epsilon2:
            return True
        ux, uy = x[L.tangent]
        if dx * ux + dy * uy < 0.0:
            return False
        if x[L.is_circle] > 0.5:
            ox, oy = x[L.center]
            return (px - ox) * (tx - ox) + (py - oy) * (ty - oy) > 0.0
        return True

    def _Update(self, context, discrete_state):
        L = self._layout
        x = context.get_discrete_state(self._state_index).CopyToVector()
        if x[L.complete] > 0.5:
            return
        p = self._position_port.Eval(context)
        px, py = float(p[0]), float(p[1])
        plan = self._plan
        c1 = x[L.c1]
        index = int(x[L.index])
        if self._path_parameters_port.HasValue(context):
            c1_in = float(self._path_parameters_port.Eval(context)[0])
            if math.isfinite(c1_in):
                c1_in = min(max(c1_in, self._c1_lo), self._c1_hi)
                if abs(c1_in - c1) > 1e-9:
                    c1 = c1_in
                    x[L.c1] = c1
        if math.isfinite(px) and math.isfinite(py):
            t = context.get_time()
            for _ in range(8):  # several zero-length stages may fire at once
                if not self._Triggered(x, px, py):
                    break
                rest = plan.StagesAfter(index, tuple(x[L.anchor]), c1)
                if not rest:
                    x[L.complete] = 1.0
                    break
                self._LoadStage(x, rest[0], x[L.total])
                index = rest[0].index
                k = rest[0].primitive
                if 0 <= k < self._num_primitives:
                    last = x[L.entries.start + k]
                    if last >= 0.0 and t > last:
                        x[L.period] = t - last
                    x[L.entries.start + k] = t
            x[L.remaining] = self._Fraction(x, (px, py))
            length = x[L.length]
            x[L.stage_left] = self._StageLeft(x, (px, py)) / length if length > 0.0 else 0.0
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(x)
        if x[L.complete] > 0.5:
            return EventStatus.ReachedTermination(self, "complete")
