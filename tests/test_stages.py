"""A plan's stages (eaplan_drake.flight.stages): the ground speed in wind, the time and the length
of a stage."""

import dataclasses as dc
import math

import numpy as np
import pytest

from eaplan_drake.flight.coverage import MakeCoveragePlan
from eaplan_drake.flight.paths import Circle
from eaplan_drake.flight.stages import (
    ArcStart,
    ArcStartTime,
    GroundSpeed,
    PathLength,
    Stage,
    StagePoints,
    StageTime,
)
from eaplan_drake.params import GuidanceParams, Scenario

V_A = 15.0  # the reference airspeed [m/s]
K_E = GuidanceParams().k_e


def test_ground_speed_and_stage_time_in_wind():
    w = (5.0, 0.0)
    assert GroundSpeed((1.0, 0.0), V_A, w) == pytest.approx(20.0)
    assert GroundSpeed((-1.0, 0.0), V_A, w) == pytest.approx(10.0)
    assert GroundSpeed((0.0, 1.0), V_A, w) == pytest.approx(math.sqrt(200.0))
    # A half circle (bottom, downwind) against an independent time integration of the arc.
    c = Circle((0.0, 0.0), 75.0, s=-1.0, k_e=K_E)
    st = Stage(0, c, (75.0, 0.0), 1, 0.0, (-75.0, 0.0), math.pi * 75.0)
    theta, t, h = math.pi, 0.0, 1e-3  # ccw from 180° through 270° to 360°
    while theta < 2 * math.pi:
        course = (-math.sin(theta), math.cos(theta))
        dtheta = GroundSpeed(course, V_A, w) / 75.0
        step = min(h, (2 * math.pi - theta) / dtheta)
        theta += dtheta * step
        t += step
    assert StageTime(st, V_A, w) == pytest.approx(t, rel=1e-5)
    assert StageTime(st, V_A) == pytest.approx(math.pi * 75.0 / V_A)
    with pytest.raises(ValueError, match="wind"):
        StageTime(st, V_A, (15.0, 0.0))


@pytest.mark.parametrize("radius", [75.0, 17.320508075688775, 123.4567])
def test_an_arc_is_timed_from_its_start_as_its_stage(radius):
    """ArcStartTime of the wind-free ArcStart (what a plan keeps per arc) is StageTime, bit for
    bit, in still air and in wind, for both directions and any entry."""
    for s in (-1.0, 1.0):
        c = Circle((312.25, -48.5), radius, s=s, k_e=K_E)
        for angle in (0.0, 1.0, -2.5, math.pi):
            entry = (312.25 + radius * math.cos(angle), -48.5 + radius * math.sin(angle))
            st = Stage(0, c, entry, 1, 0.0, entry, 0.75 * math.pi * radius)
            for wind in ((0.0, 0.0), (-0.0, 0.0), (5.0, -3.0), (-7.5, 11.25), (0.0, 9.0)):
                time = ArcStartTime(ArcStart(c, entry), st.length, V_A, *wind)
                assert time == StageTime(st, V_A, wind), (s, angle, wind)


def test_path_length_helper():
    c = Circle((0.0, 0.0), 10.0, s=-1.0, k_e=K_E)  # ccw
    assert PathLength(c, (10.0, 0.0), (0.0, 10.0)) == pytest.approx(math.pi * 5.0)
    assert PathLength(c, (0.0, 10.0), (10.0, 0.0)) == pytest.approx(math.pi * 15.0)
    cw = dc.replace(c, s=1.0)
    assert PathLength(cw, (10.0, 0.0), (0.0, 10.0)) == pytest.approx(math.pi * 15.0)


def test_stage_points_follow_the_circle_from_entry_to_trigger():
    plan = MakeCoveragePlan(Scenario().coverage, Scenario().vehicle, c1=0.0, k_e=0.05)
    stage = next(s for s in plan.Stages(0.0) if s.is_circle and s.primitive >= 0)
    pts = StagePoints(stage, step=1.0)
    r = np.linalg.norm(pts - np.asarray(stage.path.center), axis=1)
    np.testing.assert_allclose(r, stage.path.radius, atol=1e-9)
    np.testing.assert_allclose(pts[0], stage.entry, atol=1e-9)
    np.testing.assert_allclose(pts[-1], stage.trigger, atol=1e-6)
    length = np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert length == pytest.approx(stage.length, rel=1e-3)
    line = next(s for s in plan.Stages(0.0) if not s.is_circle)
    np.testing.assert_allclose(StagePoints(line), [line.entry, line.trigger])
