"""Coverage plan (paper 003 Alg. 1): reference geometry, times, Eq. 10, re-planning, validation."""

import dataclasses as dc
import math
import pickle

import numpy as np
import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.flight.coverage import (
    CoverageTime,
    MakeCoveragePlan,
    ScalingFactors,
    ZamboniCoverage,
)
from eaplan_drake.flight.stages import (
    APPROACH,
    PathLeft,
    Stage,
    StageRemaining,
    StageTime,
    SurveyFraction,
    TurningRadius2,
)
from eaplan_drake.params import CoverageParams, GuidanceParams, VehicleParams

V_A = 15.0
R2_MIN = math.sqrt(3900.0)  # r2(−1000)
START = (-100.0, 220.0)
K_E = GuidanceParams().k_e


def _Zamboni(params=None, start=START, c1=0.0, airspeed=V_A, k_e=K_E):
    params = CoverageParams() if params is None else params
    return ZamboniCoverage(params, start=start, airspeed=airspeed, initial_c1=c1, k_e=k_e)


@pytest.fixture(scope="module")
def reference():
    return _Zamboni()


def _line_x(stage: Stage) -> float:
    """x of a vertical line φ = ±(x − x0)."""
    a, bx, by, c = stage.path.descriptor()[:4]
    assert a == 0.0 and abs(by) < 1e-12 and abs(abs(bx) - 1.0) < 1e-12
    return -c / bx


def test_reference_rectangle_reproduces_the_authors_first_stages(reference):
    s = reference.Stages(0.0)
    approach, down, turn1, up, turn2, down2 = s[:6]
    assert approach.primitive == APPROACH
    assert approach.path.center == pytest.approx([-45.0, 146.0])
    assert approach.path.radius == pytest.approx(70.0)
    assert approach.trigger == pytest.approx((-115.0, 146.0))
    assert [st.primitive for st in s[1:9]] == [0, 1, 2, 3, 0, 1, 2, 3]
    assert _line_x(down) == pytest.approx(-115.0)
    assert down.entry == pytest.approx((-115.0, 146.0))
    assert down.trigger == pytest.approx((-115.0, 11.0))
    assert down.TriggerTangent() == pytest.approx([0.0, -1.0])
    assert turn1.path.center == pytest.approx([-40.0, 11.0])
    assert turn1.path.radius == pytest.approx(75.0)  # r1 = r + x_d/2
    assert turn1.trigger == pytest.approx((35.0, 11.0))
    assert _line_x(up) == pytest.approx(35.0)
    assert up.trigger == pytest.approx((35.0, 146.0))
    assert up.TriggerTangent() == pytest.approx([0.0, 1.0])
    assert turn2.path.center == pytest.approx([-35.0, 146.0])
    assert turn2.path.radius == pytest.approx(70.0)
    assert _line_x(down2) == pytest.approx(-105.0)
    # Every turn is counter-clockwise (s = −1 on a positive circle), like the authors' direction 0.
    for st in (approach, turn1, turn2):
        assert st.path.s == -1.0 and st.path.a > 0
        assert st.length == pytest.approx(
            st.path.radius * (math.pi if st is not approach else math.radians(53.3785)), rel=1e-4
        )


def test_every_stage_is_normalised_and_continuous(reference):
    for c1 in (0.0, -1000.0):
        stages = reference.Stages(c1)
        for prev, st in zip(stages, stages[1:], strict=False):
            assert st.entry == pytest.approx(prev.trigger, abs=1e-9)
            for p in (st.entry, st.trigger):
                assert abs(st.path.value(p)) < 1e-9
                assert np.linalg.norm(st.path.gradient(p)) == pytest.approx(1.0, abs=1e-12)
            # Tangent continuity at the switch: same direction of travel on both stages.
            t_prev, t_next = prev.TriggerTangent(), st.path.tangent(st.entry)
            assert t_next / np.linalg.norm(t_next) == pytest.approx(t_prev, abs=1e-9)
            assert st.path.k_e == GuidanceParams().k_e
            assert st.index == prev.index + 1


@pytest.mark.parametrize("c1, shift", [(0.0, 10.0), (-1000.0, 150.0 - 2.0 * R2_MIN)])
def test_shift_between_repetitions(reference, c1, shift):
    assert reference.Shift(c1) == pytest.approx(shift)
    downs = [_line_x(s) for s in reference.Stages(c1) if s.primitive == 0]
    ups = [_line_x(s) for s in reference.Stages(c1) if s.primitive == 2]
    np.testing.assert_allclose(np.diff(downs), shift, rtol=1e-12)
    np.testing.assert_allclose(np.diff(ups), shift, rtol=1e-12)
    # The survey ends after the last up-line that fits: x <= 180 − x_d/2 = 175.
    assert ups[-1] <= 175.0 + 1e-9 and ups[-1] + shift > 175.0
    assert reference.Stages(c1)[-1].primitive == 2
    assert reference.Stages(c1)[-1].trigger == pytest.approx((ups[-1], 146.0))


def test_reference_shift_at_c1_minus_1000_is_25_1_m(reference):
    assert reference.Shift(-1000.0) == pytest.approx(25.1, abs=0.01)
    assert len(reference.Stages(0.0)) == 1 + 15 * 4 - 1  # 60, as the authors' plan file
    assert len(reference.Stages(-1000.0)) == 1 + 6 * 4 - 1


def _analytic_time(c1: float, n_reps: int, approach_angle: float) -> float:
    r2 = TurningRadius2(c1, 70.0)
    length = (
        r2 * approach_angle + n_reps * (2 * 135.0 + math.pi * 75.0) + (n_reps - 1) * math.pi * r2
    )
    return length / V_A


def test_coverage_time_matches_geometry_and_the_paper(reference):
    # Approach: from the start's direction seen from the approach circle's centre to 180°.
    for c1, n_reps, paper in ((0.0, 15, 706.0), (-1000.0, 6, 270.0)):
        r2 = TurningRadius2(c1, 70.0)
        o = np.array([-115.0 + r2, 146.0])
        v = np.array([-100.0, 220.0]) - o
        angle = math.pi - math.atan2(v[1], v[0])
        t = reference.CoverageTime(c1, V_A)
        assert t == pytest.approx(_analytic_time(c1, n_reps, angle), rel=1e-12)
        assert abs(t - paper) <= 0.10 * paper
    assert CoverageTime(CoverageParams(), 0.0, V_A, start=START) == pytest.approx(
        reference.CoverageTime(0.0, V_A)
    )
    assert reference.CoverageTime(0.0, V_A, include_approach=False) == pytest.approx(
        reference.SurveyLength(0.0) / V_A
    )


def test_repetition_time_in_wind_is_longer_than_in_still_air(reference):
    reps = reference.Stages(0.0)[1:5]
    still = sum(StageTime(s, V_A) for s in reps)
    windy = sum(StageTime(s, V_A, (5.0, 0.0)) for s in reps)
    assert still == pytest.approx((270.0 + math.pi * 145.0) / V_A)
    assert windy > still + 2.0  # crossing a 5 m/s wind costs time on every closed circuit


def test_scaling_factors_eq10(reference):
    nu, tau = reference.ScalingFactors(V_A)
    t_lo, t_hi = reference.CoverageTime(-1000.0, V_A), reference.CoverageTime(0.0, V_A)
    assert nu.shape == (1,) and tau.shape == (1,)
    assert nu[0] * -1000.0 + tau[0] == pytest.approx(t_lo)
    assert nu[0] * 0.0 + tau[0] == pytest.approx(t_hi)
    assert nu[0] > 0  # larger c1, longer coverage
    nu2, tau2 = ScalingFactors((-1000.0, 0.0), (270.0, 706.0))
    assert nu2[0] == pytest.approx(0.436) and tau2[0] == pytest.approx(706.0)
    assert reference.CoverageTimeBounds((-1000.0, 0.0), V_A) == pytest.approx((t_lo, t_hi))
    with pytest.raises(ValueError, match="lower < upper"):
        ScalingFactors((0.0, 0.0), (1.0, 1.0))


def test_replan_with_the_same_c1_changes_nothing(reference):
    stages = reference.Stages(0.0)
    for j in range(len(stages)):
        assert reference.Replan(stages, j, 0.0) == stages
    # From the approach on, everything but the (kept) approach circle is the c1 = −1000 plan.
    assert reference.Replan(stages, 0, -1000.0)[1:] == reference.Stages(-1000.0)[1:]


@pytest.mark.parametrize("current", [5, 6, 7, 8])  # rep 1: primitives 0, 1, 2, 3
def test_replan_keeps_the_current_stage_and_moves_later_ones(reference, current):
    old = reference.Stages(0.0)
    new = reference.Replan(old, current, -1000.0)
    assert new[: current + 1] == old[: current + 1]
    assert all(s.c1 == -1000.0 for s in new[current + 1 :])
    assert len(new) < len(old)
    # The first r2 circle not yet started gets the new radius; the lines after it move with the
    # new shift from where that circle ends.
    k_turn = next(s for s in new[current + 1 :] if s.primitive == 3)
    if old[current].primitive == 3:
        assert k_turn.index == current + 4
    assert k_turn.path.radius == pytest.approx(R2_MIN)
    downs = [_line_x(s) for s in new if s.primitive == 0 and s.index > k_turn.index]
    up_before = _line_x(new[k_turn.index - 1])
    assert downs[0] == pytest.approx(up_before - 2 * R2_MIN)
    np.testing.assert_allclose(np.diff(downs), 150.0 - 2 * R2_MIN)
    # Replanning from every point stays continuous and tangent.
    for prev, st in zip(new, new[1:], strict=False):
        assert st.entry == pytest.approx(prev.trigger, abs=1e-9)


def test_replan_back_and_forth_is_consistent(reference):
    a = reference.Replan(reference.Stages(0.0), 9, -1000.0)
    b = reference.Replan(a, 14, 0.0)
    assert b[:15] == a[:15]
    # From stage 14 (rep 3, primitive 1) on, the rest is the c1 = 0 pattern shifted by 10 m.
    downs = [_line_x(s) for s in b if s.primitive == 0]
    np.testing.assert_allclose(np.diff(downs[3:]), 10.0)


def test_remaining_fraction_falls_from_one_to_zero(reference):
    stages = reference.Stages(0.0)
    fractions = [reference.RemainingFraction(stages, j) for j in range(len(stages))]
    assert fractions[0] == 1.0 and fractions[1] == 1.0
    assert np.all(np.diff(fractions[1:]) < 0)
    last = stages[-1]
    assert reference.RemainingFraction(stages, len(stages) - 1, last.trigger) == 0.0
    mid = reference.RemainingFraction(stages, 30)
    assert mid == pytest.approx(0.5, abs=0.05)
    # Nearly independent of c1: re-planning half-way to c1 = −1000 changes it by less than one
    # repetition's share (the number of repetitions left is an integer at each c1).
    replanned = reference.Replan(stages, 30, -1000.0)
    new = reference.RemainingFraction(replanned, 30)
    rep = sum(s.length for s in reference.Stages(-1000.0)[1:5])
    assert abs(new - mid) < rep / reference.SurveyLength(-1000.0)
    assert new * reference.SurveyLength(-1000.0) == pytest.approx(
        sum(s.length for s in replanned[30:])
    )


def test_rotated_and_reordered_polygon_gives_the_rotated_plan():
    ref = _Zamboni()
    angle = math.radians(30.0)
    R = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    pivot = np.array([10.0, -20.0])

    def rot(p):
        return R @ (np.asarray(p) - pivot) + pivot

    poly = [rot(v).tolist() for v in CoverageParams().polygon]
    # Counter-clockwise order, and a shuffled order: the edge (v0, v1) keeps its meaning.
    ccw = [poly[1], poly[2], poly[3], poly[0]][::-1]  # v0, v3, v2, v1: edge (v1, v0) = 3
    shuffled = [poly[2], poly[0], poly[1], poly[3]]  # edge (v0, v1) = 1
    for vertices, edge in ((poly, 0), (ccw, 3), (shuffled, 1)):
        params = dc.replace(CoverageParams(), polygon=vertices, line_edge=edge)
        plan = _Zamboni(params, start=rot(START))
        for a, b in zip(ref.Stages(-400.0), plan.Stages(-400.0), strict=True):
            assert b.trigger == pytest.approx(rot(a.trigger), abs=1e-9)
            assert b.length == pytest.approx(a.length, rel=1e-9)
            assert b.primitive == a.primitive
        assert plan.CoverageTime(0.0, V_A) == pytest.approx(ref.CoverageTime(0.0, V_A))


def test_trapezoid_lines_cover_their_swath_and_turns_are_tangent():
    # Lines parallel to the bottom edge (edge 0), the polygon narrows towards the top.
    params = dc.replace(
        CoverageParams(),
        polygon=[[0.0, 0.0], [400.0, 0.0], [330.0, 320.0], [60.0, 320.0]],
        line_edge=0,
    )
    plan = _Zamboni(params, start=(0.0, -150.0))
    poly = plan.polygon
    assert poly.width == pytest.approx(320.0)
    assert poly.e2 == pytest.approx([0.0, 1.0])  # sweep towards +y (into the polygon)
    stages = plan.Stages(0.0)
    for st in stages:
        if st.primitive in (0, 2):
            a, bx, by, c = st.path.descriptor()[:4]
            assert abs(bx) < 1e-12  # parallel to the bottom edge
            y = -c / by
            ends = sorted([st.entry[0], st.trigger[0]])
            lo, hi = poly.BandExtent(poly.origin @ poly.e2 + y, params.swath_spacing / 2)
            # The line spans at least the polygon's extent over its swath band.
            assert ends[0] <= lo + 1e-9 and ends[1] >= hi - 1e-9
    for prev, st in zip(stages, stages[1:], strict=False):
        t_prev, t_next = prev.TriggerTangent(), st.path.tangent(st.entry)
        assert t_next / np.linalg.norm(t_next) == pytest.approx(t_prev, abs=1e-9)
    ups = [s for s in stages if s.primitive == 2]
    assert -ups[-1].path.c / ups[-1].path.b[1] <= 320.0 - 5.0 + 1e-9


@pytest.mark.parametrize(
    "polygon, edge, match",
    [
        ([[0, 0], [100, 0], [30, 30], [0, 100]], 0, "non-convex.*vertex 2"),
        ([[0, 0], [100, 0], [200, 0]], 0, "degenerate.*collinear"),
        ([[0, 0], [100, 0], [100, 0], [0, 100]], 0, "degenerate.*coincide"),
        ([[0, 0], [100, 0]], 0, "degenerate.*3 vertices"),
        ([[0, 0], [50, 0], [100, 0], [0, 100]], 0, "degenerate.*straight edge"),
        ([[0, 0], [300, 300], [300, 0], [0, 300]], 0, "line_edge.*diagonal"),
        ([[0, 0], [300, 0], [300, 300], [0, 300]], 4, r"line_edge.*\[0, 3\]"),
        ([[0, 0], [0, 150], [300, 150], [300, 0]], 1, "too small for one repetition.*160"),
        ([[0, float("nan")], [0, 150], [300, 150]], 0, "finite"),
    ],
)
def test_bad_polygons_are_rejected_with_a_clear_message(polygon, edge, match):
    params = dc.replace(CoverageParams(), polygon=polygon, line_edge=edge)
    with pytest.raises(ValueError, match=match):
        _Zamboni(params)


def test_resolving_a_generated_plan_checks_the_geometry():
    from eaplan_drake.params import Scenario
    from eaplan_drake.resolve import ResolveScenario

    bad = Scenario()
    bad.coverage.polygon = [[0, 0], [100, 0], [30, 30], [0, 100]]
    bad.coverage.Validate()  # the schema checks fields; the Zamboni geometry is the plan's
    with pytest.raises(ScenarioError, match=r"^coverage.polygon: non-convex"):
        ResolveScenario(bad)
    with pytest.raises(ScenarioError, match=r"^coverage.trigger_radius"):
        dc.replace(CoverageParams(), trigger_radius=-1.0).Validate()
    CoverageParams().Validate()


def test_bad_radii_and_path_parameters_are_rejected(reference):
    with pytest.raises(ValueError, match=r"min_turning_radius.*r_min = 80.*r = 70"):
        _Zamboni(dc.replace(CoverageParams(), min_turning_radius=80.0))
    with pytest.raises(ValueError, match="swath_spacing"):
        _Zamboni(dc.replace(CoverageParams(), swath_spacing=0.0))
    for c1 in (-1000.1, 1.0, float("nan")):
        with pytest.raises(ValueError, match=r"c1 must be in \[-1000, 0\]"):
            reference.Stages(c1)
    with pytest.raises(ValueError, match="c1 must be in"):
        reference.Replan(reference.Stages(0.0), 3, -2000.0)
    with pytest.raises(ValueError, match="initial.*c1"):
        MakeCoveragePlan(CoverageParams(), VehicleParams(), c1=10.0, k_e=K_E)
    for kw, match in (
        ({"k_e": 0.0}, "k_e"),
        ({"airspeed": -1.0}, "airspeed"),
        ({"start": (0.0, math.nan)}, "start"),
    ):
        with pytest.raises(ValueError, match=match):
            _Zamboni(**kw)
    with pytest.raises(TypeError, match="initial_c1"):
        ZamboniCoverage(CoverageParams(), start=START, airspeed=V_A, k_e=K_E)


def test_make_coverage_plan_uses_the_vehicle():
    vehicle = dc.replace(VehicleParams(), initial_position=[-45.0, 250.0], airspeed=20.0)
    plan = MakeCoveragePlan(CoverageParams(), vehicle, c1=-500.0, k_e=0.07)
    assert plan.initial_c1 == -500.0 and plan.airspeed == 20.0
    first = plan.Stages(-500.0)[0]
    assert first.path.k_e == 0.07
    # The approach runs counter-clockwise from the start's bearing to the circle's left point.
    r2 = TurningRadius2(-500.0, 70.0)
    assert first.path.center == pytest.approx([-115.0 + r2, 146.0])
    bearing = math.atan2(250.0 - 146.0, -45.0 - (-115.0 + r2))
    assert first.length == pytest.approx((math.pi - bearing) * r2, rel=1e-12)
    lo, hi = plan.CoverageTimeBounds((-1000.0, 0.0))
    assert lo == pytest.approx(plan.CoverageTime(-1000.0, 20.0))
    assert hi == pytest.approx(plan.CoverageTime(0.0, 20.0))


def test_plan_remembers_a_copy_of_its_parameters():
    params = CoverageParams()
    plan = _Zamboni(params)
    params.swath_spacing = 20.0
    assert plan.params.swath_spacing == 10.0 and plan.x_d == 10.0


def test_plans_pickle_as_their_definition(reference):
    stages = reference.Stages(-500.0)  # fills the caches
    after = reference.StagesAfter(4, stages[4].anchor, -1000.0)
    copy = pickle.loads(pickle.dumps(reference))
    assert not any(k.startswith("_memo_") for k in vars(copy))
    assert copy.Stages(-500.0) == stages
    assert copy.StagesAfter(4, stages[4].anchor, -1000.0) == after
    assert copy.TimeAfter(4, stages[4].anchor, -1000.0, V_A, (5.0, 0.0)) == (
        reference.TimeAfter(4, stages[4].anchor, -1000.0, V_A, (5.0, 0.0))
    )
    assert (copy.airspeed, copy.initial_c1, copy.c1_bounds) == (V_A, 0.0, reference.c1_bounds)


def test_path_left_and_survey_fraction_on_a_line_and_a_circle(reference):
    approach, down, turn1 = reference.Stages(0.0)[:3]
    # Down-line x = −115 from y = 146 to y = 11 (135 m).
    assert PathLeft(down) == down.length == pytest.approx(135.0)
    assert PathLeft(down, (-115.0, 100.0)) == pytest.approx(89.0, abs=1e-12)
    assert PathLeft(down, (-110.0, 5.0)) == 0.0  # past the trigger
    assert PathLeft(down, (-115.0, 200.0)) == down.length  # before the entry: capped
    # The r1 = 75 m half circle from (−115, 11) around (−40, 11) to (35, 11), counter-clockwise
    # through (−40, −64): a quarter turn is left at its lowest point.
    assert PathLeft(turn1, (-40.0, -64.0)) == pytest.approx(math.pi * 75.0 / 2.0, rel=1e-12)
    assert PathLeft(turn1, (-115.0, 11.0)) == pytest.approx(turn1.length, rel=1e-12)
    assert StageRemaining(approach, (-100.0, 220.0)) == 0.0  # not part of the survey
    assert StageRemaining(turn1, (-40.0, -64.0)) == PathLeft(turn1, (-40.0, -64.0))
    total = reference.SurveyLength(0.0)
    rest = reference.SurveyLengthAfter(2, turn1.anchor, 0.0)
    assert rest == pytest.approx(total - 135.0 - turn1.length)
    assert SurveyFraction(turn1, (-40.0, -64.0), rest, total) == pytest.approx(
        (rest + math.pi * 75.0 / 2.0) / total, rel=1e-12
    )
    assert SurveyFraction(turn1, None, rest, 0.0) == 0.0
    assert SurveyFraction(approach, None, 2.0 * total, total) == 1.0  # clipped to [0, 1]
    assert reference.RemainingFraction(reference.Stages(0.0), 1) == pytest.approx(1.0)


def test_rests_that_share_repetitions_equal_the_rests_of_a_fresh_plan():
    """A rest rebuilt at a stage switch reuses the repetitions built before (each repetition is
    built once per first line, c1 and previous second line): along a flight that changes c1
    at several stages, every rest, its times and TimeAfter equal those of a plan built anew."""
    plan = _Zamboni()
    stages = plan.Stages(0.0)
    i = 0
    for c1 in (-1000.0, -430.0, 0.0, -1000.0, -700.0):
        i = min(i + 3, len(stages) - 2)
        stages = plan.Replan(stages, i, c1)
        for j in range(i, len(stages) - 1):
            stage = stages[j]
            fresh = _Zamboni()
            for c1_rest in (-1000.0, -430.0, 0.0):
                rest = plan.StagesAfter(stage.index, stage.anchor, c1_rest)
                assert rest == fresh.StagesAfter(stage.index, stage.anchor, c1_rest)
                assert plan.TimeAfter(stage.index, stage.anchor, c1_rest, V_A, (4.0, 1.0)) == (
                    float(sum(StageTime(s, V_A, np.array((4.0, 1.0))) for s in rest))
                )


@pytest.mark.parametrize("wind", [(0.0, 0.0), (5.0, -3.0)])
def test_time_after_is_the_sum_of_the_stage_times_after_every_stage(wind):
    # TimeAfter shares the stage times of one repetition's rest between its stages: the result
    # must be, bit for bit, the sum of StageTime over StagesAfter (the staircase the planner sees).
    plan = _Zamboni()
    for c1_flown in (0.0, -1000.0):
        stages = plan.Stages(c1_flown)
        for stage in stages[:-1]:
            for c1 in (-1000.0, -430.0, 0.0):
                rest = plan.StagesAfter(stage.index, stage.anchor, c1)
                expected = float(sum(StageTime(s, V_A, np.array(wind)) for s in rest))
                assert plan.TimeAfter(stage.index, stage.anchor, c1, V_A, wind) == expected
