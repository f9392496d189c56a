"""A route that keeps out of no-fly polygons: survey lines clipped clear of them, turns that do
not enter them, and transits that go around them.

With ``coverage.no_fly_holes: true`` a field's holes are no-fly polygons (:class:`NoFly`). The
route keeps the clearance c (:data:`CLEARANCE`, the guidance's overshoot δ) from them: every
leg is checked against the polygons buffered by c (mitred corners), its points every 2 m joined
by straight chords (:func:`Hits`).

*Lines.* The cells are those of the field minus the polygons buffered by c + x_d/2
(:func:`SurveyPolygon`; a line runs over its swath band, up to x_d/2 beyond its cell). A turn
reaches at least r_min beyond the end of its lines (a fixed wing cannot reverse in less), so a
line that runs towards a polygon ends where its turn fits: in a cell's Zamboni order, both line
ends of a turn that enters the zone are shortened by the least (to 1 m, by bisection) that keeps
it out, and a line that cannot be is dropped and the order made again (:func:`ClearCellLines`).
The strip between the shortened lines and the polygon, about r_min deep, is not surveyed
(:func:`SwathCoverage` says how much of the field the lines still cover).

*Transits.* Between cells, the Dubins path of radius r_min when it keeps out; else the shortest
path on the visibility graph of the polygons buffered by c + k r_min (k = ½, 1, 2) from the last
line's end to the next line's start, flown through its corners with Dubins turns, the heading at
a corner bisecting its two segments (:func:`AvoidingTransit`). Where no transit keeps out, the
last line's end and the next line's start are shortened by ½, 1, 3/2 or 2 r_min, and if that
fails the last line is dropped (:func:`AvoidingLegs`). The way from home and back
(:func:`WithHomeTransits`) is built the same way. When no cell can be reached the route is
refused in one line naming ``coverage.no_fly_holes``.

Lengths in m.
"""

import dataclasses as dc
import heapq
import math

import numpy as np

from eaplan_drake.field.airspace import AirspaceError, LegPoints
from eaplan_drake.field.geodesy import Require
from eaplan_drake.field.route import Leg, TransitLegs, TurnLegs, _Ordered

__all__ = [
    "CLEARANCE",
    "ENTRY_CUTS",
    "LOST_LINE_WEIGHT",
    "AvoidingLegs",
    "AvoidingTransit",
    "ClearCellLines",
    "EntryInto",
    "Hits",
    "LostLineLength",
    "MakeAvoidingRoute",
    "MakeNoFly",
    "NoFly",
    "NoFlyLines",
    "NoFlySummary",
    "NextCell",
    "PlanRoute",
    "SurveyPolygon",
    "SwathCoverage",
    "VisibilityPath",
    "WithHomeTransits",
]

CLEARANCE = 10.0
"""c [m]: how far the route keeps from a no-fly polygon (the guidance's overshoot δ,
:data:`~eaplan_drake.field.airspace.TRACKING_ALLOWANCE`)."""

KEY = "coverage.no_fly_holes"

ENTRY_CUTS = (0.0, 0.5, 1.0, 1.5, 2.0)
"""By how many r_min a transit into a cell may shorten the last line's end and the first line's
start (:func:`EntryInto`) [-]."""

LOST_LINE_WEIGHT = 10.0
"""How many metres flown a metre of survey line left out near a no-fly polygon counts as when
the sweep direction is chosen [-] (:func:`~eaplan_drake.field.plan.MakeFieldPlan`)."""


@dc.dataclass(frozen=True)
class NoFly:
    """No-fly polygons and the zone the route keeps out of."""

    polygons: tuple
    """The no-fly polygons (``shapely.Polygon``) [m]."""
    clearance: float
    """c [m]."""
    keep_out: object
    """Their union buffered by c (a little less: a leg may touch it) [m], prepared."""


def _Buffered(polygons, distance: float):
    shapely = Require("shapely")
    return shapely.unary_union([p.buffer(distance, join_style="mitre") for p in polygons])


def MakeNoFly(polygons, clearance: float = CLEARANCE) -> NoFly:
    """The :class:`NoFly` of ``polygons`` (rings (k, 2) [m] or ``shapely.Polygon``)."""
    shapely = Require("shapely")
    if not (math.isfinite(clearance) and clearance > 0.0):
        raise ValueError(f"clearance: must be > 0 [m], got {clearance!r}")
    zones = tuple(p if hasattr(p, "exterior") else shapely.Polygon(p) for p in polygons)
    keep_out = _Buffered(zones, clearance - 1e-3)
    shapely.prepare(keep_out)
    return NoFly(zones, float(clearance), keep_out)


def SurveyPolygon(field_polygon, no_fly: NoFly, spacing: float):
    """The part of ``field_polygon`` the lines at ``spacing`` x_d [m] survey: the field minus
    the no-fly polygons buffered by c + x_d/2 (a ``shapely.Polygon`` or, cut in parts, a
    ``MultiPolygon``; parts under 1 m² are left out)."""
    shapely = Require("shapely")
    rest = field_polygon.difference(_Buffered(no_fly.polygons, no_fly.clearance + 0.5 * spacing))
    parts = [g for g in getattr(rest, "geoms", [rest]) if g.geom_type == "Polygon" and g.area > 1]
    if not parts:
        raise AirspaceError(f"{KEY}: the no-fly polygons leave nothing of the field to survey")
    parts = [shapely.Polygon(p.exterior, p.interiors).simplify(1e-6) for p in parts]
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)


def Hits(legs, no_fly: NoFly, step: float = 2.0) -> bool:
    """Whether ``legs`` enter the zone of ``no_fly`` (their points every ≈ ``step`` [m])."""
    shapely = Require("shapely")
    if not legs:
        return False
    points = np.concatenate([LegPoints(leg, step) for leg in legs])
    return bool(no_fly.keep_out.intersects(shapely.LineString(points)))


def _Unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _Cut(line, cut) -> np.ndarray:
    u = _Unit(line[1] - line[0])
    return np.array([line[0] + cut[0] * u, line[1] - cut[1] * u])


def _Owners(lines, seq) -> list[tuple[int, int, int]]:
    """For each line of ``seq`` (those of ``lines``, reordered, maybe reversed): (its index in
    ``lines``, the end of that line at its start, the end at its end)."""
    mids = np.array([0.5 * (a + b) for a, b in lines])
    out = []
    for ln in seq:
        j = int(np.argmin(np.linalg.norm(mids - 0.5 * (ln[0] + ln[1]), axis=1)))
        start = int(np.linalg.norm(lines[j][0] - ln[0]) > np.linalg.norm(lines[j][1] - ln[0]))
        out.append((j, start, 1 - start))
    return out


def _TurnCut(a, b, r_min: float, no_fly: NoFly, room: float, tolerance: float = 1.0):
    """The smallest s ≥ 0 [m] (to ``tolerance``) by which shortening line ``a``'s end and line
    ``b``'s start lets the turn between them keep out of the zone; None beyond ``room`` [m]."""
    ua, ub = _Unit(a[1] - a[0]), _Unit(b[1] - b[0])

    def Clear(s):
        return not Hits(TurnLegs(a[1] - s * ua, ua, b[0] + s * ub, ub, r_min, -1), no_fly)

    if Clear(0.0):
        return 0.0
    lo, hi = 0.0, 4.0 * tolerance
    while not Clear(hi):
        if hi >= room:
            return None
        lo, hi = hi, min(2.0 * hi, room)
    while hi - lo > tolerance:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if Clear(mid) else (mid, hi)
    return hi


def ClearCellLines(
    lines, jump: int, r_min: float, no_fly: NoFly, orientation: int, min_length: float = 0.0
) -> list[np.ndarray]:
    """A cell's ``lines`` in Zamboni-like flight order (jump J = ``jump``, ``orientation`` 0–3
    of :func:`~eaplan_drake.field.route.OrderCellLines`), shortened where their turn of radius
    ``r_min`` [m] would enter the zone, by the least (to 1 m) that keeps it out (module
    docstring); a line that cannot be shortened enough (to at least ``min_length``, 1 m) is
    dropped and the order made again. Empty when none is left."""
    lines = [np.asarray(ln, dtype=float) for ln in lines]
    lines = [ln for ln in lines if not Hits([Leg("line", tuple(ln[0]), tuple(ln[1]), 1.0)], no_fly)]
    length = np.array([np.linalg.norm(ln[1] - ln[0]) for ln in lines])
    cut = np.zeros((len(lines), 2))
    alive = list(range(len(lines)))
    shortest = max(min_length, 1.0)
    while alive:
        clipped = [_Cut(lines[i], cut[i]) for i in alive]
        seq = _Ordered(clipped, jump, bool(orientation // 2), bool(orientation % 2))
        owners = _Owners(clipped, seq)
        dropped = None
        for k in range(1, len(seq)):
            (ja, _, ea), (jb, sb, _) = owners[k - 1], owners[k]
            ia, ib = alive[ja], alive[jb]
            room = min(length[ia] - cut[ia].sum(), length[ib] - cut[ib].sum()) - shortest
            s = _TurnCut(seq[k - 1], seq[k], r_min, no_fly, max(room, 0.0))
            if s is None:
                dropped = ia if length[ia] - cut[ia].sum() <= length[ib] - cut[ib].sum() else ib
                break
            cut[ia, ea] += s
            cut[ib, sb] += s
        if dropped is None:
            out = [_Cut(lines[alive[j]], cut[alive[j]]) for j, _, _ in owners]
            return [ln if s0 == 0 else ln[::-1] for ln, (_, s0, _) in zip(out, owners, strict=True)]
        alive.remove(dropped)
    return []


def _Graph(no_fly: NoFly, inflation: float):
    """(corners (k, 2), their visibility (k, k) bool, the buffered zone's interior) of the
    no-fly polygons buffered by ``inflation`` [m] (cached on ``no_fly``)."""
    shapely = Require("shapely")
    cache = no_fly.__dict__.setdefault("_graphs", {})
    if inflation not in cache:
        zone = _Buffered(no_fly.polygons, inflation)
        interior = zone.buffer(-1e-6, join_style="mitre")
        shapely.prepare(interior)
        corners = np.vstack(
            [np.asarray(g.exterior.coords)[:-1] for g in getattr(zone, "geoms", [zone])]
        )
        i, j = np.triu_indices(len(corners), 1)
        segments = shapely.linestrings(np.stack([corners[i], corners[j]], axis=1))
        free = np.zeros((len(corners), len(corners)), dtype=bool)
        free[i, j] = free[j, i] = ~shapely.intersects(interior, segments)
        cache[inflation] = (corners, free, interior)
    return cache[inflation]


def VisibilityPath(a, b, no_fly: NoFly, inflation: float):
    """The shortest polyline [m] from ``a`` to ``b`` that keeps out of the no-fly polygons
    buffered by ``inflation`` [m], its corners at theirs (the segments from ``a`` and ``b`` only
    keep out of the zone of :func:`Hits`: they may start inside the buffer); None when none."""
    shapely = Require("shapely")
    corners, free, _ = _Graph(no_fly, inflation)
    nodes = np.vstack([a, b, corners])
    n = len(nodes)
    visible = np.zeros((n, n), dtype=bool)
    visible[2:, 2:] = free
    for e in (0, 1):
        others = np.array([k for k in range(n) if k != e])
        segments = shapely.linestrings(
            np.stack([np.repeat(nodes[e][None], len(others), 0), nodes[others]], axis=1)
        )
        ok = ~shapely.intersects(no_fly.keep_out, segments)
        visible[e, others] = visible[others, e] = visible[e, others] | ok
    dist = np.full(n, np.inf)
    prev = np.full(n, -1)
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        d, k = heapq.heappop(heap)
        if k == 1:
            break
        if d > dist[k]:
            continue
        for m in np.flatnonzero(visible[k]):
            dm = d + float(np.linalg.norm(nodes[m] - nodes[k]))
            if dm < dist[m] - 1e-9:
                dist[m], prev[m] = dm, k
                heapq.heappush(heap, (dm, int(m)))
    if not math.isfinite(dist[1]):
        return None
    path, k = [], 1
    while k != -1:
        path.append(nodes[k])
        k = prev[k]
    return path[::-1]


def _Through(path, h0, h1, radius: float) -> list[Leg]:
    """Transit legs along the polyline ``path`` [m]: Dubins paths of ``radius`` between its
    points, leaving the first along ``h0``, through each corner along the bisector of its two
    segments, reaching the last along ``h1``."""
    headings = [_Unit(h0)]
    for k in range(1, len(path) - 1):
        into, out = _Unit(path[k] - path[k - 1]), _Unit(path[k + 1] - path[k])
        bisector = into + out
        headings.append(_Unit(bisector) if np.linalg.norm(bisector) > 1e-9 else out)
    headings.append(_Unit(h1))
    legs = []
    for k in range(len(path) - 1):
        legs += TransitLegs(path[k], headings[k], path[k + 1], headings[k + 1], radius)
    return legs


def AvoidingTransit(p0, h0, p1, h1, radius: float, no_fly: NoFly) -> list[Leg] | None:
    """The transit from ``p0`` [m] travelling along ``h0`` to ``p1`` along ``h1`` that keeps out
    of the zone: the Dubins path of ``radius`` [m]
    (:func:`~eaplan_drake.field.route.TransitLegs`) if it does, else the visibility path around
    the polygons buffered by c + k ``radius``, k = ½, 1, 2, flown through its corners (module
    docstring); None when none keeps out."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    legs = TransitLegs(p0, h0, p1, h1, radius)
    if not Hits(legs, no_fly):
        return legs
    for k in (0.5, 1.0, 2.0):
        path = VisibilityPath(p0, p1, no_fly, no_fly.clearance + k * radius)
        if path is None or len(path) < 3:
            continue
        legs = _Through(path, h0, h1, radius)
        if not Hits(legs, no_fly):
            return legs
    return None


def _Shorten(line, start: float, end: float, shortest: float):
    """``line`` (2, 2) [m] shortened by ``start`` and ``end`` [m], or None if below
    ``shortest``."""
    if np.linalg.norm(line[1] - line[0]) - start - end < shortest:
        return None
    return _Cut(line, (start, end))


def EntryInto(last, position, heading, seq, r_min: float, no_fly: NoFly, shortest: float):
    """(transit legs, the previous cell's last line, the cell's lines, s [m]) from ``position``
    [m] along ``heading`` (the end of line ``last``, or, ``last`` None, a point whose end is
    kept) onto a cell's lines ``seq`` in flight order: the last line's end and the first line's
    start shortened by s = :data:`ENTRY_CUTS` × r_min, the first that lets a transit keep out
    (:func:`AvoidingTransit`); None when none does or a line would get shorter than
    ``shortest`` [m]."""
    for s in (k * r_min for k in ENTRY_CUTS):
        first = _Shorten(seq[0], s, 0.0, shortest)
        end = last if last is None else _Shorten(last, 0.0, s, shortest)
        if first is None or (last is not None and end is None):
            return None
        p0 = position if last is None else end[1]
        h0 = (first[1] - first[0]) if heading is None else heading
        legs = AvoidingTransit(p0, h0, first[0], first[1] - first[0], r_min, no_fly)
        if legs is not None:
            return legs, end, [first, *seq[1:]], s
    return None


def _LineLeg(line, cell: int) -> Leg:
    a, b = (float(line[0][0]), float(line[0][1])), (float(line[1][0]), float(line[1][1]))
    return Leg("line", a, b, float(np.linalg.norm(line[1] - line[0])), cell=cell)


def NextCell(
    cell_lines, jump, todo, Seq, last, position, r_min, no_fly, shortest, order_by, heading=None
):
    """(cost, cell, orientation, :func:`EntryInto`) of the next cell from ``position`` [m] (the
    end of line ``last``, or the start) travelling along ``heading`` (default: ``last``'s
    direction), or None when no transit reaches any of ``todo``: candidates (cell, orientation
    0–3, ``Seq(cell, orientation)`` their lines by :func:`ClearCellLines`) by the distance to the
    start of their uncut lines ``cell_lines[cell]``; the first that has an entry
    (``order_by="distance"``), or the shortest entry."""
    if heading is None and last is not None:
        heading = last[1] - last[0]

    def Rough(c):
        seq = _Ordered(cell_lines[c[0]], jump, bool(c[1] // 2), bool(c[1] % 2))
        return float(np.linalg.norm(seq[0][0] - position))

    best = None
    for i, code in sorted(((i, c) for i in todo for c in range(4)), key=Rough):
        seq = Seq(i, code)
        entry = EntryInto(last, position, heading, seq, r_min, no_fly, shortest) if seq else None
        if entry is None:
            continue
        cost = Rough((i, code)) if order_by == "distance" else sum(g.length for g in entry[0])
        if best is None or cost < best[0]:
            best = (cost, i, code, entry)
        if order_by == "distance":
            break
    return best


def _DropLastLine(legs: list) -> bool:
    """Drops the last line of ``legs`` with the turn (or transit) that led to it; False when
    there is no line to drop."""
    if not legs or legs[-1].kind != "line":
        return False
    legs.pop()
    while legs and legs[-1].kind in ("turn", "transit"):
        legs.pop()
    return True


def AvoidingLegs(
    cell_lines,
    jump: int,
    r_min: float,
    no_fly: NoFly,
    start=None,
    *,
    order_by: str = "transit",
    min_length: float = 0.0,
) -> list[Leg]:
    """The legs of :func:`~eaplan_drake.field.route.MakeRoute` that keep out of ``no_fly``'s
    zone: each cell's lines by :func:`ClearCellLines`, the next cell and its orientation those
    of the shortest transit that keeps out (``order_by="transit"``) or of the nearest start that
    has one (``"distance"``), entered by :func:`EntryInto`. Raises
    :class:`~eaplan_drake.field.airspace.AirspaceError` naming ``coverage.no_fly_holes`` when
    no cell left can be reached."""
    from eaplan_drake.field.route import CellLegs

    seqs: dict = {}

    def Seq(i, code):
        if (i, code) not in seqs:
            seqs[i, code] = ClearCellLines(cell_lines[i], jump, r_min, no_fly, code, min_length)
        return seqs[i, code]

    shortest = max(min_length, 1.0)
    todo = [i for i, lines in enumerate(cell_lines) if lines]
    legs: list[Leg] = []
    start = None if start is None else np.asarray(start, dtype=float)
    position = start
    while todo:
        if position is None:
            i = todo.pop(0)
            code = next((c for c in range(4) if Seq(i, c)), None)
            if code is not None:
                legs += CellLegs(Seq(i, code), r_min, i)
                position = np.asarray(legs[-1].end)
            continue
        last = None
        if legs and legs[-1].kind == "line":
            last = np.array([legs[-1].start, legs[-1].end])
        best = NextCell(
            cell_lines, jump, todo, Seq, last, position, r_min, no_fly, shortest, order_by
        )
        if best is None:
            todo = [i for i in todo if any(Seq(i, c) for c in range(4))]
            if not todo:
                break
            if not _DropLastLine(legs):
                raise AirspaceError(
                    f"{KEY}: no transit around the no-fly polygons reaches cell {todo[0]} (their "
                    "clearance and the turning radius leave no way: leave them out or split the "
                    "field)"
                )
            position = np.asarray(legs[-1].end) if legs else start
            continue
        _, i, _, (transit, end, seq, _) = best
        todo.remove(i)
        if last is not None:
            legs[-1] = _LineLeg(end, legs[-1].cell)
        legs += transit
        legs += CellLegs(seq, r_min, i)
        position = np.asarray(legs[-1].end)
    return legs


def _Around(a, b, heading_a, heading_b, radius: float, no_fly: NoFly):
    """Transit legs from ``a`` [m] (along ``heading_a``) that bring the straight line to ``b``
    clear of the zone: along the visibility path from ``a`` to ``b`` up to its last corner
    (``heading_b`` None: reached heading for ``b``), or, ``heading_a`` None, from its first
    corner (left heading away from ``a``) to ``b`` along ``heading_b``; None when none keeps
    out."""
    for k in (0.5, 1.0, 2.0):
        path = VisibilityPath(a, b, no_fly, no_fly.clearance + k * radius)
        if path is None or len(path) < 3:
            continue
        if heading_b is None:
            legs = _Through(path[:-1], heading_a, path[-1] - path[-2], radius)
        else:
            legs = _Through(path[1:], path[1] - path[0], heading_b, radius)
        if not Hits(legs, no_fly):
            return legs
    return None


def _TurnToward(p, heading, target, radius: float):
    """The arc of ``radius`` [m] from ``p`` [m] travelling along ``heading`` that turns towards
    ``target`` until it heads straight at it (to 0.5°): a list of one transit leg (none when it
    already does), or None when ``target`` lies within the turn's circle."""
    p, target = np.asarray(p, dtype=float), np.asarray(target, dtype=float)
    u = _Unit(heading)
    d = target - p
    cross = u[0] * d[1] - u[1] * d[0]
    if abs(cross) <= 1e-9 * np.linalg.norm(d) and u @ d > 0.0:
        return []
    ccw = cross > 0.0
    sign = 1.0 if ccw else -1.0
    center = p + sign * radius * np.array([-u[1], u[0]])
    if np.linalg.norm(target - center) <= radius:
        return None
    r0 = p - center
    for a in np.radians(np.arange(0.5, 360.0, 0.5)):
        c, s_ = math.cos(sign * a), math.sin(sign * a)
        q = center + np.array([c * r0[0] - s_ * r0[1], s_ * r0[0] + c * r0[1]])
        h = sign * np.array([-(q - center)[1], (q - center)[0]])
        e = target - q
        if h[0] * e[1] - h[1] * e[0] <= 0.0 if ccw else h[0] * e[1] - h[1] * e[0] >= 0.0:
            start, end = (float(p[0]), float(p[1])), (float(q[0]), float(q[1]))
            c_ = (float(center[0]), float(center[1]))
            return [Leg("transit", start, end, radius * a, c_, radius, bool(ccw), float(a))]
    return None


def _Return(legs, home, radius: float, no_fly: NoFly):
    """``legs`` with their way home (:func:`WithHomeTransits`): the last line's end shortened
    by s = 0, ½, 1, 3/2, 2 r_min, and then the last line left out, until it keeps out; None
    when no line is left."""
    legs = list(legs)
    while legs:
        out = _ReturnFrom(legs, home, radius, no_fly)
        if out is not None or not _DropLastLine(legs):
            return out
    return None


def _ReturnFrom(legs, home, radius: float, no_fly: NoFly):
    last = legs[-1]
    for s in (0.0, 0.5 * radius, radius, 1.5 * radius, 2.0 * radius):
        out = list(legs)
        if s > 0.0:
            line = np.array([last.start, last.end])
            if last.kind != "line" or _Shorten(line, 0.0, s, 1.0) is None:
                return None
            out[-1] = _LineLeg(_Shorten(line, 0.0, s, 1.0), last.cell)
        end, heading = np.asarray(out[-1].end), np.subtract(out[-1].end, out[-1].start)
        if np.linalg.norm(home - end) < 1e-6:
            return out
        arc = _TurnToward(end, heading, home, radius)
        if arc is not None:
            after = np.asarray(arc[-1].end) if arc else end
            if not Hits([*arc, Leg("home", tuple(after), tuple(home), 1.0)], no_fly):
                return out + arc
        around = _Around(end, home, heading, None, radius, no_fly)
        if around is not None:
            return out + around
    return None


def WithHomeTransits(route, home, no_fly: NoFly):
    """``route`` flown from and back to ``home`` [m] around the no-fly polygons. The way back is
    a turn of radius r_min from the route's end until it heads at home, then the straight leg
    home (:func:`~eaplan_drake.field.plan.WithHomeLegs`), when both keep out; else a transit
    along the visibility path (:func:`VisibilityPath`) that leaves a straight leg home clear of
    it; if none does, the last line is shortened or left out (``_Return``). Where the
    straight leg from home to the route's start would enter the zone, a transit from home is
    put before it. Raises :class:`~eaplan_drake.field.airspace.AirspaceError` naming
    ``coverage.no_fly_holes`` when no way keeps out."""
    home = np.asarray(home, dtype=float)
    legs = list(route.legs)
    r = route.min_turning_radius
    first = legs[0]
    start = np.asarray(first.start)
    if np.linalg.norm(start - home) > 0.0:
        if Hits([Leg("home", tuple(home), tuple(start), 1.0)], no_fly):
            heading = np.subtract(first.end, first.start)
            before = _Around(home, start, None, heading, r, no_fly)
            if before is None:
                raise AirspaceError(f"{KEY}: no way from home to the route keeps out of them")
            legs = before + legs
    legs = _Return(legs, home, r, no_fly)
    if legs is None:
        raise AirspaceError(f"{KEY}: no way from the route back home keeps out of them")
    return dc.replace(route, legs=tuple(legs))


def SwathCoverage(route, field_polygon) -> float:
    """The fraction [0, 1] of ``field_polygon``'s area that the swaths of ``route``'s lines
    (each line buffered by x_d/2 on either side, flat ends) cover."""
    shapely = Require("shapely")
    half = 0.5 * route.spacing
    swaths = shapely.union_all(
        [
            shapely.LineString([leg.start, leg.end]).buffer(half, cap_style="flat")
            for leg in route.legs
            if leg.kind == "line" and leg.length > 0.0
        ]
    )
    return float(swaths.intersection(field_polygon).area / field_polygon.area)


def MakeAvoidingRoute(
    decomposition,
    spacing: float,
    min_turning_radius: float,
    no_fly: NoFly,
    start=None,
    *,
    min_line_length: float = 0.0,
    order_by: str = "transit",
):
    """:func:`~eaplan_drake.field.route.MakeRoute` whose lines, turns and transits keep out of
    ``no_fly``'s polygons (:func:`AvoidingLegs`); the cells of ``decomposition`` should be those
    of :func:`SurveyPolygon`."""
    from eaplan_drake.field.route import Route, TurnJump, _CellLines

    if order_by not in ("transit", "distance"):
        raise ValueError(f"order_by: must be transit or distance, got {order_by!r}")
    if not (math.isfinite(min_turning_radius) and min_turning_radius > 0.0):
        raise ValueError(f"min turning radius: must be > 0 [m], got {min_turning_radius!r}")
    legs = AvoidingLegs(
        _CellLines(decomposition, spacing, min_line_length),
        TurnJump(spacing, min_turning_radius),
        min_turning_radius,
        no_fly,
        start,
        order_by=order_by,
        min_length=min_line_length,
    )
    theta = decomposition.theta_deg
    return Route(tuple(legs), theta, float(spacing), float(min_turning_radius))


def LostLineLength(decomposition, route, spacing: float) -> float:
    """How much survey line [m] ``route`` leaves out of the lines of ``decomposition``'s cells
    at ``spacing`` [m] (:func:`~eaplan_drake.field.route.CellSweepLines`)."""
    from eaplan_drake.field.route import CellSweepLines

    theta = decomposition.theta_deg
    lines = [ln for c in decomposition.cells for ln in CellSweepLines(c, theta, spacing)]
    total = float(sum(np.linalg.norm(ln[1] - ln[0]) for ln in lines))
    return max(total - route.Length("line"), 0.0)


def NoFlySummary(no_fly: NoFly, route, field_polygon) -> dict:
    """The plan summary's ``no_fly``: how many polygons, the clearance [m], and the swath
    coverage of ``route`` over ``field_polygon`` (:func:`SwathCoverage`)."""
    return {
        "polygons": len(no_fly.polygons),
        "clearance_m": no_fly.clearance,
        "swath_coverage": SwathCoverage(route, field_polygon),
    }


def NoFlyLines(summary: dict | None) -> list[str]:
    """The ``plan`` command's line of a :func:`NoFlySummary` (none for None)."""
    if summary is None:
        return []
    n = summary
    return [
        f"no-fly          {n['polygons']} polygons kept {n['clearance_m']:g} m clear "
        f"(coverage.no_fly_holes); the lines' swaths cover {100 * n['swath_coverage']:.0f} % "
        "of the field (turns need r_min beyond the lines)"
    ]


def PlanRoute(d, spacing, r_min, start, min_line_length, no_fly, order_by="transit"):
    """:func:`~eaplan_drake.field.route.MakeRoute` over the cells of ``d``, or with ``no_fly``
    (a :class:`NoFly`) :func:`MakeAvoidingRoute`."""
    from eaplan_drake.field.route import MakeRoute

    if no_fly is None:
        return MakeRoute(
            d, spacing, r_min, start, min_line_length=min_line_length, order_by=order_by
        )
    return MakeAvoidingRoute(
        d, spacing, r_min, no_fly, start, min_line_length=min_line_length, order_by=order_by
    )
