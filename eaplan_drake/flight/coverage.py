"""Zamboni-like coverage plan of a convex polygon (paper 003 Sec. IV-A, Alg. 1, Eqs. 10, 14–15).

A *plan* is a sequence of stages (:class:`~eaplan_drake.flight.stages.Stage`, whose module
measures them): a normalised path function φ (line or circle, with its direction of travel s and
field gain k_e), the triggering point p_Γ where the next stage starts, and the index of the
primitive stage it repeats. After an *approach* stage (primitive −1: a circle of radius r2 that
brings the aircraft onto the first line) the plan repeats four primitive stages

    0  first line ("down"-line), travelling along e1,
    1  left (counter-clockwise) half circle of radius r1 = r + x_d/2,
    2  second line ("up"-line) at 2 r1 from the first, travelling along −e1,
    3  left half circle of radius r2(c1) = sqrt(r² + c1)                        (Eq. 14)

so each repetition moves the lines by the shift d = 2 r1 − 2 r2(c1) [m] (x_d at c1 = 0; c1 < 0
widens the spacing, fewer lines, shorter flight). c1 ∈ [r_min² − r², 0] keeps r2 ≥ r_min.
The survey ends at the end of the last second line that fits in the polygon.

Geometry (the polygon: :class:`~eaplan_drake.flight.polygon.CoveragePolygon`). Lines are
parallel to the chosen polygon edge (v_i, v_{i+1}) (``line_edge``). With n the unit normal of
that edge pointing into the polygon, the local frame is e2 = n (the sweep direction) and e1 = n
rotated by −90° (right-handed, so left turns in the local frame are left turns in the world).
Line k sits at the offset η from the edge: the first line at x_d/2. A line runs over the
polygon's extent of its swath band [η − x_d/2, η + x_d/2]; the two lines joined by a half circle
end at the same ξ (the farther of the two extents: the aircraft may overfly the boundary), so
every turn is tangent to both of its lines. For the reference rectangle
(:ref:`design-reference-scenario`; edge 0 = the left side x = −120) this gives the first line
x = −115 from (−115, 146) to (−115, 11), the r1 turn to the line x = 35, and so on, as in the
authors' plan file (without their 1 m drift of y per repetition).

Re-planning (:meth:`PlanSource.Replan`) keeps every stage up to the current one and regenerates
the later ones with the new c1: a line or circle being flown never moves. The coverage time
t(c1) is the sum of the stage times at airspeed v_a (optionally in a constant wind w: ground speed
v_g = wᵀt̂ + sqrt(v_a² − (w × t̂)²) along the course t̂), and the path scaling factors of Eq. 10
are the linear fit ν c1 + τ through (c̲1, t(c̲1)) and (c̄1, t(c̄1)) (ρ = 1).

The remaining survey *fraction* (:meth:`PlanSource.RemainingFraction`, the sequencer's
:meth:`~eaplan_drake.flight.sequencer.StageSequencer.SurveyRemaining`) is the survey length still
to fly divided by the survey length of the whole plan at the current c1 (the approach excluded):
it falls from 1 to 0 along a flight, exactly 0 at the last trigger, and fraction · t(c1)
estimates the remaining time at any c1 because both numerator and denominator scale alike with
the line spacing (paper 003 Alg. 2 l. 25). The sequencer's ``coverage_remaining`` (the planner's
input) is the same ratio with the rest and the whole plan taken at c̄1 instead: it does not jump on
re-plans, but at the end of a plan flown below c̄1 it still holds the repetitions that the c̄1 plan
would fit after the flown plan's last one (the number of repetitions is whole at each c1).

What a completed plan covers (``tests/test_coverage_completion.py``): with swaths of half the widest
line spacing flown, d/2, the lines cover the polygon from its near edge to the last second line's
swath, but for small corners at slanted edges between coarse lines (a line spans the polygon over
its own x_d band only). Beyond the last second line a strip at the far edge is left when the next
repetition did not fit, narrower than d/2 + x_d/2: 2 % of the reference field at c1 = −1000, none at
c1 = 0 (15 repetitions land on W − x_d/2). The first lines meet the second lines (the middle of the
field is swept) only when the field is about 4 r1 wide across the lines or wider (the reference
field: exactly 4 r1 = 300 m); a narrower field passes :func:`CheckCoverageGeometry` (which needs 2
r1 + x_d) and is left unswept between the last first line and the first second line.
"""

import copy
import functools
import math
import typing

import numpy as np

from eaplan_drake.flight.paths import Circle, Line
from eaplan_drake.flight.polygon import CoveragePolygon
from eaplan_drake.flight.stages import (
    APPROACH,
    NUM_PRIMITIVES,
    ArcAngle,
    ArcStart,
    ArcStartTime,
    CheckedWind,
    LineSpeed,
    MakeStage,
    Stage,
    StageTime,
    SurveyFraction,
    TurningRadius2,
)

if typing.TYPE_CHECKING:  # no import at run time: params imports this module to validate
    from eaplan_drake.params import CoverageParams

__all__ = [
    "PlanSource",
    "StaticPlan",
    "ZamboniCoverage",
    "CheckCoverageGeometry",
    "CoverageTime",
    "FlownStages",
    "MakeCoveragePlan",
    "MakeZamboniPlanSource",
    "ScalingFactors",
]


def _Memoized(maxsize: int):
    """Caches a pure method per instance (LRU of ``maxsize`` entries, positional hashable
    arguments). The cache lives in the instance's ``__dict__`` under ``_memo_<name>`` and is left
    out when the instance is pickled or copied (:meth:`PlanSource.__getstate__`)."""

    def decorate(method):
        key = "_memo_" + method.__name__

        @functools.wraps(method)
        def wrapper(self, *args):
            cached = self.__dict__.get(key)
            if cached is None:
                cached = functools.lru_cache(maxsize)(functools.partial(method, self))
                self.__dict__[key] = cached
            return cached(*args)

        return wrapper

    return decorate


class PlanSource:
    """A plan as a function of the path parameter c1: the stages at c1, and the stages after a
    given stage when c1 changes in flight. Subclasses call ``PlanSource.__init__`` and implement
    ``_Stages`` and ``_StagesAfter``; the public methods cache their results per argument
    (the methods are pure). A plan pickles as its definition (the caches are left out).

    Args:
        c1_bounds: admissible [c̲1, c̄1] [m²].
        initial_c1: c1 of the initial plan [m²]; the sequencer starts with it.
        airspeed: v_a [m/s] the plan is flown at (:meth:`CoverageTimeBounds`, the sequencer's
            remaining time).
    """

    def __init__(self, c1_bounds, *, initial_c1: float, airspeed: float):
        name = type(self).__name__
        try:
            lo, hi = (float(v) for v in c1_bounds)
        except (TypeError, ValueError):
            raise ValueError(
                f"{name}.c1_bounds: need two numbers [m²], got {c1_bounds!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f"{name}.c1_bounds: need finite lower <= upper, got {c1_bounds!r}")
        self.c1_bounds = (lo, hi)
        v = float(airspeed) if isinstance(airspeed, int | float) else math.nan
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"{name}.airspeed: must be a finite number > 0 m/s, got {airspeed!r}")
        self.airspeed = v
        try:
            self.initial_c1 = self.CheckC1(float(initial_c1))
        except (TypeError, ValueError) as e:
            raise ValueError(f"{name}.initial_c1: {e}") from None

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_memo_")}

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        """The whole plan at c1 (c1 already checked)."""
        raise NotImplementedError

    def _StagesAfter(self, index: int, anchor: tuple[float, ...], c1: float) -> tuple[Stage, ...]:
        """The stages after stage ``index`` with ``anchor`` at c1 (arguments already checked)."""
        raise NotImplementedError

    def Stages(self, c1: float) -> tuple[Stage, ...]:
        """The whole plan at c1."""
        return self._CachedStages(self.CheckC1(c1))

    def StagesAfter(self, index: int, anchor: tuple[float, ...], c1: float) -> tuple[Stage, ...]:
        """The stages that follow stage ``index`` (with its ``anchor``) when the rest of the plan
        is flown with c1; the stage itself is kept as it is."""
        return self._CachedStagesAfter(
            int(index), tuple(float(a) for a in anchor), self.CheckC1(c1)
        )

    @_Memoized(64)
    def _CachedStages(self, c1: float) -> tuple[Stage, ...]:
        return tuple(self._Stages(c1))

    @_Memoized(512)
    def _CachedStagesAfter(self, index: int, anchor: tuple, c1: float) -> tuple[Stage, ...]:
        return tuple(self._StagesAfter(index, anchor, c1))

    # -- derived ---------------------------------------------------------------------------------

    def CheckC1(self, c1: float) -> float:
        """c1 within ``c1_bounds`` (1e-6 tolerance, then clipped); ValueError otherwise."""
        lo, hi = self.c1_bounds
        if not math.isfinite(c1) or c1 < lo - 1e-6 or c1 > hi + 1e-6:
            raise ValueError(f"path parameter c1 must be in [{lo:g}, {hi:g}] m², got {c1!r}")
        return min(max(float(c1), lo), hi)

    def Replan(self, stages, index: int, c1: float) -> tuple[Stage, ...]:
        """``stages[:index + 1]`` kept, the later ones regenerated with c1 (paper 003 Sec. IV)."""
        c1 = self.CheckC1(c1)
        current = stages[index]
        return tuple(stages[: index + 1]) + self.StagesAfter(index, current.anchor, c1)

    def SurveyLength(self, c1: float) -> float:
        """Length [m] of the survey stages (approach excluded) of the plan at c1."""
        return _SurveyLength(self.Stages(self.CheckC1(c1)))

    def CoverageTime(
        self, c1: float, airspeed: float, wind=(0.0, 0.0), include_approach: bool = True
    ) -> float:
        """t(c1) [s]: time to fly the whole plan at c1 at ``airspeed`` in constant ``wind``."""
        stages = self.Stages(self.CheckC1(c1))
        return sum(
            StageTime(s, airspeed, wind)
            for s in stages
            if include_approach or s.primitive != APPROACH
        )

    def TimeAfter(
        self, index: int, anchor: tuple[float, ...], c1: float, airspeed: float, wind=(0.0, 0.0)
    ) -> float:
        """Exact nominal time [s] to fly every stage after stage ``index`` (with its ``anchor``)
        when the rest of the plan is flown with c1, at ``airspeed`` [m/s] in constant ``wind``
        [m/s]: the staircase t(c1) of whole repetitions, not the Eq. 10 line."""
        c1 = min(max(float(c1), self.c1_bounds[0]), self.c1_bounds[1])
        w = np.asarray(wind, dtype=float).reshape(2)
        key = (int(index), tuple(float(a) for a in anchor), c1, float(airspeed))
        return self._CachedTimeAfter(*key, (float(w[0]), float(w[1])))

    @_Memoized(1024)
    def _CachedTimeAfter(self, index, anchor, c1, airspeed, wind) -> float:
        return float(sum(self._StageTimesAfter(index, anchor, c1, airspeed, wind)))

    def _StageTimesAfter(self, index, anchor, c1, airspeed, wind) -> tuple[float, ...]:
        """StageTime [s] of each stage after stage ``index``, in order (arguments checked); a
        subclass may share them between stages whose rests are suffixes of one another."""
        w = np.array(wind)
        return tuple(StageTime(s, airspeed, w) for s in self.StagesAfter(index, anchor, c1))

    def SurveyLengthAfter(self, index: int, anchor: tuple[float, ...], c1: float) -> float:
        """Survey length [m] of the stages after stage ``index`` (with its ``anchor``) when the
        rest of the plan is flown with c1 (approach excluded)."""
        return self._CachedSurveyLengthAfter(
            int(index), tuple(float(a) for a in anchor), self.CheckC1(c1)
        )

    @_Memoized(512)
    def _CachedSurveyLengthAfter(self, index, anchor, c1) -> float:
        return _SurveyLength(self.StagesAfter(index, anchor, c1))

    def CoverageTimeBounds(
        self, c1_bounds=None, airspeed: float | None = None, wind=(0.0, 0.0)
    ) -> tuple[float, float]:
        """(t(c̲1), t(c̄1)) [s] at ``airspeed`` (default ``airspeed``), approach included:
        the two end points of the linear coverage-time model of Eq. 10."""
        lo, hi = self.c1_bounds if c1_bounds is None else c1_bounds
        v = self.airspeed if airspeed is None else airspeed
        return (self.CoverageTime(lo, v, wind), self.CoverageTime(hi, v, wind))

    def ScalingFactors(
        self, airspeed: float, c1_bounds=None, wind=(0.0, 0.0), include_approach: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """ν, τ of paper 003 Eq. 10 (ρ = 1): t(c1) ≈ ν c1 + τ through both bounds."""
        lo, hi = self.c1_bounds if c1_bounds is None else c1_bounds
        t_lo = self.CoverageTime(lo, airspeed, wind, include_approach)
        t_hi = self.CoverageTime(hi, airspeed, wind, include_approach)
        return ScalingFactors((lo, hi), (t_lo, t_hi))

    def RemainingFraction(self, stages, index: int, position=None, c1=None) -> float:
        """Fraction [0, 1] of the survey still to fly: the survey length after the point
        ``position`` on stage ``index`` (its entry when None) over the survey length of the whole
        plan at c1 (default: the c1 of the last stage, i.e. the one the rest is flown with). The
        sequencer's ``survey`` fraction for ``stages`` as flown; with the plan at c̄1 and c1 = c̄1,
        its ``coverage_remaining``."""
        c1 = stages[-1].c1 if c1 is None else c1
        return SurveyFraction(
            stages[index], position, _SurveyLength(stages[index + 1 :]), self.SurveyLength(c1)
        )


def FlownStages(plan: PlanSource, stage_index, flown_c1) -> tuple[Stage, ...]:
    """The stages a flight flew, in order, from its log: the ``stage`` index and the
    ``flown_path_parameter`` c1 [m²] the sequencer held at each sample. The first stage is
    ``plan.Stages(c1)[0]`` at the first sample's c1; at each later index the sequencer's switches
    are replayed, ``plan.StagesAfter(stage, c1)[0]`` at the c1 of the sample that shows the new
    index (the log samples much faster than stages switch). ValueError when the log does not fit
    the plan (an index that goes back, or beyond the plan's last stage)."""
    index = np.asarray(stage_index, dtype=float).reshape(-1)
    c1 = np.asarray(flown_c1, dtype=float).reshape(-1)
    if index.size == 0 or index.size != c1.size:
        raise ValueError(
            f"flown stages: need as many c1 samples as stage samples (> 0), got {c1.size} and "
            f"{index.size}"
        )
    changes = np.flatnonzero(np.diff(index)) + 1
    stage = plan.Stages(float(c1[0]))[0]
    flown = [stage]
    if int(index[0]) != stage.index:
        first = int(index[0])
        raise ValueError(f"flown stages: the log starts at stage {first}, not {stage.index}")
    for k in changes:
        target, previous = int(index[k]), stage.index
        while stage.index < target:
            rest = plan.StagesAfter(stage.index, stage.anchor, float(c1[k]))
            if not rest:
                raise ValueError(f"flown stages: stage {target} is beyond the plan's last stage")
            stage = rest[0]
            flown.append(stage)
        if stage.index != target:
            raise ValueError(
                f"flown stages: the log goes from stage {previous} to {target}, which the plan "
                "does not have"
            )
    return tuple(flown)


def _LineTime(length: float, speed: float) -> float:
    """StageTime [s] of a line of ``length`` [m] flown at the ground speed ``speed`` [m/s]."""
    return 0.0 if length <= 0.0 else length / speed


def _SurveyLength(stages) -> float:
    return float(sum(s.length for s in stages if s.primitive != APPROACH))


def ScalingFactors(c1_bounds, times) -> tuple[np.ndarray, np.ndarray]:
    """Paper 003 Eq. 10 with ρ = 1: ν = (t̄ − t̲)/(c̄ − c̲), τ = c̲ (t̲ − t̄)/(c̄ − c̲) + t̲, so
    that t(c1) ≈ ν c1 + τ [s]. Returns 1-element arrays (one per path parameter)."""
    lo, hi = (float(v) for v in c1_bounds)
    t_lo, t_hi = (float(v) for v in times)
    if not hi > lo:
        raise ValueError(f"ScalingFactors: c1 bounds must satisfy lower < upper, got {c1_bounds}")
    nu = (t_hi - t_lo) / (hi - lo)
    tau = lo * (t_lo - t_hi) / (hi - lo) + t_lo
    return np.array([nu]), np.array([tau])


class StaticPlan(PlanSource):
    """A fixed list of stages (re-planning changes nothing), flown at ``airspeed`` [m/s]."""

    def __init__(self, stages, *, airspeed: float):
        stages = tuple(stages)
        if not stages:
            raise ValueError("StaticPlan: needs at least one stage")
        self._stages = stages
        c1 = stages[0].c1
        super().__init__((c1, c1), initial_c1=c1, airspeed=airspeed)

    def CheckC1(self, c1: float) -> float:
        return self.c1_bounds[0]

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        return self._stages

    def _StagesAfter(self, index, anchor, c1) -> tuple[Stage, ...]:
        return self._stages[int(index) + 1 :]


# -- Alg. 1 -------------------------------------------------------------------------------------


def CheckCoverageGeometry(params: "CoverageParams", key: str = "coverage") -> CoveragePolygon:
    """Checks the geometry of a Zamboni-like survey (positive x_d, r, r_min with r_min ≤ r; a
    convex, non-degenerate polygon; a line edge on its boundary; room for one repetition,
    width ≥ 2 r1 + x_d) and returns the polygon; ValueError naming ``key.<field>`` otherwise."""
    for name in ("swath_spacing", "turning_radius", "min_turning_radius"):
        v = getattr(params, name)
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{key}.{name}: must be a finite number > 0 m, got {v!r}")
    r, r_min, x_d = (
        float(params.turning_radius),
        float(params.min_turning_radius),
        float(params.swath_spacing),
    )
    if r_min > r:
        raise ValueError(
            f"{key}.min_turning_radius: r_min = {r_min:g} m must be <= turning_radius r = {r:g} m"
        )
    polygon = CoveragePolygon(params.polygon, params.line_edge, key)
    r1 = r + x_d / 2.0
    need = 2.0 * r1 + x_d
    if polygon.width < need - 1e-9:
        raise ValueError(
            f"{key}.polygon: too small for one repetition: its width across the lines "
            f"(normal to edge {params.line_edge}) is {polygon.width:g} m, the Zamboni-like motion "
            f"needs >= 2 r1 + x_d = {need:g} m (r1 = r + x_d/2 = {r1:g} m)"
        )
    return polygon


class ZamboniCoverage(PlanSource):
    """The Zamboni-like coverage plan of paper 003 Alg. 1 as a function of c1 (see module doc).

    Args:
        params: the survey's :class:`~eaplan_drake.params.CoverageParams` (copied).
        start: the aircraft's start position [m] (it sets the approach stage's length).
        airspeed: v_a [m/s] the plan is flown at.
        initial_c1: c1 of the initial plan [m²], in [r_min² − r², 0].
        k_e: the field gain put into every path descriptor [1/m].
    """

    def __init__(self, params: "CoverageParams", *, start, airspeed: float, initial_c1, k_e):
        key = "coverage"
        self.polygon = CheckCoverageGeometry(params, key)
        self.params = copy.deepcopy(params)
        self.r = float(params.turning_radius)
        self.r_min = float(params.min_turning_radius)
        self.x_d = float(params.swath_spacing)
        self.r1 = self.r + self.x_d / 2.0
        self.k_e = float(k_e) if isinstance(k_e, int | float) else math.nan
        if not (math.isfinite(self.k_e) and self.k_e > 0):
            raise ValueError(f"ZamboniCoverage.k_e: must be > 0 1/m, got {k_e!r}")
        self.start = np.array(start, dtype=float).reshape(2)
        if not np.all(np.isfinite(self.start)):
            raise ValueError(f"ZamboniCoverage.start: must be a finite [x, y] in m, got {start!r}")
        self._last_eta = self.polygon.width - self.x_d / 2.0
        super().__init__((self.r_min**2 - self.r**2, 0.0), initial_c1=initial_c1, airspeed=airspeed)

    # -- geometry helpers --------------------------------------------------------------------------

    def Shift(self, c1: float) -> float:
        """d = 2 r1 − 2 r2(c1) [m], the distance between repetitions."""
        return 2.0 * self.r1 - 2.0 * TurningRadius2(self.CheckC1(c1), self.r)

    def _Fits(self, eta_d: float) -> bool:
        return eta_d + 2.0 * self.r1 <= self._last_eta + 1e-9

    def _Reps(self, k: int, eta_d: float, c1: float, fixed_r2=None) -> list:
        """Repetitions (k, η_d, r2 or None for the last, c1) from rep k at η_d until the last
        second line that fits."""
        reps = []
        r2c = TurningRadius2(c1, self.r)
        while True:
            r2 = fixed_r2 if (fixed_r2 is not None and not reps) else r2c
            nxt = eta_d + 2.0 * self.r1 - 2.0 * r2
            if self._Fits(nxt):
                reps.append((k, eta_d, r2, c1))
                eta_d, k = nxt, k + 1
            else:
                reps.append((k, eta_d, None, c1))
                return reps
            if len(reps) > 100000:  # unreachable: the shift is >= 2 r1 − 2 r > 0
                raise RuntimeError("ZamboniCoverage: too many repetitions")

    def _Build(self, reps: list, prev_eta_u) -> list[Stage]:
        """Stages of the repetitions ``reps``; ``prev_eta_u`` is the second line before them."""
        stages: list[Stage] = []
        for k, eta_d, r2, c1 in reps:
            stages.extend(self._RepStages(k, eta_d, r2, c1, prev_eta_u))
            prev_eta_u = eta_d + 2.0 * self.r1
        return stages

    @_Memoized(4096)
    def _RepStages(self, k: int, eta_d: float, r2, c1: float, prev_eta_u) -> tuple[Stage, ...]:
        """The stages of repetition k with its first line at η_d [m] (r2 [m] of its second circle,
        None for the last), after the second line at ``prev_eta_u`` [m] (None: the first). The
        rest rebuilt at a stage switch shares every repetition but its first with the rest built
        at the switch before, so each is built once."""
        poly, k_e = self.polygon, self.k_e
        top_d, bottom, top_u, eta_u = self._RepGeometry(eta_d, r2, prev_eta_u)
        W = poly.ToWorld
        p_top_d = W(top_d, eta_d)
        p_bot_d = W(bottom, eta_d)
        p_bot_u = W(bottom, eta_u)
        p_top_u = W(top_u, eta_u)
        anchor_r2 = 0.0 if r2 is None else r2
        base = 1 + NUM_PRIMITIVES * k
        line_d = Line(p_top_d, poly.e2, s=1.0, k_e=k_e)  # travels along e1
        circle1 = Circle(W(bottom, eta_d + self.r1), self.r1, s=-1.0, k_e=k_e)
        line_u = Line(p_top_u, poly.e2, s=-1.0, k_e=k_e)  # travels along −e1
        items = [
            (line_d, p_bot_d, 0, p_top_d, bottom - top_d),
            (circle1, p_bot_u, 1, p_bot_d, math.pi * self.r1),
            (line_u, p_top_u, 2, p_bot_u, bottom - top_u),
        ]
        if r2 is not None:
            circle2 = Circle(W(top_u, eta_u - r2), r2, s=-1.0, k_e=k_e)
            items.append((circle2, W(top_u, eta_u - 2.0 * r2), 3, p_top_u, math.pi * r2))
        return tuple(
            MakeStage(base + prim, path, trig, prim, c1, entry, length, (k, prim, eta_d, anchor_r2))
            for path, trig, prim, entry, length in items
        )

    def _RepGeometry(self, eta_d: float, r2, prev_eta_u) -> tuple[float, float, float, float]:
        """(ξ of the first line's top, ξ of the bottom of both lines, ξ of the second line's top,
        η_u of the second line) [m] of the repetition of :meth:`_RepStages` (the same arguments):
        each line spans the polygon over its band, and a turn reaches the farther of its lines'
        ends."""
        poly, h = self.polygon, self.x_d / 2.0
        eta_u = eta_d + 2.0 * self.r1
        lo_d, hi_d = poly.BandExtent(eta_d, h)
        lo_u, hi_u = poly.BandExtent(eta_u, h)
        if prev_eta_u is not None:
            top_d = min(lo_d, poly.BandExtent(prev_eta_u, h)[0])
        else:
            top_d = lo_d
        bottom = max(hi_d, hi_u)
        top_u = lo_u
        if r2 is not None:
            eta_next = eta_u - 2.0 * r2
            top_u = min(lo_u, poly.BandExtent(eta_next, h)[0])
        return top_d, bottom, top_u, eta_u

    @_Memoized(4096)
    def _RepArcs(self, eta_d: float, r2, prev_eta_u) -> tuple:
        """(length [m] of the first line, first half circle, length [m] of the second line,
        second half circle or None) of the repetition of :meth:`_RepStages` (the same arguments
        but k and c1), a half circle as (:func:`ArcStart`, length [m]): what its times need,
        independent of the wind (kept: a changing wind re-times the same repetitions)."""
        top_d, bottom, top_u, eta_u = self._RepGeometry(eta_d, r2, prev_eta_u)
        r1 = self.r1
        arc2 = None if r2 is None else self._HalfCircle(top_u, eta_u - r2, r2, eta_u)
        return (
            float(bottom - top_d),
            self._HalfCircle(bottom, eta_d + r1, r1, eta_d),
            float(bottom - top_u),
            arc2,
        )

    @_Memoized(64)
    def _LineSpeed(self, s: float, airspeed: float, wind) -> float:
        """Ground speed [m/s] along every line of the plan flown in direction s (all have the
        normal e2 and :func:`LineSpeed` is the same at every point of a line)."""
        poly = self.polygon
        line = Line(poly.origin, poly.e2, s=s, k_e=self.k_e)
        return LineSpeed(line, poly.origin, airspeed, CheckedWind(airspeed, wind))

    def _HalfCircle(self, xi, eta_o, radius, eta_entry) -> tuple[tuple, float]:
        """(:func:`ArcStart`, length [m]) of the left half circle of ``radius`` [m] (> 0) around
        (ξ, η_o) entered at (ξ, η_entry) (local frame [m]), as :meth:`_RepStages` builds it."""
        W = self.polygon.ToWorld
        entry = W(xi, eta_entry)
        path = Circle(W(xi, eta_o), radius, s=-1.0, k_e=self.k_e)
        return ArcStart(path, (float(entry[0]), float(entry[1]))), float(math.pi * radius)

    def _BuildTimes(self, reps: list, prev_eta_u, airspeed, wind) -> tuple[float, ...]:
        """StageTime [s] of each stage of :meth:`_Build` (the same arguments), in order, from the
        repetitions' geometry without building their stages (the staircase times ~20 values of
        c1 whose stages nobody flies): the same lengths, the lines' ground speed
        (:meth:`_LineSpeed`) and the same circles (:meth:`_RepArcs`) timed by the same function,
        so the same numbers. The wind is a pair of Python floats, already checked."""
        down, up = self._LineSpeed(1.0, airspeed, wind), self._LineSpeed(-1.0, airspeed, wind)
        times: list[float] = []
        for _, eta_d, r2, _ in reps:
            line_d, arc1, line_u, arc2 = self._RepArcs(eta_d, r2, prev_eta_u)
            times.append(_LineTime(line_d, down))
            times.append(ArcStartTime(*arc1, airspeed, *wind))
            times.append(_LineTime(line_u, up))
            if arc2 is not None:
                times.append(ArcStartTime(*arc2, airspeed, *wind))
            prev_eta_u = eta_d + 2.0 * self.r1
        return tuple(times)

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        """The whole plan at c1 (Alg. 1): approach, then the repetitions."""
        poly = self.polygon
        eta_d0 = self.x_d / 2.0
        r2 = TurningRadius2(c1, self.r)
        top0 = poly.BandExtent(eta_d0, self.x_d / 2.0)[0]
        trig = poly.ToWorld(top0, eta_d0)
        approach = Circle(poly.ToWorld(top0, eta_d0 + r2), r2, s=-1.0, k_e=self.k_e)
        o = approach.center
        v = self.start - o
        nv = np.linalg.norm(v)
        entry = o + r2 * v / nv if nv > 0 else trig
        length = r2 * ArcAngle(approach, entry, trig)
        anchor = (-1.0, APPROACH, eta_d0, 0.0)
        first = MakeStage(0, approach, trig, APPROACH, c1, entry, length, anchor)
        return (first,) + tuple(self._Build(self._Reps(0, eta_d0, c1), None))

    def _StagesAfter(self, index: int, anchor: tuple, c1: float) -> tuple[Stage, ...]:
        k, prim, eta_d, r2k = anchor
        k, prim = int(round(k)), int(round(prim))
        if prim == APPROACH:
            return self._Stages(c1)[1:]
        if prim == 3:
            eta_u = eta_d + 2.0 * self.r1
            reps = self._Reps(k + 1, eta_u - 2.0 * r2k, c1)
            return tuple(self._Build(reps, eta_u))
        return tuple(s for s in self._RestFrom(k, eta_d, c1) if s.index > index)

    def _StageTimesAfter(self, index, anchor, c1, airspeed, wind) -> tuple[float, ...]:
        """The stage times of :meth:`_StagesAfter`, timed per repetition (:meth:`_BuildTimes`);
        ValueError for a wind that :func:`CheckedWind` refuses, as :func:`StageTime`."""
        CheckedWind(airspeed, wind)
        k, prim, eta_d, r2k = anchor
        k, prim = int(round(k)), int(round(prim))
        if prim == APPROACH:  # the whole plan but the approach
            return self._RestTimes(0, self.x_d / 2.0, c1, airspeed, wind)
        if prim == 3:
            eta_u = eta_d + 2.0 * self.r1
            reps = self._Reps(k + 1, eta_u - 2.0 * r2k, c1)
            return self._BuildTimes(reps, eta_u, airspeed, wind)
        # The stages of :meth:`_RestFrom` are numbered on from 1 + 4k: those after ``index``.
        times = self._RestTimes(k, eta_d, c1, airspeed, wind)
        return times[max(0, index - (1 + NUM_PRIMITIVES * k) + 1) :]

    @_Memoized(64)
    def _RestTimes(self, k, eta_d, c1, airspeed, wind) -> tuple[float, ...]:
        """StageTime [s] of each stage of :meth:`_RestFrom` at ``airspeed`` in ``wind``."""
        return self._BuildTimes(self._Reps(k, eta_d, c1), None, airspeed, wind)

    @_Memoized(64)
    def _RestFrom(self, k: int, eta_d: float, c1: float) -> tuple[Stage, ...]:
        """The stages of repetitions k, k + 1, … with the first line at η_d [m] and c1 [m²]: the
        same for every stage of repetition k but its second circle (built once for them)."""
        return tuple(self._Build(self._Reps(k, eta_d, c1), None))


def CoverageTime(
    params: "CoverageParams",
    c1: float,
    airspeed: float,
    wind=(0.0, 0.0),
    *,
    start,
    include_approach: bool = True,
) -> float:
    """t(c1) [s] of the Zamboni-like plan of ``params`` flown from ``start`` [m] at ``airspeed``
    [m/s] in constant ``wind`` [m/s] (see :class:`ZamboniCoverage`; the field gain k_e does not
    enter the time, 1 is passed)."""
    plan = ZamboniCoverage(params, start=start, airspeed=airspeed, initial_c1=c1, k_e=1.0)
    return plan.CoverageTime(c1, airspeed, wind, include_approach)


def MakeCoveragePlan(coverage: "CoverageParams", vehicle, *, c1: float, k_e: float):
    """The Zamboni-like plan of a scenario: ``coverage`` geometry, start position and airspeed from
    ``vehicle`` (:class:`~eaplan_drake.params.VehicleParams`), initial c1 [m²] (checked against
    [r_min² − r², 0]) and field gain ``k_e`` [1/m] (``GuidanceParams.k_e``)."""
    return ZamboniCoverage(
        coverage,
        start=vehicle.initial_position,
        airspeed=vehicle.airspeed,
        initial_c1=c1,
        k_e=k_e,
    )


def MakeZamboniPlanSource(scenario, initial_c1: float) -> "ZamboniCoverage":
    """The generated Zamboni-like coverage of ``scenario.coverage`` (:func:`MakeCoveragePlan`),
    flown from ``vehicle.initial_position`` at ``vehicle.airspeed`` with the field gain
    ``guidance.k_e``, starting with ``initial_c1`` [m²]. Raises ValueError."""
    return MakeCoveragePlan(
        scenario.coverage, scenario.vehicle, c1=initial_c1, k_e=scenario.guidance.k_e
    )
