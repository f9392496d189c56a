"""What a completed survey has flown and covered: the sequencer alone driven along its plan, and the
guidance loop (FlyTracking), for every shipped scenario and for random convex polygons.

Findings these tests pin (see the sequencer's and the coverage module's docstrings):

- At completion nothing of the plan being flown is left: the aircraft is within the trigger radius
  (plus one update's travel) of the last line's triggering point; no turn or exit leg follows.
- The sequencer's ``survey`` fraction (the plan being flown) is then at most that distance over the
  survey length, and exactly 0 after the completing update.
- The planner's ``coverage_remaining`` (taken at c̄1) is then the c̄1 repetitions that the flown
  plan does not have (the number of repetitions is whole at each c1): 0.068 for the reference field
  flown at c1 = −1000, the number the flight summary showed for "survey complete".
- The swaths (half-width d/2 of the widest line spacing flown) cover the whole polygon but for a
  strip at the far edge beyond the last line's swath, narrower than d/2 + x_d/2 (Alg. 1 ends after
  the last whole repetition that fits); for the reference field at c1 = 0 nothing is left.
- A field narrower than 4 r1 across the lines is accepted but left unswept in the middle (xfail).
"""

import dataclasses as dc
import math

import numpy as np
import pytest

from eaplan_drake import LoadNamedScenario
from eaplan_drake.flight.coverage import ZamboniCoverage
from eaplan_drake.flight.polygon import CoveragePolygon
from eaplan_drake.flight.sequencer import StageSequencer
from eaplan_drake.flight.stages import APPROACH, PathLeft, TurningRadius2
from eaplan_drake.output.plot_math import UncoveredArea
from eaplan_drake.params import CoverageParams, GuidanceParams
from eaplan_drake.resolve import ResolveScenario
from eaplan_drake.studies.tracking import FlyTracking

SHIPPED = ["plan_I", "plan_II", "plan_i", "plan_ii", "survey"]
STEP = 2.0
"""Distance [m] the driven aircraft moves along the active stage between two updates."""
RESOLUTION = 1.0
"""Grid cell [m] of the coverage check (:func:`~eaplan_drake.output.plot_math.UncoveredArea`)."""
GRID_SLACK = 1.5 * RESOLUTION
"""How far inside a swath's edge [m] a cell may still be counted uncovered by the grid."""
MAX_GAPS = 0.002
"""Stated bound: at most 0.2 % of a field is left uncovered before the last line's swath (cells at
slanted edges between coarse lines: a line spans the polygon over its own x_d band only)."""
MAX_UNCOVERED_SHIPPED = 0.03
"""Stated bound: the far strip of the reference field is at most 3 % of it (2.0 % at c1 = −1000)."""


def _PointBefore(stage, left: float) -> np.ndarray:
    """The point of ``stage``'s nominal path ``left`` [m] before its triggering point."""
    g = stage.geometry
    if g.is_circle:
        a = g.trigger_angle + (-1.0 if g.ccw else 1.0) * left / g.radius
        return np.array([g.ox + g.radius * math.cos(a), g.oy + g.radius * math.sin(a)])
    return np.array([g.tx - g.ux * left, g.ty - g.uy * left])


def Drive(plan, schedule, *, trigger_radius: float, step: float = STEP) -> dict:
    """Drives a :class:`StageSequencer` alone: the position moves ``step`` [m] along the active
    stage's nominal path before each update, with c1 = ``schedule(stage index)``; returns what
    the tests need at completion."""
    seq = StageSequencer(
        plan,
        trigger_radius=trigger_radius,
        initial_period=46.0,
        wind=(0.0, 0.0),
        initial_c1=schedule(0),
    )
    ctx = seq.CreateDefaultContext()
    position, c1_in = seq.GetInputPort("position"), seq.GetInputPort("path_parameters")
    planner_fraction = seq.GetOutputPort("coverage_remaining")
    done = seq.GetOutputPort("mission_complete")
    p = np.asarray(seq.ActiveStage(ctx).entry, dtype=float)
    lines, flown_c1 = [], set()
    for n in range(1, 200000):
        stage = seq.ActiveStage(ctx)
        # The outputs as the previous update left them (at the previous position).
        before = {
            "stage": stage,
            "position": p,
            "survey": seq.SurveyRemaining(ctx),
            "coverage_remaining": float(planner_fraction.Eval(ctx)[0]),
            "c1": seq.PathParameter(ctx),
        }
        p = _PointBefore(stage, max(PathLeft(stage, p) - step, 0.0))
        ctx.SetTime(n * 0.05)
        position.FixValue(ctx, p)
        c1_in.FixValue(ctx, [schedule(stage.index)])
        ctx.get_mutable_discrete_state().SetFrom(seq.EvalUniquePeriodicDiscreteUpdate(ctx))
        if stage.primitive != APPROACH:
            flown_c1.add(seq.PathParameter(ctx))
            if not stage.is_circle:
                lines.append(p)
        if done.Eval(ctx)[0] > 0.5:
            return {
                "last": stage,
                "position": p,
                "c1": seq.PathParameter(ctx),
                "flown_c1": flown_c1,
                "before": before,
                "survey_after": seq.SurveyRemaining(ctx),
                "coverage_remaining_after": float(planner_fraction.Eval(ctx)[0]),
                "lines": np.array(lines),
            }
    raise AssertionError("the survey did not complete")


def _Shift(coverage, c1: float) -> float:
    r1 = coverage.turning_radius + 0.5 * coverage.swath_spacing
    return 2.0 * r1 - 2.0 * TurningRadius2(c1, coverage.turning_radius)


def CheckCompletion(plan, coverage, flight) -> dict:
    """The assertions every completed survey meets (module docstring); returns the numbers."""
    eps = float(coverage.trigger_radius)
    last, c1 = flight["last"], flight["c1"]
    # Nothing of the flown plan is left: the last stage is the plan's last, flown to its trigger.
    assert not plan.StagesAfter(last.index, last.anchor, c1)
    assert last.primitive != APPROACH and not last.is_circle
    assert np.linalg.norm(flight["position"] - np.asarray(last.trigger)) <= eps + STEP + 1e-9
    # The flown plan's fraction: the trigger distance left, then exactly 0.
    survey_length = plan.SurveyLength(c1)
    assert 0.0 <= flight["before"]["survey"] * survey_length <= eps + 2.0 * STEP + 1e-6
    assert flight["survey_after"] == 0.0 and flight["coverage_remaining_after"] == 0.0
    # The planner's fraction holds the c̄1 plan's survey after the flown plan's last stage.
    c1_ref = plan.c1_bounds[1]
    before = flight["before"]
    beyond = plan.SurveyLengthAfter(last.index, last.anchor, c1_ref)
    expected = (PathLeft(last, before["position"]) + beyond) / plan.SurveyLength(c1_ref)
    assert before["coverage_remaining"] == pytest.approx(min(expected, 1.0), abs=1e-12)
    # The swaths of half the widest spacing flown cover all but the strip beyond the last line.
    poly = CoveragePolygon(coverage.polygon, coverage.line_edge)
    radius = 0.5 * max(_Shift(coverage, v) for v in flight["flown_c1"])
    x, y, mask, uncovered = UncoveredArea(coverage.polygon, flight["lines"], radius, RESOLUTION)
    gx, gy = np.meshgrid(x, y)
    eta = (np.column_stack([gx[mask], gy[mask]]) - poly.origin) @ poly.e2
    eta_last = float((np.asarray(last.trigger) - poly.origin) @ poly.e2)
    gaps = np.sum(eta < eta_last + radius - GRID_SLACK) / mask.sum() * uncovered if eta.size else 0
    assert gaps <= MAX_GAPS, f"{gaps:.2%} of the field uncovered before the last line"
    # ... and that strip is narrower than d/2 + x_d/2: the next whole repetition did not fit.
    x_d = float(coverage.swath_spacing)
    assert poly.width - eta_last < _Shift(coverage, c1) + 0.5 * x_d + 1e-9
    return {
        "uncovered": uncovered,
        "strip": max(0.0, poly.width - eta_last - radius),
        "coverage_remaining": before["coverage_remaining"],
    }


@pytest.fixture(scope="module")
def shipped():
    out = {}
    for name in SHIPPED:
        scenario = LoadNamedScenario(name)
        out[name] = (scenario, ResolveScenario(scenario).plan)
    return out


_DRIVES: dict = {}


def _SharedDrive(plan, coverage, label, schedule) -> dict:
    """:func:`Drive`, once per plan definition and schedule: the shipped scenarios share the
    reference field, start and c1 range (they differ in wind, battery and planner, which the
    sequencer alone does not see), so their drives are the same."""
    key = (repr(dc.asdict(coverage)), tuple(plan.start), plan.c1_bounds, plan.airspeed, label)
    if key not in _DRIVES:
        _DRIVES[key] = Drive(plan, schedule, trigger_radius=coverage.trigger_radius)
    return _DRIVES[key]


def _Schedules(scenario):
    lo, hi = (float(v) for v in scenario.planner.path_parameter_bounds)
    c1_0 = float(scenario.planner.initial_path_parameters[0])

    def coarse_to_fine(i):  # plan ii's pattern: coarse, finer, the finest from stage 21 on
        return lo if i < 7 else (0.5 * lo if i < 17 else (0.25 * lo if i < 21 else hi))

    return {
        "lowest": lambda i: lo,
        "highest": lambda i: hi,
        "initial": lambda i: c1_0,
        "coarse_to_fine": coarse_to_fine,
        "fine_to_coarse": lambda i: hi if i < 21 else lo,
    }


@pytest.mark.parametrize("name", SHIPPED)
def test_a_complete_shipped_survey_has_flown_its_plan_and_covered_its_field(shipped, name):
    scenario, plan = shipped[name]
    results = {}
    for label, schedule in _Schedules(scenario).items():
        flight = _SharedDrive(plan, scenario.coverage, label, schedule)
        results[label] = CheckCompletion(plan, scenario.coverage, flight)
        assert results[label]["uncovered"] <= MAX_UNCOVERED_SHIPPED, label
    # At c̄1 the reference field's 15 repetitions land on W − x_d/2: nothing is left at all.
    assert results["highest"]["uncovered"] <= 1e-3
    assert results["highest"]["strip"] == pytest.approx(0.0, abs=1e-9)
    assert results["highest"]["coverage_remaining"] <= 1e-3
    # At c̲1 the planner's fraction at completion is one c̄1 repetition of the 15 (the 0.068 of
    # the flight summaries), though the flown plan is complete.
    rep = sum(s.length for s in plan.Stages(0.0)[1:5]) / plan.SurveyLength(0.0)
    assert results["lowest"]["coverage_remaining"] == pytest.approx(rep, abs=2e-3)
    assert results["lowest"]["coverage_remaining"] == pytest.approx(0.068, abs=1e-3)
    assert results["lowest"]["uncovered"] == pytest.approx(0.020, abs=0.003)


def _RandomFields(seed: int, count: int, min_width: float, max_width: float):
    """``count`` random convex polygons (3–7 vertices) whose width across the lines is in
    [min_width, max_width] [m], with a random line edge."""
    rng = np.random.default_rng(seed)
    fields = []
    while len(fields) < count:
        n = int(rng.integers(3, 8))
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        radii = rng.uniform(160.0, 320.0, n)
        vertices = np.column_stack([radii * np.cos(angles), radii * np.sin(angles)]).round(1)
        edge = int(rng.integers(0, n))
        try:
            poly = CoveragePolygon(vertices.tolist(), edge)
        except ValueError:
            continue
        if min_width <= poly.width <= max_width:
            fields.append(CoverageParams(polygon=vertices.tolist(), line_edge=edge))
    return fields


def _Plan(coverage, c1):
    """The Zamboni plan of ``coverage`` from a start half a turn before the first line (so the
    approach circle is flown, not triggered at once)."""
    poly = CoveragePolygon(coverage.polygon, coverage.line_edge)
    h = 0.5 * coverage.swath_spacing
    top = poly.BandExtent(h, h)[0]
    start = poly.ToWorld(top, h + 2.0 * TurningRadius2(c1, coverage.turning_radius))
    k_e = GuidanceParams().k_e
    return ZamboniCoverage(coverage, start=start, airspeed=15.0, initial_c1=c1, k_e=k_e)


FOUR_R1 = 4.0 * (CoverageParams().turning_radius + 0.5 * CoverageParams().swath_spacing)


@pytest.mark.parametrize("index", range(4))
@pytest.mark.parametrize("c1", [-1000.0, pytest.param(0.0, marks=pytest.mark.slow)])
def test_a_complete_survey_of_a_random_convex_field_covers_it(index, c1):
    coverage = _RandomFields(11, 4, FOUR_R1, 700.0)[index]
    plan = _Plan(coverage, c1)
    flight = Drive(plan, lambda i: c1, trigger_radius=coverage.trigger_radius)
    result = CheckCompletion(plan, coverage, flight)
    # The far strip is at most d/2 + x_d/2 wide; in area, a few per cent of these fields.
    assert result["uncovered"] <= 0.03


@pytest.mark.xfail(
    strict=True,
    reason="CheckCoverageGeometry accepts a field narrower than 4 r1 (it needs 2 r1 + x_d); the "
    "first lines then never meet the second lines and the middle of the field is left unswept, "
    "while both fractions reach 0 (tests/test_policies.py's 180 m 'small world' is such a field)",
)
def test_a_complete_survey_of_a_field_narrower_than_4_r1_covers_it():
    field = [[-120.0, 11.0], [-120.0, 146.0], [60.0, 146.0], [60.0, 11.0]]  # 180 m across
    coverage = CoverageParams(polygon=field)
    plan = _Plan(coverage, 0.0)
    flight = Drive(plan, lambda i: 0.0, trigger_radius=coverage.trigger_radius)
    # Both fractions say "done" (the trigger distance left of a 2.6 km survey) ...
    length = plan.SurveyLength(0.0)
    assert flight["before"]["survey"] * length <= coverage.trigger_radius + 2.0 * STEP + 1e-6
    assert flight["before"]["coverage_remaining"] == flight["before"]["survey"]
    # ... but the swaths cover only the two sides of the 180 m field: 0.59 of it is left.
    uncovered = UncoveredArea(coverage.polygon, flight["lines"], 5.0, RESOLUTION)[3]
    assert uncovered <= 0.01


@pytest.mark.parametrize(
    "name, c1", [("plan_II", -1000.0), pytest.param("survey", 0.0, marks=pytest.mark.slow)]
)
def test_the_guidance_loop_completes_at_the_last_trigger_with_the_field_covered(shipped, name, c1):
    scenario, plan = shipped[name]
    f = FlyTracking(scenario, plan, c1)
    assert f["complete"]
    last = plan.Stages(c1)[-1]
    # The last logged position (before the completing update) is on the last line, near its end.
    v_g = scenario.vehicle.airspeed + scenario.wind.speed
    reach = scenario.coverage.trigger_radius + v_g * scenario.simulation.log_period + 0.5
    assert np.linalg.norm(f["position"][-1] - np.asarray(last.trigger)) <= reach
    on_line = f["path"][:, 0] == 0.0  # lines have a = 0; the approach and turns are circles
    radius = 0.5 * _Shift(scenario.coverage, c1)
    uncovered = UncoveredArea(scenario.coverage.polygon, f["position"][on_line], radius, 1.0)[3]
    assert uncovered <= (0.025 if c1 < 0.0 else 1e-3)
