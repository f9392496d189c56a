"""Boustrophedon cells of non-convex fields with holes: area conserved, cells convex, their
union the field; survey lines and the sweep direction against hand-counted answers."""

import math

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")

from eaplan_drake.field.decompose import (  # noqa: E402
    ChooseSweepDirection,
    Decompose,
    IsConvex,
    SweepLines,
)

U_WITH_HOLE = shapely.Polygon(
    [(0, 0), (400, 0), (400, 300), (250, 300), (250, 150), (150, 150), (150, 300), (0, 300)],
    [[(50, 50), (50, 100), (100, 100), (100, 50)]],
)
STAR_RADII = 200.0 * np.array([1.0, 0.45] * 5)  # a five-pointed star [m]
STAR_ANGLES = np.linspace(0.0, 2 * math.pi, 10, endpoint=False) + 0.1
STAR = shapely.Polygon(
    np.column_stack([STAR_RADII * np.cos(STAR_ANGLES), STAR_RADII * np.sin(STAR_ANGLES)]),
    [[(-20, -20), (-20, 25), (30, 25), (30, -20)]],
)


def Rotated(polygon, degrees):
    from shapely import affinity

    return affinity.rotate(polygon, degrees, origin=(0, 0))


@pytest.mark.parametrize("field", [U_WITH_HOLE, STAR, Rotated(U_WITH_HOLE, 23.0)])
@pytest.mark.parametrize("theta", [0.0, 17.0, 45.0, 90.0, 133.0])
@pytest.mark.parametrize("convex", [True, False])
def test_cells_conserve_area_and_their_union_is_the_field(field, theta, convex):
    d = Decompose(field, theta, convex=convex)
    cells = [shapely.Polygon(c.vertices) for c in d.cells]
    assert all(c.is_valid and c.area > 0.0 for c in cells)
    assert sum(c.area for c in cells) == pytest.approx(field.area, rel=1e-6)
    # the union is the field: every cell inside it, no two overlapping, areas summing to its
    # area; and GEOS's union, snapped to a 1 µm grid (unsnapped, GEOS 3.x drops a cell whose
    # corner lies on another cell's edge at rounding distance), matches it
    assert all(c.difference(field).area <= 1e-9 * field.area for c in cells)
    union = shapely.union_all(cells, grid_size=1e-6)
    assert union.symmetric_difference(field).area <= 1e-6 * field.area
    for i, a in enumerate(cells):  # no overlap: interiors disjoint
        for b in cells[i + 1 :]:
            assert a.intersection(b).area <= 1e-9 * field.area
    if convex:
        assert all(IsConvex(c.vertices) for c in d.cells)
    assert len(d.cells) <= d.trapezoids


def test_a_convex_field_is_one_cell():
    square = Rotated(shapely.Polygon([(0, 0), (100, 0), (100, 100), (0, 100)]), 10.0)
    for theta in (0.0, 10.0, 33.0):
        assert len(Decompose(square, theta).cells) == 1


def test_the_u_with_a_hole_has_the_hand_counted_cells():
    # lines along east: below the hole, either side of it, above it, the two arms
    assert len(Decompose(U_WITH_HOLE, 0.0, convex=False).cells) == 6
    # lines along north: left of the hole's column, the hole's column split in two, the bottom
    # of the notch's column, and the right arm
    assert len(Decompose(U_WITH_HOLE, 90.0, convex=False).cells) == 4


def test_sweep_lines_of_a_rectangle():
    rect = shapely.Polygon([(-120, 11), (180, 11), (180, 146), (-120, 146)])  # 300 m × 135 m
    (cell,) = Decompose(rect, 0.0).cells
    lines = SweepLines(cell, 0.0, 10.0)
    assert len(lines) == 14  # ⌈135 / 10⌉
    ys = [ln[0, 1] for ln in lines]
    np.testing.assert_allclose(np.diff(ys), 10.0, atol=1e-9)
    assert ys[0] - 11.0 == pytest.approx(146.0 - ys[-1], abs=1e-9)  # centred
    for k, ln in enumerate(lines):
        assert np.linalg.norm(ln[1] - ln[0]) == pytest.approx(300.0, abs=1e-9)
        assert (ln[1, 0] > ln[0, 0]) == (k % 2 == 0)  # alternating
    with pytest.raises(ValueError, match=r"line spacing: must be finite and > 0 \[m\], got 0"):
        SweepLines(cell, 0.0, 0.0)


@pytest.mark.parametrize("angle", [0.0, 30.0, 72.5, 150.0])
def test_the_sweep_direction_of_a_long_strip_is_along_it(angle):
    strip = Rotated(shapely.Polygon([(0, 0), (600, 0), (600, 80), (0, 80)]), angle)
    choice = ChooseSweepDirection(strip, 10.0)
    assert choice.decomposition.theta_deg == pytest.approx(angle % 180.0, abs=1e-6)
    assert choice.lines == 8
    assert choice.line_length == pytest.approx(8 * 600.0, rel=1e-9)


def test_the_chosen_direction_has_the_fewest_lines_of_a_grid():
    choice = ChooseSweepDirection(STAR, 10.0, step_deg=5.0)
    for theta in range(0, 180, 15):
        d = Decompose(STAR, float(theta))
        n = sum(len(SweepLines(c, float(theta), 10.0)) for c in d.cells)
        assert choice.lines <= n
