"""Plan files (paper 002 Appendix I): whitelisted expression parser, quadratic forms, the
authors' reference plans."""

import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from eaplan_drake.flight.coverage import ZamboniCoverage
from eaplan_drake.flight.planfile import (
    REFERENCE_PLAN,
    LoadPlanFile,
    ParseExpression,
    PlanFile,
    PlanFileError,
    QuadraticForm,
    ReadPlanFile,
)
from eaplan_drake.flight.stages import APPROACH, ArcAngle
from eaplan_drake.logfit.powerlog import ReferenceDirectory
from eaplan_drake.params import CoverageParams, GuidanceParams, Scenario, VehicleParams
from eaplan_drake.resolve import MakePlanSource

REFERENCE_DIR = ReferenceDirectory()
DYN_PLAN = REFERENCE_DIR / "dyn_plan_specification.pln"
STATIC_PLAN = REFERENCE_DIR / "plan_specification.pln"
K_E = GuidanceParams().k_e
START = (-100.0, 220.0)
KW = {"k_e": K_E, "start": START, "airspeed": 15.0, "initial_c1": 0.0, "c1_bounds": (-1000.0, 0.0)}


def _Zamboni():
    return ZamboniCoverage(CoverageParams(), start=START, airspeed=15.0, initial_c1=0.0, k_e=K_E)


@pytest.mark.parametrize(
    "text, env, value",
    [
        ("1+2*3", {}, 7.0),
        ("(1+2)*3", {}, 9.0),
        ("-2^2", {}, -4.0),  # unary minus binds looser than ^
        ("2^3^2", {}, 512.0),  # ^ is right-associative
        ("2^-1", {}, 0.5),
        ("8/4/2", {}, 1.0),  # left-associative
        ("1e-3*1000 + .5", {}, 1.5),
        ("sqrt(4900+c1)", {"c1": -1000.0}, math.sqrt(3900.0)),
        ("(x+45)^2+(y-146)^2-4900", {"x": -115.0, "y": 146.0}, 0.0),
        ("-115+2*75-2*sqrt(4900+c1)", {"c1": 0.0}, -105.0),
        ("--x", {"x": 3.0}, 3.0),
    ],
)
def test_expression_values(text, env, value):
    assert ParseExpression(text)(**env) == pytest.approx(value)


@pytest.mark.parametrize(
    "text, col, match",
    [
        ("exp(x)", 1, "unknown name 'exp'"),
        ("__import__('os')", 1, "unknown name '__import__'"),
        ("x+", 3, "expected a number.*end of expression"),
        ("(x+1", 5, r"expected '\)'"),
        ("3 $ 4", 3, r"unexpected character '\$'"),
        ("x y", 3, "unexpected 'y' after a complete expression"),
        ("sqrt x", 6, r"expected '\('"),
        ("2**3", 3, "expected a number"),
    ],
)
def test_expression_errors_name_the_column(text, col, match):
    with pytest.raises(ValueError, match=rf"column {col}: {match}"):
        ParseExpression(text)


def test_expression_domain_errors():
    with pytest.raises(ValueError, match="column 1: sqrt of a negative"):
        ParseExpression("sqrt(4900+c1)")(c1=-5000.0)
    with pytest.raises(ValueError, match="column 2: division by zero"):
        ParseExpression("1/(x-1)")(x=1.0)
    with pytest.raises(ValueError, match="non-integer power"):
        ParseExpression("x^0.5")(x=-1.0)


def test_quadratic_form_identification():
    circle = ParseExpression("(x+45)^2+(y-146)^2-4900")
    assert QuadraticForm(circle) == (1.0, 90.0, -292.0, 45**2 + 146**2 - 4900)  # exact
    assert QuadraticForm(ParseExpression("x-35")) == (0.0, 1.0, 0.0, -35.0)
    # c1 enters through constant sub-expressions, evaluated with the domain checks.
    shifted = ParseExpression("(x-sqrt(4900+c1))^2/2+y^2/2-c1")
    r = math.sqrt(3900.0)
    assert QuadraticForm(shifted, -1000.0) == pytest.approx((0.5, -r, 0.0, r * r / 2 + 1000.0))
    assert QuadraticForm(ParseExpression("x^2+y^2-(c1+1)^2"), 1.0) == (1.0, 0.0, 0.0, -4.0)
    for bad, match in (
        ("x^3+y", "power of x or y.*degree <= 2"),
        ("(x^2+y)^2", "degree > 2"),
        ("sqrt(x^2+y^2)-10", "column 1: .*sqrt of x or y"),
        ("1/x", "column 2: .*division of x or y"),
        ("x^0.5+y", "column 2: .*power of x or y"),
        ("x^y", "power of x or y"),
        ("x*y-1", "x·y"),
        ("x^2+2*y^2-1", "equal x² and y²"),
    ):
        with pytest.raises(ValueError, match=match):
            QuadraticForm(ParseExpression(bad))
    with pytest.raises(ValueError, match="sqrt of a negative"):
        QuadraticForm(ParseExpression("x+sqrt(c1)"), -1.0)


def test_reference_plan_reads_into_the_generated_geometry():
    plan = ReadPlanFile(**KW)  # packaged plan_specification.pln
    assert plan.shift == (-10.0, -1.0)
    stages = plan.Stages(0.0)
    assert len(stages) == 60
    assert [s.primitive for s in stages[:6]] == [APPROACH, 0, 1, 2, 3, 0]
    assert stages[-1].trigger == (175.0, 161.0)
    generated = _Zamboni().Stages(0.0)
    for a, b in zip(stages, generated, strict=True):
        assert a.primitive == b.primitive
        assert a.path.is_circle == b.path.is_circle
        assert a.path.s == b.path.s
        if a.path.is_circle:
            assert a.path.radius == pytest.approx(b.path.radius)
            # The authors drift y by 1 m per repetition; x matches.
            assert a.path.center[0] == pytest.approx(b.path.center[0])
        else:
            np.testing.assert_allclose(a.path.descriptor(), b.path.descriptor(), atol=1e-9)
        assert a.trigger[0] == pytest.approx(b.trigger[0])
        assert a.path.k_e == GuidanceParams().k_e
    assert plan.specs[0].file_k_e == 0.0003 and plan.specs[1].file_k_e == 0.05


def test_direction_zero_flies_the_first_circle_counter_clockwise():
    first = ReadPlanFile(**KW).Stages(0.0)[0]
    assert first.path.center == pytest.approx([-45.0, 146.0])
    assert first.path.radius == pytest.approx(70.0)
    assert first.path.s == -1.0
    # From the start (−100, 220) down to (−115, 146): a short counter-clockwise arc (53°), and the
    # direction of travel at the trigger is −y, straight into the down-line x = −115.
    assert math.degrees(ArcAngle(first.path, (-100.0, 220.0), first.trigger)) == pytest.approx(
        53.38, abs=0.01
    )
    assert first.TriggerTangent() == pytest.approx([0.0, -1.0])
    top = first.path.tangent((-45.0, 216.0))
    assert top[0] < 0 and abs(top[1]) < 1e-12  # at the top it travels towards −x: ccw
    lines = ReadPlanFile(**KW).Stages(0.0)[1:4:2]  # x+115 (direction 1), x-35 (direction 0)
    assert lines[0].TriggerTangent() == pytest.approx([0.0, -1.0])
    assert lines[1].TriggerTangent() == pytest.approx([0.0, 1.0])


@pytest.mark.authors_data
def test_dynamic_plan_at_c1_zero_equals_the_static_one():
    static = ReadPlanFile(STATIC_PLAN, **KW).Stages(0.0)
    dyn = ReadPlanFile(DYN_PLAN, **KW)
    assert dyn.specs[-1].trigger_line == 202  # the fixed final point (175, 161)
    for a, b in zip(dyn.Stages(0.0), static, strict=True):
        np.testing.assert_allclose(a.path.descriptor(), b.path.descriptor(), atol=1e-9)
        assert a.trigger == pytest.approx(b.trigger)
    low = dyn.Stages(-1000.0)
    assert low[0].path.radius == pytest.approx(math.sqrt(3900.0))
    assert low[4].path.radius == pytest.approx(math.sqrt(3900.0))
    assert low[5].trigger[0] == pytest.approx(-115.0 + 150.0 - 2 * math.sqrt(3900.0))
    # Re-planning re-evaluates only the later stages.
    replanned = dyn.Replan(dyn.Stages(0.0), 10, -1000.0)
    assert replanned[:11] == dyn.Stages(0.0)[:11]
    assert replanned[11:] == low[11:]


def _read(text, **kw):
    return ReadPlanFile(text=text, **{**KW, **kw})


@pytest.mark.parametrize(
    "text, match",
    [
        ("0.1;0;x-1\n0,0\n0.1;1;x*y\n1,1\n", r"<text>:3: path 'x\*y'.*x·y"),
        ("0.1;0;x-1\n0,0\n0.1;2;x-1\n1,1\n", r"<text>:3:5: direction must be 0, 1, 90 or 270"),
        ("0.1;0;x-+\n0,0\n", r"<text>:1:10: expected a number.*found end"),
        ("0.1;0;x-1;2\n0,0\n", r"<text>:1:1: a stage is 'k_e;direction;equation'"),
        ("0.1;0;x-1\n0.1;0;y-1\n1,1\n", r"<text>:2:1: stage of line 1 has no triggering point"),
        ("0.1;0;x-1\n0,0,1\n", r"<text>:2:1: a triggering point must be two"),
        ("0.1;0;x-1\n0,y\n", r"<text>:2:3: a triggering point may depend on c1 only, not on y"),
        ("0.1;0;x^2+y^2+1\n0,0\n", r"<text>:1: path .*no real circle"),
        ("0.1;0;5\n0,0\n", r"<text>:1: path '5'.*does not depend on x or y"),
        ("0.1;0;x-1\n0,0\n0.1;1;y-1\n", r"<text>:3: the last stage has no triggering"),
        ("0.1;0;x+sqrt(c1)\n0,0\n", r"<text>:1: path .*c1 = -1000.*sqrt of a negative"),
        ("% only comments\n\n", r"<text>: no stages"),
        ("1,2\n3,4\n", r"<text>:2:1: expected a stage"),
        ("0.1;0;x-1\n0,0\n[0,1\n", r"<text>:3:1: a constraint set"),
        ("0.1;0;x-1;\n", r"<text>:1:1: a stage is"),
        ("x;0;x-1\n0,0\n", r"<text>:1:1: k_e must be a number"),
    ],
)
def test_bad_plan_files_name_line_and_column(text, match):
    with pytest.raises(PlanFileError, match=match):
        _read(text)


def test_plan_file_comments_bounds_and_paper_002_directions():
    text = """% a plan in the paper-002 style
    0.0003; 90; (x+45)^2+(y-146)^2-4900+c1   % circle, rotation E
    -sqrt(4900+c1)-45,146
    [-3*10^3,0]
    [2,10]
    0.05;270;x+sqrt(4900+c1)+45
    -sqrt(4900+c1)-45,11
    """
    plan = _read(text, c1_bounds=(-1000.0, 0.0), start=(-45.0, 300.0))
    assert plan.shift is None
    assert plan.specs[0].bounds == ((-3000.0, 0.0), (2.0, 10.0))
    first, second = plan.Stages(0.0)
    assert first.path.s == -1.0 and second.path.s == 1.0
    assert second.TriggerTangent() == pytest.approx([0.0, -1.0])
    # The paper-002 circle shrinks as c1 falls: radius sqrt(4900 − c1)... (their sign) at −1000.
    assert plan.Stages(-1000.0)[0].path.radius == pytest.approx(math.sqrt(5900.0))


def test_final_point_argument_completes_a_plan_without_one():
    plan = _read("0.1;0;x-1\n1,0\n0.1;0;y\n", final_point=(-50.0, 0.0), start=(1.0, -20.0))
    last = plan.Stages(0.0)[-1]
    assert last.trigger == (-50.0, 0.0)
    assert last.length == pytest.approx(51.0)


def test_plan_file_missing_and_bad_arguments(tmp_path):
    with pytest.raises(PlanFileError, match="no such plan file"):
        ReadPlanFile(tmp_path / "nope.pln", **KW)
    with pytest.raises(ValueError, match="k_e"):
        ReadPlanFile(**{**KW, "k_e": -1.0})
    with pytest.raises(ValueError, match="c1 must be in"):
        ReadPlanFile(**KW).Stages(10.0)
    with pytest.raises(ValueError, match=r"PlanFile.initial_c1: .*\[-1000, 0\]"):
        ReadPlanFile(**{**KW, "initial_c1": 5.0})
    with pytest.raises(ValueError, match="PlanFile.airspeed"):
        ReadPlanFile(**{**KW, "airspeed": 0.0})
    with pytest.raises(TypeError, match="c1_bounds"):
        ReadPlanFile(k_e=K_E, start=START, airspeed=15.0, initial_c1=0.0)


def test_load_plan_file_for_a_scenario():
    vehicle = VehicleParams(airspeed=16.0)
    plan = LoadPlanFile("reference", vehicle, c1=-200.0, k_e=0.03, c1_bounds=(-1000.0, 0.0))
    assert Path(REFERENCE_PLAN).is_file()
    assert plan.initial_c1 == -200.0 and plan.airspeed == 16.0
    assert tuple(plan.start) == tuple(vehicle.initial_position)
    assert plan.CoverageTimeBounds()[1] == pytest.approx(plan.CoverageTime(0.0, 16.0))
    assert plan.Stages(0.0)[5].path.k_e == 0.03
    t_lo, t_hi = plan.CoverageTimeBounds((-1000.0, 0.0), airspeed=15.0)
    assert t_lo == t_hi  # the static plan does not depend on c1
    # The authors' plan is 1 m per repetition longer on each line than ours: ≈ 716 s at 15 m/s.
    assert t_hi == pytest.approx(_Zamboni().CoverageTime(0.0, 15.0) + 1.0, abs=0.5)


def test_make_plan_source_builds_the_scenarios_plan():
    scenario = Scenario()
    scenario.vehicle.airspeed = 17.0
    scenario.guidance.k_e = 0.04
    plan = MakePlanSource(scenario, initial_c1=-300.0)
    assert isinstance(plan, ZamboniCoverage)
    assert (plan.airspeed, plan.initial_c1, plan.k_e) == (17.0, -300.0, 0.04)
    assert tuple(plan.start) == tuple(scenario.vehicle.initial_position)
    scenario.coverage.plan_file = "reference"
    scenario.planner.path_parameter_bounds = [-800.0, 0.0]
    pln = MakePlanSource(scenario, initial_c1=0.0)
    assert isinstance(pln, PlanFile) and pln.c1_bounds == (-800.0, 0.0)
    assert (pln.airspeed, pln.k_e) == (17.0, 0.04)


def test_plan_file_pickles():
    plan = ReadPlanFile(**KW)
    stages = plan.Stages(-1000.0)
    copy = pickle.loads(pickle.dumps(plan))
    assert copy.Stages(-1000.0) == stages
    assert copy.source == plan.source and copy.c1_bounds == plan.c1_bounds
