"""The survey polygon (eaplan_drake.flight.polygon) in the local frame of one of its edges."""

import pytest

from eaplan_drake.flight.polygon import CoveragePolygon


def test_polygon_band_extent_of_a_triangle():
    poly = CoveragePolygon([[0.0, 0.0], [0.0, 100.0], [100.0, 0.0]], line_edge=0)
    # Edge 0 is the y-axis; e2 = +x; e1 = −y: ξ = −y. At x = 50 the chord is y ∈ [0, 50].
    assert poly.width == pytest.approx(100.0)
    assert poly.Chord(50.0) == pytest.approx((-50.0, 0.0))
    assert poly.BandExtent(50.0, 5.0) == pytest.approx((-55.0, 0.0))
