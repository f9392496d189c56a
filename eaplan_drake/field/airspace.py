"""The airspace a field survey declares: the field plus a margin for the turns beyond it, the
missions' geofence, and the check that a route lies inside it.

Turns leave the field: a survey line runs over its cell's extent within its swath band, so its
end lies up to half a spacing d/2 beyond a slanted edge, and a turn between two lines w apart
reaches beyond the line ends by

    E(R, w) = R                                  (w ≥ 2R: two quarter circles and a straight piece)
    E(R, w) = R + √(4R² − (R + w/2)²)            (w < 2R: the three-arc Ω turn; ≤ (1 + √3) R),

with R the turn's ground radius (:func:`TurnExcursion`). The route's turns have radius r_min
(``coverage.min_turning_radius``). In wind w [m/s] an aircraft at its bank limit φ_max turns on a
ground radius up to r_a ((v_a + w)/v_a)², r_a = v_a² / (g tan φ_max) its still-air minimum radius
(the tailwind part of a turn, ground speed v_a + w); where that exceeds r_min the turns grow
by the factor k = max(1, r_a ((v_a + w)/v_a)² / r_min) (:func:`TurnStretch`). The default margin
(``coverage.airspace_margin`` < 0) is therefore

    M = e_line + k (e_route − e_line) + δ

with e_route the largest distance of the still-air route (lines, turns and transits) from the
field, e_line that of its lines (≤ d/2), and δ = :data:`TRACKING_ALLOWANCE` for the guidance's
overshoot where a turn begins and ends (:func:`AirspaceMargin`). It is also the smallest margin
that works: a smaller ``coverage.airspace_margin`` is refused in one line naming it.

The airspace (:func:`MakeAirspace`) is the field's outer boundary (its holes are not surveyed,
and may be overflown) buffered by M, with corridors of half-width M along the legs from home to
the route and back; the missions' inclusion geofence is that polygon, and the exclusion fences
are only the no-fly polygons (a route that keeps out of them:
:mod:`eaplan_drake.field.nofly`). :func:`PointsOutside` counts the points of a route that leave
it.

Lengths in m, speeds in m/s, angles in degrees.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.field.geodesy import Require
from eaplan_drake.field.readers import Field
from eaplan_drake.field.route import Route

__all__ = [
    "GRAVITY",
    "LegPoints",
    "TRACKING_ALLOWANCE",
    "Airspace",
    "AirspaceError",
    "AirspaceMargin",
    "MakeAirspace",
    "PointsOutside",
    "RoutePoints",
    "TurnExcursion",
    "TurnStretch",
]

GRAVITY = 9.80665
"""g [m/s²]."""

TRACKING_ALLOWANCE = 10.0
"""δ [m]: how far the guidance overshoots a turn's circle where it begins and ends (the course
error the vector field takes a few seconds to remove), added to the default margin."""


class AirspaceError(ValueError):
    """A margin or no-fly polygon the route cannot keep; one line naming the key."""


def TurnExcursion(radius: float, width: float) -> float:
    """E(R, w) [m]: how far beyond the line ends a turn of ground radius R [m] between lines w [m]
    apart reaches (module docstring)."""
    R, w = float(radius), float(width)
    if w >= 2.0 * R:
        return R
    return R + math.sqrt(max(4.0 * R * R - (R + 0.5 * w) ** 2, 0.0))


def TurnStretch(airspeed: float, wind: float, max_bank_deg: float, min_radius: float) -> float:
    """k = max(1, r_a ((v_a + w)/v_a)² / r_min) [-] with r_a = v_a² / (g tan φ_max): how much the
    wind stretches the route's turns of radius r_min [m] (module docstring)."""
    v, w = float(airspeed), abs(float(wind))
    r_air = v * v / (GRAVITY * math.tan(math.radians(max_bank_deg)))
    return max(1.0, r_air * ((v + w) / v) ** 2 / float(min_radius))


def LegPoints(leg, step: float = 2.0) -> np.ndarray:
    """Points [m] (k × 2) along one leg, from its start to its end, every ≈ ``step`` [m]."""
    n = 2 + int(leg.length / step)
    if leg.radius > 0.0:
        c = np.asarray(leg.center, dtype=float)
        a0 = math.atan2(leg.start[1] - c[1], leg.start[0] - c[0])
        a = a0 + (1.0 if leg.ccw else -1.0) * np.linspace(0.0, leg.angle, n)
        return c + leg.radius * np.column_stack([np.cos(a), np.sin(a)])
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1.0 - t) * np.asarray(leg.start, dtype=float) + t * np.asarray(leg.end, dtype=float)


def RoutePoints(route: Route, step: float = 2.0, kinds=None) -> np.ndarray:
    """Points [m] (k × 2) along ``route``'s legs (of ``kinds``, default all), every ≈ ``step``
    [m] (:func:`LegPoints`): the path the aircraft flies, arcs included."""
    out = [LegPoints(leg, step) for leg in route.legs if kinds is None or leg.kind in kinds]
    return np.concatenate(out) if out else np.zeros((0, 2))


def _Excursion(polygon, points: np.ndarray) -> float:
    shapely = Require("shapely")
    if len(points) == 0:
        return 0.0
    return float(np.max(shapely.distance(polygon, shapely.points(points))))


def AirspaceMargin(route: Route, field: Field, scenario) -> dict:
    """The default margin M [m] of ``route`` over ``field`` in ``scenario``'s wind, with its
    parts (module docstring): ``margin``, ``line_m`` (e_line), ``route_m`` (e_route),
    ``stretch`` (k), ``allowance`` (δ)."""
    shapely = Require("shapely")
    outline = shapely.Polygon(field.exterior)
    e_line = _Excursion(outline, RoutePoints(route, kinds=("line",)))
    e_route = _Excursion(outline, RoutePoints(route, kinds=("line", "turn", "transit")))
    vehicle = scenario.vehicle
    k = TurnStretch(
        vehicle.airspeed,
        scenario.wind.speed,
        vehicle.max_bank_angle_deg,
        route.min_turning_radius,
    )
    margin = e_line + k * max(e_route - e_line, 0.0) + TRACKING_ALLOWANCE
    return {
        "margin": margin,
        "line_m": e_line,
        "route_m": e_route,
        "stretch": k,
        "allowance": TRACKING_ALLOWANCE,
    }


@dc.dataclass(frozen=True)
class Airspace:
    """The airspace a mission declares, in the local frame [m]."""

    polygon: object
    """The inclusion polygon (a ``shapely.Polygon``, no holes)."""
    no_fly: tuple
    """The no-fly polygons (``shapely.Polygon``), the exclusion fences."""
    margin: float
    """M [m]."""
    required: dict
    """:func:`AirspaceMargin` of the route: the smallest margin that works, and its parts."""

    def Fence(self):
        """The :class:`~eaplan_drake.field.missions.Fence` the missions write."""
        from eaplan_drake.field.missions import Fence

        ring = np.asarray(self.polygon.exterior.coords, dtype=float)[:-1]
        holes = tuple(np.asarray(p.exterior.coords, dtype=float)[:-1] for p in self.no_fly)
        return Fence(ring, holes)


def MakeAirspace(
    route: Route,
    field: Field,
    scenario,
    *,
    margin: float | None = None,
    home=None,
    extra_points=(),
    no_fly=(),
    key: str = "coverage.airspace_margin",
) -> Airspace:
    """The :class:`Airspace` of ``route`` over ``field``: the field's outline buffered by
    ``margin`` [m] (None or < 0: :func:`AirspaceMargin`'s default), with corridors of the same
    half-width from ``home`` [m] to the route and back and to each of ``extra_points`` (e.g. a
    landing's approach fix), minus nothing: ``no_fly`` polygons [m] are the exclusion fences.

    Raises :class:`AirspaceError` (one line naming ``key``) when ``margin`` is below the
    smallest that works, or when the route enters a no-fly polygon."""
    shapely = Require("shapely")
    required = AirspaceMargin(route, field, scenario)
    smallest = required["margin"]
    if margin is None or margin < 0.0:
        margin = smallest
    elif margin < smallest - 1e-9:
        raise AirspaceError(
            f"{key}: {margin:g} m is too small for this route: it reaches "
            f"{required['route_m']:.1f} m beyond the field in still air (its turns × "
            f"{required['stretch']:.3f} in the wind, + {required['allowance']:g} m tracking); the "
            f"smallest that works is {math.ceil(smallest * 10.0) / 10.0:.1f} m"
        )
    tolerance = 1.0
    shapes = [shapely.Polygon(field.exterior)]
    if home is not None:
        home = tuple(float(v) for v in home)
        ends = [route.legs[0].start, route.legs[-1].end, *[tuple(p) for p in extra_points]]
        shapes += [shapely.LineString([home, tuple(e)]) for e in ends if math.dist(home, e) > 0]
        shapes.append(shapely.Point(home))
    region = shapely.unary_union([s.buffer(margin + tolerance, quad_segs=8) for s in shapes])
    if region.geom_type != "Polygon":  # corridors always join the field; keep the largest
        region = max(region.geoms, key=lambda g: g.area)
    polygon = shapely.Polygon(region.exterior).simplify(tolerance)
    polygon = shapely.geometry.polygon.orient(polygon, 1.0)
    zones = tuple(shapely.Polygon(p) for p in no_fly)
    for i, zone in enumerate(zones):
        if zone.intersects(shapely.LineString(RoutePoints(route))):
            raise AirspaceError(
                f"no-fly polygon {i}: the route crosses it (a route planned with "
                "coverage.no_fly_holes: true keeps out of the field's holes)"
            )
    return Airspace(polygon, zones, float(margin), required)


def PointsOutside(points, fence) -> dict:
    """How many of ``points`` [m] (k × 2) lie outside ``fence``'s inclusion polygon and how many
    inside one of its exclusions (a :class:`~eaplan_drake.field.missions.Fence`), and how far
    outside the farthest is [m]."""
    shapely = Require("shapely")
    pts = shapely.points(np.asarray(points, dtype=float))
    inclusion = shapely.Polygon(fence.inclusion)
    outside = ~shapely.covers(inclusion, pts)
    inside_no_fly = np.zeros(len(pts), dtype=bool)
    for ring in fence.exclusions:
        inside_no_fly |= shapely.contains(shapely.Polygon(ring), pts)
    distance = shapely.distance(inclusion, pts)
    return {
        "points": int(len(pts)),
        "outside": int(np.count_nonzero(outside)),
        "in_no_fly": int(np.count_nonzero(inside_no_fly)),
        "farthest_out_m": float(np.max(distance)) if len(pts) else 0.0,
    }
