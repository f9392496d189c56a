"""The route over a decomposed field: continuity, turn circles through their end points, the
Zamboni-like order, and the time and energy against a hand computation."""

import math

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")

from eaplan_drake.field.decompose import Decompose  # noqa: E402
from eaplan_drake.field.route import (  # noqa: E402
    Leg,
    MakeRoute,
    Route,
    RouteEnergy,
    TurnLegs,
    ZamboniOrder,
)

U_WITH_HOLE = shapely.Polygon(
    [(0, 0), (600, 0), (600, 500), (350, 500), (350, 250), (250, 250), (250, 500), (0, 500)],
    [[(80, 80), (80, 160), (160, 160), (160, 80)]],
)


def test_zamboni_order_visits_every_line_once_and_jumps_far():
    for n, jump in [(30, 15), (7, 3), (5, 15), (1, 4), (44, 13)]:
        order = ZamboniOrder(n, jump)
        assert sorted(order) == list(range(n))
    assert ZamboniOrder(30, 14)[:5] == [0, 15, 1, 16, 2]  # the reference: x_d 10, r 70 m
    jumps = np.abs(np.diff(ZamboniOrder(30, 14)))
    assert jumps.min() >= 14


def test_a_cell_of_a_full_block_or_more_has_no_turn_closer_than_the_jump():
    """Every order of n ≥ 2(J + 1) lines joins lines at least J apart (no Ω turn): across
    block boundaries (every other block from its upper half) and in a merged short last
    block; a narrower cell is one block, as before."""
    for jump in range(1, 16):
        for n in range(2 * (jump + 1), 8 * (jump + 1) + 3):
            order = ZamboniOrder(n, jump)
            assert sorted(order) == list(range(n)), (n, jump)
            assert np.abs(np.diff(order)).min() >= jump, (n, jump)
    assert ZamboniOrder(8, 3) == [0, 4, 1, 5, 2, 6, 3, 7]
    assert ZamboniOrder(16, 3) == [0, 4, 1, 5, 2, 6, 3, 7, 12, 8, 13, 9, 14, 10, 15, 11]
    assert ZamboniOrder(11, 3) == [0, 6, 1, 7, 2, 8, 3, 9, 4, 10, 5]  # 8 + 3 merged
    assert ZamboniOrder(5, 15) == [0, 3, 1, 4, 2]  # narrower than a block: as before


def _Heading(leg, where: str) -> np.ndarray:
    """Unit direction of travel at the start or end of a leg."""
    if leg.radius == 0.0:
        v = np.subtract(leg.end, leg.start)
        return v / np.linalg.norm(v)
    p = np.subtract(leg.start if where == "start" else leg.end, leg.center) / leg.radius
    return np.array([-p[1], p[0]]) if leg.ccw else np.array([p[1], -p[0]])


@pytest.mark.parametrize("theta", [0.0, 90.0, 30.0])
def test_the_route_is_continuous_and_its_turns_are_flyable(theta):
    r_min = 62.45
    d = Decompose(U_WITH_HOLE, theta)
    route = MakeRoute(d, 10.0, r_min)
    legs = route.legs
    for a, b in zip(legs[:-1], legs[1:], strict=True):
        np.testing.assert_allclose(a.end, b.start, atol=1e-9)
    for leg in legs:
        if leg.kind != "line" and leg.radius > 0.0:  # an arc of a turn or a transit
            assert leg.radius >= r_min - 1e-9
            for p in (leg.start, leg.end):  # the circle passes through both ends
                assert np.hypot(*(np.subtract(p, leg.center))) == pytest.approx(
                    leg.radius, abs=1e-6
                )
            assert leg.length == pytest.approx(leg.radius * leg.angle, rel=1e-12)
            assert 0.0 < leg.angle < 2 * math.pi
    for a, b in zip(legs[:-1], legs[1:], strict=True):  # every leg tangent to the next
        if b.kind != "transit" and a.kind != "transit":
            np.testing.assert_allclose(_Heading(a, "end"), _Heading(b, "start"), atol=1e-9)
    lines = route.Count("line")
    assert route.turns == lines - len(d.cells)  # one per line but the last of each cell
    assert route.Length() == pytest.approx(sum(leg.length for leg in legs), rel=1e-12)


def test_lines_far_apart_are_joined_by_quarter_circles_and_a_straight_piece():
    """Lines w ≥ 2 r_min apart with level ends: the Dubins turn is a quarter circle of r_min, a
    straight piece of w − 2 r_min across the lines and another quarter circle (one half circle
    when w = 2 r_min)."""
    rect = shapely.Polygon([(0, 0), (300, 0), (300, 300), (0, 300)])  # 30 lines at 10 m
    route = MakeRoute(Decompose(rect, 0.0), 10.0, 70.0)  # J = 14: turns 150 m and 140 m wide
    turns = route.TurnGroups()
    assert len(turns) == route.turns == 29
    for k, turn in enumerate(turns[:4]):
        arcs = [leg for leg in turn if leg.radius > 0.0]
        assert all(a.radius == pytest.approx(70.0, abs=1e-9) for a in arcs)
        assert sum(a.angle for a in arcs) == pytest.approx(math.pi, abs=1e-9)
        width = 150.0 if k % 2 == 0 else 140.0  # 140 = 2 r_min: one half circle
        assert sum(leg.length for leg in turn) == pytest.approx(70.0 * math.pi + width - 140.0)
    assert route.loops == 0
    assert route.Count("line") == 30


def test_route_energy_is_power_times_time():
    rect = shapely.Polygon([(0, 0), (300, 0), (300, 300), (0, 300)])
    route = MakeRoute(Decompose(rect, 0.0), 10.0, 70.0)
    v, p0, p2, g = 15.0, 25.0, 0.5, 3.0
    time, energy, mean = RouteEnergy(route, v, (p0, p2), g)
    assert time == pytest.approx(route.Length() / v, rel=1e-12)
    expected = sum(
        leg.length / v * (p0 + g + (p2 * (v / leg.radius) ** 2 if leg.radius > 0.0 else 0.0))
        for leg in route.legs
    )
    assert energy == pytest.approx(expected, rel=1e-12)
    assert mean == pytest.approx(energy / time, rel=1e-12)
    with pytest.raises(ValueError, match=r"airspeed: must be > 0 \[m/s\], got 0"):
        RouteEnergy(route, 0.0, (p0, p2), g)


def test_loops_count_the_turns_of_three_arcs_not_a_long_arc_before_a_straight_piece():
    """Route.loops counts the Ω turns (three arcs, lines closer than 2 r_min), not a turn whose
    one arc is longer than a half circle because the next line starts behind the last one's end
    (arc, straight piece, arc)."""
    r_min, east, west = 70.0, np.array([1.0, 0.0]), np.array([-1.0, 0.0])

    def RouteOf(next_start):
        line = Leg("line", (-200.0, 0.0), (0.0, 0.0), 200.0, cell=0)
        turn = TurnLegs(np.zeros(2), east, np.asarray(next_start), west, r_min, 0)
        back = Leg("line", tuple(next_start), (next_start[0] - 200.0, 10.0), 200.0, cell=0)
        return Route((line, *turn, back), 0.0, 10.0, r_min), turn

    omega, turn = RouteOf((0.0, 10.0))  # 10 m apart, starting level: an Ω turn
    assert [leg.radius > 0.0 for leg in turn] == [True, True, True]
    assert omega.loops == 1 and omega.turns == 1
    behind, turn = RouteOf((-300.0, 10.0))  # starting far behind: arc, straight, arc
    assert [leg.radius > 0.0 for leg in turn] == [True, False, True]
    assert max(leg.angle for leg in turn) > math.pi + 0.1  # the old count took it for a loop
    assert behind.loops == 0 and behind.turns == 1
