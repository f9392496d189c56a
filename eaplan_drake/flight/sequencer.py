"""Stage sequencer: the plan's finite-state machine (paper 003 Def. II.1–II.5) as a Drake system.

Every ``update_period`` the sequencer compares the aircraft's position p with the triggering point
p_Γ of the active stage and moves to the next stage when::

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
generated with that c1, at the airspeed in a constant wind: the scenario's (known), or, with a
``wind`` input (``wind_input``), the wind that input gave at the last stage switch (an estimate,
or the true mean wind), held in the ``priced_wind`` state and capped at
:data:`STAIRCASE_WIND_FRACTION` of the airspeed. It is the plan's staircase t(c1) from here
(whole repetitions), not the Eq. 10 line; the mpc planner decides on it.
``coverage_remaining`` is the planner's fraction [0, 1] of the survey still to fly: the rest of the
current stage plus the survey length of the remaining stages *as if flown at the reference c1 = c̄1*
(the finest coverage), over the survey length of the whole plan at c̄1. It does not jump when c1 is
re-planned (whole repetitions would make a ratio at the current c1 jump), and fraction · t(c1)
estimates the remaining time at any c1 (paper 003 Alg. 2 l. 25). It is the work left if c1 were
raised to c̄1, so it is *not* a completion measure: a plan flown below c̄1 ends, as Alg. 1 says,
after its last whole repetition that fits at the flown c1; the c̄1 plan may fit one or two more
repetitions from there (their shift is smaller), and the fraction still holds them when the survey
completes (0.068 at the end of the reference field flown at c1 = −1000: one c̄1 repetition of the
15). The paper planner reads this fraction and relies on that: a fraction that fell to 0 on the
last line would have it raise c1 there, which regrows the plan by those repetitions (plan i then
ends at the reserve instead of completing).

The fraction of the survey *of the plan being flown* still to fly is the ``survey`` element of the
``mode`` state (:meth:`StageSequencer.SurveyRemaining`): the rest of the current stage plus the
survey length of the stages after it at the current c1, over the survey length of the whole plan at
the current c1 (:meth:`~eaplan_drake.flight.coverage.PlanSource.RemainingFraction`). It falls to 0
exactly when the survey completes (before the completing update it is at most the trigger radius
plus one update's travel over the survey length), and it jumps by up to a repetition's share when a
re-plan changes the number of repetitions left. It is the number to report ("x % of the survey
left"); nothing in the loop reads it, so it changes no flight.

The update runs every ``update_period`` [s]. So that its event times coincide with the other
periodic events of a diagram (Drake computes sample times as k·period, and k·0.05 is not always
5k·0.01 in floating point: the integrator then takes an extra step of a few ulp), the event is
declared at the diagram's base period ``time_step`` (e.g. the sensor's 0.01 s) and the work is
done at every n-th tick, n = max(1, round(update_period / time_step)); the other ticks do nothing.
When the survey completes, the update returns ``EventStatus.ReachedTermination(self,
"complete")``: a ``Simulator`` stops there, without a monitor.

State (discrete groups): ``mode`` (namedview :data:`SequencerMode`: active stage index, c1, the
held remaining fraction (the planner's, at c̄1), the held share of the active stage still to fly
and the held survey fraction of the plan being flown), ``period`` (T [s]),
``complete`` (0/1), ``path`` (the active stage's path descriptor, the held ``path`` output),
``entries`` (last entry time into each primitive stage) and ``source`` (namedview
:data:`StageSource`: the stage after which the active one was generated, its anchor and the c1 it
was generated with; ``after_index`` −1 means the plan's first stage). The stage's geometry is not
state: it comes from the plan source (a pure, cached function of those numbers). ``path``,
``period`` and ``mission_complete`` are state output ports (read every step by the guidance, the
estimator and a monitor without a Python call), and so is ``mode`` (the :data:`SequencerMode`
group: ``stage`` and ``coverage_remaining`` are two of its elements, which the flight log reads
from it); the other outputs depend on the state only (no direct feedthrough). Ports: see
:class:`StageSequencer`.
"""

import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import EventStatus, LeafSystem

from eaplan_drake.flight.coverage import PlanSource
from eaplan_drake.flight.stages import (
    ANCHOR_SIZE,
    NUM_PRIMITIVES,
    PathLeft,
    Stage,
    StageTime,
    SurveyFraction,
)
from eaplan_drake.ticks import DeclareTickedDiscreteUpdateEvent

__all__ = [
    "STAIRCASE_WIND_FRACTION",
    "SequencerMode",
    "StageSequencer",
    "StageSource",
    "StaircaseWind",
    "Triggered",
    "UPDATE_PERIOD",
]

_SUCCEEDED = EventStatus.Succeeded()
"""The status of an update that did its work (one object, not one per call)."""

UPDATE_PERIOD = 0.05
"""Default period of the sequencer's trigger test [s] (the authors' simulator's)."""

STAIRCASE_WIND_FRACTION = 0.9
"""The largest wind a ``wind`` input prices the staircase in, as a fraction of the airspeed [-]
(a gust may briefly reach the airspeed, where no stage time exists)."""

SequencerMode = namedview("SequencerMode", ["stage", "c1", "remaining", "stage_left", "survey"])
"""The sequencer's ``mode`` state: active stage index, c1 [m²], remaining survey fraction at the
reference c1 = c̄1 (``coverage_remaining``, the planner's) [-], share of the active stage's path
still to fly [-], remaining survey fraction of the plan being flown (0 when complete) [-]."""
_STAGE, _C1, _REMAINING, _STAGE_LEFT, _SURVEY = range(len(SequencerMode._fields))

StageSource = namedview(
    "StageSource", ["after_index"] + [f"anchor_{i}" for i in range(ANCHOR_SIZE)] + ["c1"]
)
"""The sequencer's ``source`` state: the active stage is
``plan.StagesAfter(after_index, anchor, c1)[0]`` (``plan.Stages(c1)[0]`` when after_index < 0)."""


def Triggered(stage: Stage, position, epsilon: float) -> bool:
    """True when ``position`` p [m] triggers the switch after ``stage`` (module docstring):
    ‖p − p_Γ‖ < ε [m], or p has passed the normal line at p_Γ, (p − p_Γ)ᵀt̂_Γ ≥ 0, and on a
    circle also (p − o)ᵀ(p_Γ − o) > 0."""
    g = stage.geometry
    px, py = position[0], position[1]
    dx, dy = px - g.tx, py - g.ty
    if dx * dx + dy * dy < epsilon * epsilon:
        return True
    if dx * g.ux + dy * g.uy < 0.0:
        return False
    if g.is_circle:
        return (px - g.ox) * (g.tx - g.ox) + (py - g.oy) * (g.ty - g.oy) > 0.0
    return True


def StaircaseWind(wind, airspeed: float) -> tuple[float, float]:
    """The wind w [m/s] the staircase is priced in: ``wind`` scaled down to at most
    :data:`STAIRCASE_WIND_FRACTION` · v_a when it is faster; (0, 0) when it is not finite."""
    wx, wy = float(wind[0]), float(wind[1])
    speed = math.hypot(wx, wy)
    if not math.isfinite(speed):
        return 0.0, 0.0
    top = STAIRCASE_WIND_FRACTION * float(airspeed)
    if speed <= top:
        return wx, wy
    return wx * top / speed, wy * top / speed


class StageSequencer(LeafSystem):
    """Runs a plan: switches stages at the triggering points, re-plans on c1 changes, measures the
    period (paper 003 Def. II.1–II.5; see the module docstring for the equations).

    Args:
        plan: a :class:`~eaplan_drake.flight.coverage.PlanSource` (``ZamboniCoverage``,
            ``PlanFile``, ``StaticPlan``); its ``airspeed`` v_a [m/s] serves the
            ``remaining_time`` output.
        trigger_radius: ε [m], ≥ 0 (``CoverageParams.trigger_radius``).
        initial_period: first guess of the period T [s], > 0
            (``EnergyModelParams.initial_period``).
        wind: constant wind w [m/s] of the ``remaining_time`` output (with ``wind_input``, until
            the first stage switch).
        update_period: period of the trigger test [s], > 0.
        time_step: the diagram's base period [s] at which the event is declared (None: the
            update period); see the module docstring.
        initial_c1: the path parameter of the initial plan [m²] (None: ``plan.initial_c1``).
        path_parameter_grid: the c1 values [m²] of the ``remaining_time`` output (None: the
            initial c1 only).
        wind_input: declare the ``wind`` input port (2) [m/s] and price the staircase in the
            wind it gives at each stage switch (:func:`StaircaseWind`; held in the
            ``priced_wind`` state); False (default): the constant ``wind``.

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
        - mode
        - flown_path_parameter
    """

    def __init__(
        self,
        plan: PlanSource,
        *,
        trigger_radius: float,
        initial_period: float,
        wind,
        update_period: float = UPDATE_PERIOD,
        time_step: float | None = None,
        initial_c1: float | None = None,
        path_parameter_grid=None,
        wind_input: bool = False,
    ):
        super().__init__()
        if not isinstance(plan, PlanSource):
            raise TypeError(
                "StageSequencer.plan: expected a PlanSource (e.g. StaticPlan(stages, "
                f"airspeed=...)), got {type(plan).__name__}"
            )
        if time_step is None:
            time_step = update_period
        for name, value, ok in (
            ("update_period", update_period, lambda v: v > 0),
            ("time_step", time_step, lambda v: v > 0),
            ("trigger_radius", trigger_radius, lambda v: v >= 0),
            ("initial_period", initial_period, lambda v: v > 0),
        ):
            v = float(value) if isinstance(value, int | float) else math.nan
            if not (math.isfinite(v) and ok(v)):
                raise ValueError(f"StageSequencer.{name}: out of range, got {value!r}")
        self._plan = plan
        c1 = plan.initial_c1 if initial_c1 is None else initial_c1
        try:
            c1 = plan.CheckC1(c1)
        except ValueError as e:
            raise ValueError(f"StageSequencer.initial_c1: {e}") from None
        self._c1_lo, self._c1_hi = plan.c1_bounds
        self._epsilon = float(trigger_radius)
        self._num_primitives = int(getattr(plan, "num_primitives", NUM_PRIMITIVES))
        self._airspeed = float(plan.airspeed)
        self._wind = np.array(wind, dtype=float).reshape(2)
        self._rest_key, self._rest = None, None
        if not (np.all(np.isfinite(self._wind)) and math.hypot(*self._wind) < self._airspeed):
            raise ValueError(
                "StageSequencer.wind: need a finite wind below the plan's airspeed "
                f"{self._airspeed:g} m/s, got {wind!r}"
            )
        grid = [c1] if path_parameter_grid is None else path_parameter_grid
        self._grid = np.array(grid, dtype=float).reshape(-1)
        if self._grid.size < 1 or not np.all(np.isfinite(self._grid)):
            raise ValueError(
                f"StageSequencer.path_parameter_grid: need finite values, got {grid!r}"
            )
        self._time_step = float(time_step)
        self._DeclareState(c1, initial_period, update_period)
        self._DeclarePorts()
        self._wind_port, self._wind_index = None, None
        if wind_input:
            self._wind_port = self.DeclareVectorInputPort("wind", 2)
            self._wind_index = self.DeclareDiscreteState(self._wind.copy())

    def _DeclareState(self, c1: float, initial_period: float, update_period: float) -> None:
        """The discrete state at the plan's first stage flown at ``c1`` [m²], with the period
        guess [s], and the ticked update every ``update_period`` [s]."""
        # The remaining fraction is measured in survey lengths at the reference c1 = c̄1 (the
        # finest coverage), so that it does not jump when c1 is re-planned.
        self._c1_ref = self._c1_hi
        self._memo_key = None
        self._survey_memo_key = None
        self._total = self._plan.SurveyLength(self._c1_ref)
        first = self._plan.Stages(c1)[0]
        mode = SequencerMode(np.zeros(len(SequencerMode._fields)))
        mode.c1 = c1
        mode.stage = first.index
        mode.remaining = SurveyFraction(first, None, self._RestLength(first), self._total)
        mode.stage_left = 1.0
        mode.survey = SurveyFraction(first, None, *self._FlownLengths(first, c1))
        source = StageSource(np.zeros(len(StageSource._fields)))
        source.after_index = -1.0
        source.c1 = c1
        self._mode_index = self.DeclareDiscreteState(mode[:])
        self._period_index = self.DeclareDiscreteState([float(initial_period)])
        self._complete_index = self.DeclareDiscreteState([0.0])
        self._path_index = self.DeclareDiscreteState(first.descriptor.copy())
        self._entries_index = self.DeclareDiscreteState(np.full(self._num_primitives, -1.0))
        self._source_index = self.DeclareDiscreteState(source[:])
        ticks = max(1, round(float(update_period) / self._time_step))
        DeclareTickedDiscreteUpdateEvent(
            self, ticks * self._time_step, self._time_step, self._Update
        )

    def _DeclarePorts(self) -> None:
        """The input ports and the output ports, in the order of the class docstring."""
        self._position_port = self.DeclareVectorInputPort("position", 2)
        self._path_parameters_port = self.DeclareVectorInputPort("path_parameters", 1)
        xd = {self.xd_ticket()}

        def _Mode(field):
            i = SequencerMode._fields.index(field)

            def calc(context, output):
                output.SetAtIndex(0, context.get_discrete_state(self._mode_index).GetAtIndex(i))

            return calc

        self._path_port = self.DeclareStateOutputPort("path", self._path_index)
        self._stage_port = self.DeclareVectorOutputPort(
            "stage", 1, _Mode("stage"), prerequisites_of_calc=xd
        )
        self._period_port = self.DeclareStateOutputPort("period", self._period_index)
        self._coverage_remaining_port = self.DeclareVectorOutputPort(
            "coverage_remaining", 1, _Mode("remaining"), prerequisites_of_calc=xd
        )
        self._remaining_time_port = self.DeclareVectorOutputPort(
            "remaining_time", self._grid.size, self._CalcRemainingTime, prerequisites_of_calc=xd
        )
        self._mission_complete_port = self.DeclareStateOutputPort(
            "mission_complete", self._complete_index
        )
        self._mode_port = self.DeclareStateOutputPort("mode", self._mode_index)
        self._flown_c1_port = self.DeclareVectorOutputPort(
            "flown_path_parameter", 1, _Mode("c1"), prerequisites_of_calc=xd
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

    def PricedWind(self, context) -> np.ndarray:
        """The wind w [m/s] the ``remaining_time`` staircase is priced in now."""
        if self._wind_index is None:
            return self._wind.copy()
        return context.get_discrete_state(self._wind_index).CopyToVector()

    def EntryTimes(self, context) -> np.ndarray:
        """Last entry time [s] into each primitive stage (−1 = not yet)."""
        return context.get_discrete_state(self._entries_index).CopyToVector()

    def PathParameter(self, context) -> float:
        """The c1 the remaining plan is flown with [m²]."""
        return float(SequencerMode(context.get_discrete_state(self._mode_index).value()).c1)

    def ActiveStage(self, context) -> Stage:
        """The stage being flown (from the plan source, keyed by the ``source`` state)."""
        return self._StageOf(context.get_discrete_state(self._source_index).value())

    def SurveyRemaining(self, context) -> float:
        """Fraction [0, 1] of the survey of the plan being flown still to fly (the ``survey``
        element of ``mode``; 0 once the survey is complete). Unlike ``coverage_remaining`` (the
        planner's fraction at c̄1) it holds no repetition that the flown plan does not have."""
        return float(SequencerMode(context.get_discrete_state(self._mode_index).value()).survey)

    # -- internals -------------------------------------------------------------------------------

    def _StageOf(self, source) -> Stage:
        return self._ActiveOf(source)[0]

    def _ActiveOf(self, source) -> tuple[Stage, float]:
        """(stage, survey length [m] after it at the reference c1) for the ``source`` state: pure
        functions of the plan, memoised for the last source seen (it changes at stage switches
        only)."""
        key = tuple(source.tolist())  # Python floats: a cheap comparison at every update
        if key != self._memo_key:
            after = int(key[0])
            if after < 0:
                stage = self._plan.Stages(key[-1])[0]
            else:
                stage = self._plan.StagesAfter(after, key[1:-1], key[-1])[0]
            self._memo = (stage, self._RestLength(stage))
            self._memo_key = key
        return self._memo

    def _RestLength(self, stage: Stage) -> float:
        """Survey length [m] after ``stage`` if the rest were flown at the reference c1."""
        return self._plan.SurveyLengthAfter(stage.index, stage.anchor, self._c1_ref)

    def _FlownLengths(self, stage: Stage, c1: float) -> tuple[float, float]:
        """(survey length [m] after ``stage`` when the rest is flown with c1, survey length [m] of
        the whole plan at c1): memoised for the last (stage, c1) seen."""
        key = (stage.index, stage.anchor, c1)
        if key != self._survey_memo_key:
            plan = self._plan
            self._survey_memo = (
                plan.SurveyLengthAfter(stage.index, stage.anchor, c1),
                plan.SurveyLength(c1),
            )
            self._survey_memo_key = key
        return self._survey_memo

    def _CalcRemainingTime(self, context, output) -> None:
        mode = SequencerMode(context.get_discrete_state(self._mode_index).value())
        if context.get_discrete_state(self._complete_index).GetAtIndex(0) > 0.5:
            output.SetFromVector(np.zeros(self._grid.size))
            return
        source = context.get_discrete_state(self._source_index).value()
        stage = self._StageOf(source)
        key = tuple(source.tolist())
        w = self._wind
        if self._wind_index is not None:
            w = context.get_discrete_state(self._wind_index).value()
            key += tuple(w.tolist())
        if key != self._rest_key:  # the staircase after the active stage, once per stage
            plan, v = self._plan, self._airspeed
            rest = np.array(
                [plan.TimeAfter(stage.index, stage.anchor, c1, v, w) for c1 in self._grid]
            )
            self._rest_key, self._rest = key, (rest, StageTime(stage, v, w))
        rest, stage_time = self._rest
        output.SetFromVector(rest + mode.stage_left * stage_time)

    def _Update(self, context, discrete_state):
        # Drake fills discrete_state with the context's values before this handler
        # (LeafSystem::DispatchDiscreteVariableUpdateHandler): the groups are read and written in
        # place; entries, source, period and path change at stage switches only.
        if discrete_state.get_value(self._complete_index)[0] > 0.5:
            return EventStatus.ReachedTermination(self, "complete")
        mode = discrete_state.get_mutable_value(self._mode_index)
        source = discrete_state.get_mutable_value(self._source_index)
        stage, rest_length = self._ActiveOf(source)
        c1 = mode[_C1]
        p = self._position_port.Eval(context)
        px, py = float(p[0]), float(p[1])
        if self._path_parameters_port.HasValue(context):
            c1_in = float(self._path_parameters_port.Eval(context)[0])
            if math.isfinite(c1_in):
                c1_in = min(max(c1_in, self._c1_lo), self._c1_hi)
                if abs(c1_in - c1) > 1e-9:
                    c1 = c1_in
                    mode[_C1] = c1
        if not (math.isfinite(px) and math.isfinite(py)):
            return _SUCCEEDED
        complete = False
        if Triggered(stage, (px, py), self._epsilon):
            stage, complete = self._Switch(context, discrete_state, stage, (px, py), c1)
            rest_length = self._ActiveOf(source)[1]
        mode[_STAGE] = stage.index
        if complete:
            mode[_REMAINING] = 0.0
            mode[_SURVEY] = 0.0
        else:
            mode[_REMAINING] = SurveyFraction(stage, (px, py), rest_length, self._total)
            mode[_SURVEY] = SurveyFraction(stage, (px, py), *self._FlownLengths(stage, c1))
        length = stage.length
        mode[_STAGE_LEFT] = PathLeft(stage, (px, py)) / length if length > 0.0 else 0.0
        if complete:
            discrete_state.get_mutable_value(self._complete_index)[0] = 1.0
            return EventStatus.ReachedTermination(self, "complete")
        return _SUCCEEDED

    def _Switch(self, context, discrete_state, stage, position, c1) -> tuple[Stage, bool]:
        """Moves past every stage whose triggering point ``position`` has reached (several
        zero-length stages may fire at once): the new stage's source, path, entry time and the
        period (time between two entries into the same primitive) are written into
        ``discrete_state``. Returns (the active stage, whether the plan is complete)."""
        plan = self._plan
        source = discrete_state.get_mutable_value(self._source_index)
        entries = discrete_state.get_mutable_value(self._entries_index)
        period = discrete_state.get_mutable_value(self._period_index)
        t = context.get_time()
        complete = False
        for _ in range(8):
            if not Triggered(stage, position, self._epsilon):
                break
            if not plan.StagesAfter(stage.index, stage.anchor, c1):
                complete = True
                break
            source[:] = (stage.index, *stage.anchor, c1)
            stage = self._ActiveOf(source)[0]
            k = stage.primitive
            if 0 <= k < self._num_primitives:
                last = entries[k]
                if last >= 0.0 and t > last:
                    period[0] = t - last
                entries[k] = t
        discrete_state.set_value(self._path_index, stage.descriptor)
        if self._wind_port is not None and not complete:
            wind = StaircaseWind(self._wind_port.Eval(context), self._airspeed)
            discrete_state.set_value(self._wind_index, wind)
        return stage, complete
