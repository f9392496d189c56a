"""The route over a decomposed field: survey lines, the turns between them, transits between
cells; its length, and its time and energy at the lowest plan.

Within a cell the lines are flown in a Zamboni-like order (paper 003 Sec. IV-A): with J =
⌈2 r_min / x_d⌉, blocks of 2(J + 1) consecutive lines are flown i, i + h, i + 1, i + 1 + h, …
(h = J + 1), so that the outgoing turns join lines (J + 1) x_d apart and the return turns lines
J x_d ≥ 2 r_min apart (the paper's r1 = r + x_d/2 and r2 = r at c1 = 0, with r = J x_d / 2).
Every other block is flown from its upper half (i + h, i, i + 1 + h, …), so that a block ends
h + 1 lines from the next block's first line, and a last block shorter than 2(J + 1) lines joins
the one before (h grows to half the merged block): a cell at least 2(J + 1) lines wide has no
turn between lines closer than 2 r_min. A narrower cell is one block of m lines, h = ⌈m/2⌉.

A turn is the shortest path of curvature at most 1/r_min from the end of a line, along it, to the
start of the next, along that one (Dubins': :func:`DubinsPieces`), so it is tangent to both
lines: between lines w ≥ 2 r_min apart whose ends are level across them a half circle of radius
r_min and a straight piece (along the lines where they are not level); between closer lines three
arcs of radius r_min (away from the next line, round, and away again: up to (1 + √3) r_min
beyond the line ends).

Cells are visited greedily, each time the unvisited cell, and the end of its first or last line
to start from, that the shortest transit reaches: the Dubins path of radius r_min from the last
line, along it, onto the next cell's first line, along that one (:func:`TransitLegs`).

Lengths in m, angles in rad, times in s, powers in W, energies in J; in still air.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.field.decompose import Decomposition, SweepLines, _Rotation

__all__ = [
    "CellLegs",
    "CellSweepLines",
    "DubinsPieces",
    "Leg",
    "MakeRoute",
    "OrderCellLines",
    "Route",
    "RouteEnergy",
    "TurnLegs",
    "TransitLegs",
    "TurnJump",
    "ZamboniOrder",
]


@dc.dataclass(frozen=True)
class Leg:
    """One piece of the route."""

    kind: str
    """``line`` (a survey line), ``turn`` (a circle between two lines) or ``transit``."""
    start: tuple[float, float]
    """Start point [m]."""
    end: tuple[float, float]
    """End point [m]."""
    length: float
    """Path length [m]."""
    center: tuple[float, float] = (0.0, 0.0)
    """Arc centre [m] (turns and a transit's arcs)."""
    radius: float = 0.0
    """Arc radius R [m] (turns and a transit's arcs; 0 for a straight leg)."""
    ccw: bool = True
    """Arc direction: counter-clockwise (left) or clockwise."""
    angle: float = 0.0
    """Arc angle flown [rad], in (0, 2π)."""
    cell: int = -1
    """Index of the cell of a line or turn (−1: transit)."""


@dc.dataclass(frozen=True)
class Route:
    """The legs of a survey, in flight order."""

    legs: tuple[Leg, ...]
    theta_deg: float
    """Direction of the lines [deg from east, counter-clockwise]."""
    spacing: float
    """x_d [m]."""
    min_turning_radius: float
    """r_min [m]."""

    def Count(self, kind: str) -> int:
        return sum(1 for leg in self.legs if leg.kind == kind)

    def Length(self, kind: str | None = None) -> float:
        """Total length [m] of the legs of ``kind`` (all when None)."""
        return float(sum(leg.length for leg in self.legs if kind is None or leg.kind == kind))

    @property
    def turns(self) -> int:
        """Turns between lines: a half circle, or an Ω turn of three arcs."""
        legs = self.legs
        return sum(
            1
            for a, b in zip(legs[:-1], legs[1:], strict=True)
            if (a.kind, b.kind) == ("line", "turn")
        )

    @property
    def transits(self) -> int:
        """Transits between cells (each up to three legs)."""
        legs = self.legs
        return sum(
            1
            for k, leg in enumerate(legs)
            if leg.kind == "transit" and (k == 0 or legs[k - 1].kind != "transit")
        )

    def TurnGroups(self) -> list[list[Leg]]:
        """The turns between lines, each the list of its consecutive ``turn`` legs (arcs and
        straight pieces)."""
        groups, current = [], []
        for leg in self.legs:
            if leg.kind == "turn":
                current.append(leg)
            elif current:
                groups.append(current)
                current = []
        if current:
            groups.append(current)
        return groups

    @property
    def loops(self) -> int:
        """Turns of three arcs (Ω turns, between lines closer than 2 r_min). A turn of one arc
        longer than a half circle and a straight piece (lines whose ends are offset) is not
        one."""
        return sum(1 for g in self.TurnGroups() if sum(leg.radius > 0.0 for leg in g) >= 3)


def ZamboniOrder(n: int, jump: int) -> list[int]:
    """The order 0..n−1 of a cell's lines for turns at least ``jump`` J lines apart wherever the
    cell has 2(J + 1) lines or more (see the module docstring): blocks of 2(J + 1) lines, a
    shorter last block merged into the one before, every other block flown from its upper half,
    so that a block ends h + 1 lines from where the next one starts. A cell narrower than one
    block is one block (its turns are closer: Ω turns where they are under 2 r_min apart)."""
    block = 2 * (jump + 1)
    firsts = list(range(0, n, block))
    if len(firsts) > 1 and n - firsts[-1] < block:
        firsts.pop()  # the short last block joins the one before
    ends = [*firsts[1:], n]
    order = []
    for b, (first, end) in enumerate(zip(firsts, ends, strict=True)):
        m = end - first
        if b % 2 == 0:  # i, i + h, … from the lower half (h = ⌈m/2⌉)
            h = (m + 1) // 2
            pairs = [(first + i, first + i + h) for i in range(h)]
        else:  # i + h, i, … from the upper half (h = ⌊m/2⌋: its extra line is the last)
            h = m // 2
            pairs = [(first + i + h, first + i if i < h else end) for i in range(m - h)]
        for a, c in pairs:
            order += [v for v in (a, c) if v < end]
    return order


def _Left(v) -> np.ndarray:
    return np.array([-v[1], v[0]], dtype=float)


def _Sweep(a, b, ccw: bool) -> float:
    """The angle [rad, in [0, 2π)] turned from heading ``a`` to heading ``b``, counter-clockwise
    or clockwise."""
    d = math.atan2(b[1], b[0]) - math.atan2(a[1], a[0])
    return (d if ccw else -d) % (2.0 * math.pi)


def _Center(p, u, R: float, ccw: bool) -> np.ndarray:
    return p + (R if ccw else -R) * _Left(u)


def _OnCircle(c, R: float, ccw: bool, heading) -> np.ndarray:
    """The point of the circle (c, R) where travel (ccw or not) has ``heading``."""
    return c - (R if ccw else -R) * _Left(heading)


def _HeadingAt(c, p, ccw: bool) -> np.ndarray:
    r = _Unit(np.subtract(p, c))
    return _Left(r) if ccw else -_Left(r)


def _Words(p0, u0, p1, u1, R: float):
    """Every candidate (length, pieces) of :func:`DubinsPieces`."""
    for ccw0 in (True, False):
        for ccw1 in (True, False):
            c0, c1 = _Center(p0, u0, R, ccw0), _Center(p1, u1, R, ccw1)
            v = c1 - c0
            D = float(np.linalg.norm(v))
            psi = math.atan2(v[1], v[0])
            phi = None
            if ccw0 == ccw1 and D <= 1e-9 * R:  # one circle through both: a single arc
                a = _Sweep(u0, u1, ccw0)
                yield R * a, [("arc", p0, p1, c0, ccw0, a)]
            elif ccw0 == ccw1:
                phi = psi
            elif ccw0 != ccw1 and D >= 2.0 * R:
                phi = psi + (1.0 if ccw0 else -1.0) * math.asin(2.0 * R / D)
            if phi is not None:  # turn–straight–turn
                e = np.array([math.cos(phi), math.sin(phi)])
                t0, t1 = _OnCircle(c0, R, ccw0, e), _OnCircle(c1, R, ccw1, e)
                a0, a1 = _Sweep(u0, e, ccw0), _Sweep(e, u1, ccw1)
                straight = float((t1 - t0) @ e)
                if straight >= -1e-9:
                    pieces = [
                        ("arc", p0, t0, c0, ccw0, a0),
                        ("straight", t0, t1),
                        ("arc", t1, p1, c1, ccw1, a1),
                    ]
                    yield R * (a0 + a1) + max(straight, 0.0), pieces
            if ccw0 == ccw1 and 1e-9 * R < D < 4.0 * R:  # turn–turn–turn, the middle one opposite
                h = math.sqrt(4.0 * R * R - 0.25 * D * D)
                for side in (1.0, -1.0):
                    cm = 0.5 * (c0 + c1) + side * h * _Left(v / D)
                    t0, t1 = 0.5 * (c0 + cm), 0.5 * (cm + c1)
                    h0, h1 = _HeadingAt(c0, t0, ccw0), _HeadingAt(c1, t1, ccw1)
                    a0, a1 = _Sweep(u0, h0, ccw0), _Sweep(h1, u1, ccw1)
                    am = _Sweep(h0, h1, not ccw0)
                    pieces = [
                        ("arc", p0, t0, c0, ccw0, a0),
                        ("arc", t0, t1, cm, not ccw0, am),
                        ("arc", t1, p1, c1, ccw1, a1),
                    ]
                    yield R * (a0 + am + a1), pieces


def DubinsPieces(p0, u0, p1, u1, radius: float):
    """The shortest path of curvature at most 1/``radius`` [1/m] from ``p0`` [m] travelling along
    the unit heading ``u0`` to ``p1`` travelling along ``u1`` (Dubins 1957: the best of the
    turn–straight–turn words LSL, RSR, LSR, RSL and the turn–turn–turn words LRL, RLR): a list
    of pieces ``("arc", start, end, centre, ccw, angle)`` and ``("straight", start, end)``
    [m, rad], pieces of zero length left out; None when there is none (p0 = p1, u0 = u1)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u0, u1 = _Unit(np.asarray(u0, float)), _Unit(np.asarray(u1, float))
    R = float(radius)
    best = None
    for total, pieces in _Words(p0, u0, p1, u1, R):
        if best is None or total < best[0] - 1e-9:
            best = (total, pieces)
    if best is None:
        return None
    return [
        piece
        for piece in best[1]
        if (piece[0] == "arc" and R * piece[5] > 1e-9)
        or (piece[0] == "straight" and np.linalg.norm(piece[2] - piece[1]) > 1e-9)
    ]


def _T(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _DubinsLegs(kind: str, p0, u0, p1, u1, radius: float, cell: int) -> list[Leg]:
    pieces = DubinsPieces(p0, u0, p1, u1, radius)
    if pieces is None:
        length = float(np.linalg.norm(np.subtract(p1, p0)))
        return [Leg(kind, _T(p0), _T(p1), length, cell=cell)]
    legs = []
    for piece in pieces:
        if piece[0] == "arc":
            _, a, b, c, ccw, angle = piece
            r = float(radius)
            legs.append(Leg(kind, _T(a), _T(b), r * angle, _T(c), r, bool(ccw), float(angle), cell))
        else:
            _, a, b = piece
            legs.append(Leg(kind, _T(a), _T(b), float(np.linalg.norm(b - a)), cell=cell))
    return legs


def TurnLegs(end, direction, start, next_direction, r_min: float, cell: int) -> list[Leg]:
    """The turn from ``end`` [m] of a line travelling along ``direction`` to ``start`` of the
    next line travelling along ``next_direction``: the shortest Dubins path of radius r_min
    (:func:`DubinsPieces`), as legs of kind ``turn`` (a straight piece has radius 0)."""
    return _DubinsLegs("turn", end, direction, start, next_direction, r_min, cell)


def TransitLegs(end, heading, start, next_heading, radius: float) -> list[Leg]:
    """The transit from ``end`` [m] travelling along ``heading`` to ``start`` travelling along
    ``next_heading``: the shortest Dubins path of ``radius`` [m] (:func:`DubinsPieces`), as legs
    of kind ``transit`` (an arc has its centre and radius, a straight piece radius 0)."""
    return _DubinsLegs("transit", end, heading, start, next_heading, radius, -1)


def _BandExtent(ring: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """(x_min, x_max) [m] of the polygon ``ring`` (rotated frame) within lo ≤ y ≤ hi."""
    xs = [x for x, y in ring if lo <= y <= hi]
    for (x0, y0), (x1, y1) in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        for level in (lo, hi):
            if (y0 - level) * (y1 - level) < 0.0:
                xs.append(x0 + (x1 - x0) * (level - y0) / (y1 - y0))
    return min(xs), max(xs)


def CellSweepLines(cell, theta_deg: float, spacing: float, min_length: float = 0.0) -> list:
    """The survey lines of ``cell`` (:func:`~eaplan_drake.field.decompose.SweepLines`), each
    run over the cell's extent within its swath band y' ± x_d/2 (as the paper's lines are), so
    that its swath also covers the corners at slanted edges (a line's points stay within x_d/2
    of the cell). Lines shorter than ``min_length`` [m] (slivers in sharp corners, too short to
    sequence: the sequencer needs 4 ε between triggering points) are left out."""
    R = _Rotation(theta_deg)
    ring = np.asarray(cell.vertices) @ R.T
    h = 0.5 * spacing
    lines = []
    for ln in SweepLines(cell, theta_deg, spacing):
        (x0, y), (x1, _) = ln @ R.T
        lo, hi = _BandExtent(ring, max(y - h, cell.bottom), min(y + h, cell.top))
        a, b = min(min(x0, x1), lo), max(max(x0, x1), hi)
        seg = np.array([[a, y], [b, y]]) if x0 <= x1 else np.array([[b, y], [a, y]])
        if b - a >= min_length:
            lines.append(seg @ R)
    return lines


def _CellLines(decomposition: Decomposition, spacing: float, min_length: float) -> list:
    return [
        CellSweepLines(c, decomposition.theta_deg, spacing, min_length) for c in decomposition.cells
    ]


def _Ordered(lines: list[np.ndarray], jump: int, reverse: bool, flip: bool) -> list[np.ndarray]:
    seq = lines[::-1] if reverse else lines
    ordered = [seq[k] for k in ZamboniOrder(len(seq), jump)]
    out = []
    for k, ln in enumerate(ordered):  # alternate directions along the flight order
        forward = (k % 2 == 0) != flip
        base = ln if (ln[1] - ln[0]) @ (lines[0][1] - lines[0][0]) > 0 else ln[::-1]
        out.append(base if forward else base[::-1])
    return out


def TurnJump(spacing: float, min_turning_radius: float) -> int:
    """J = ⌈2 r_min / x_d⌉ ≥ 1: how many lines apart a return turn joins (module docstring)."""
    return max(1, math.ceil(2.0 * min_turning_radius / spacing - 1e-9))


def OrderCellLines(
    lines: list[np.ndarray], jump: int, position=None, orientation=None, heading=None, radius=0.0
):
    """(cost [m], orientation, the lines in flight order) of a cell's ``lines``: in Zamboni-like
    order with return jump J = ``jump``, in the ``orientation`` = 2·reverse + flip (0–3) that
    is cheapest to reach from ``position`` (the first when ``position`` is None), or in the given
    ``orientation``. The cost is the distance to the first line's start, or, with ``heading``
    (the direction of travel at ``position``), the length of the Dubins path of ``radius`` [m]
    onto the first line (:func:`DubinsPieces`)."""
    best = None
    codes = range(4) if orientation is None else (int(orientation),)
    for code in codes:
        seq = _Ordered(lines, jump, bool(code // 2), bool(code % 2))
        if position is None:
            d = 0.0
        elif heading is None:
            d = float(np.linalg.norm(seq[0][0] - position))
        else:
            d = _DubinsLength(position, heading, seq[0][0], seq[0][1] - seq[0][0], radius)
        if best is None or d < best[0]:
            best = (d, code, seq)
    return best


def _DubinsLength(p0, u0, p1, u1, radius: float) -> float:
    legs = _DubinsLegs("transit", p0, u0, p1, u1, radius, -1)
    return float(sum(leg.length for leg in legs))


def CellLegs(seq: list[np.ndarray], min_turning_radius: float, cell: int) -> list[Leg]:
    """The legs of a cell's lines ``seq`` in flight order: each line, and the turn of radius at
    least ``min_turning_radius`` r_min [m] between consecutive ones (:func:`TurnLegs`)."""
    legs = []
    for k, ln in enumerate(seq):
        if k:
            prev = seq[k - 1]
            legs += TurnLegs(
                prev[1], prev[1] - prev[0], ln[0], ln[1] - ln[0], min_turning_radius, cell
            )
        length = float(np.linalg.norm(ln[1] - ln[0]))
        legs.append(Leg("line", _T(ln[0]), _T(ln[1]), length, cell=cell))
    return legs


def _Unit(v) -> np.ndarray:
    return v / np.linalg.norm(v)


def MakeRoute(
    decomposition: Decomposition,
    spacing: float,
    min_turning_radius: float,
    start=None,
    *,
    min_line_length: float = 0.0,
    order_by: str = "transit",
) -> Route:
    """The route over the cells of ``decomposition`` at line spacing x_d = ``spacing`` [m] with
    turns of at least ``min_turning_radius`` r_min [m], from ``start`` [m] (default: the first
    cell's first line); lines shorter than ``min_line_length`` [m] are left out
    (:func:`CellSweepLines`). The next cell and its end are those of the shortest transit
    (``order_by="transit"``) or, quicker to choose, of the nearest start (``"distance"``)."""
    if order_by not in ("transit", "distance"):
        raise ValueError(f"order_by: must be transit or distance, got {order_by!r}")
    if not (math.isfinite(min_turning_radius) and min_turning_radius > 0.0):
        raise ValueError(f"min turning radius: must be > 0 [m], got {min_turning_radius!r}")
    jump = TurnJump(spacing, min_turning_radius)
    cell_lines = _CellLines(decomposition, spacing, min_line_length)
    todo = [i for i, lines in enumerate(cell_lines) if lines]
    legs: list[Leg] = []
    position = None if start is None else np.asarray(start, float)
    heading = None
    while todo:
        best = None
        for i in todo:
            d, _, seq = OrderCellLines(
                cell_lines[i],
                jump,
                position,
                heading=heading if order_by == "transit" else None,
                radius=min_turning_radius,
            )
            if best is None or d < best[0]:
                best = (d, i, seq)
        d, i, seq = best
        todo.remove(i)
        if position is not None and d > 0.0:
            heading = np.subtract(legs[-1].end, legs[-1].start) if legs else seq[0][1] - seq[0][0]
            legs += TransitLegs(
                position, heading, seq[0][0], seq[0][1] - seq[0][0], min_turning_radius
            )
        legs.extend(CellLegs(seq, min_turning_radius, i))
        position, heading = seq[-1][1], seq[-1][1] - seq[-1][0]
    return Route(tuple(legs), decomposition.theta_deg, float(spacing), float(min_turning_radius))


def RouteEnergy(route: Route, airspeed: float, coefficients, computation_power: float):
    """(time [s], energy [J], mean power [W]) of flying ``route`` in still air at ``airspeed``
    v_a [m/s]: motion power P_0 + P_2 ψ̇² (``coefficients`` (P_0, P_2) of
    :func:`~eaplan_drake.flight.plant.MotionPowerCoefficients`) with ψ̇ = v_a / R on turns and 0
    elsewhere, plus a constant ``computation_power`` g(c2) [W]."""
    if not (math.isfinite(airspeed) and airspeed > 0.0):
        raise ValueError(f"airspeed: must be > 0 [m/s], got {airspeed!r}")
    p0, p2 = (float(c) for c in coefficients)
    time = energy = 0.0
    for leg in route.legs:
        t = leg.length / airspeed
        rate = airspeed / leg.radius if leg.radius > 0.0 else 0.0
        time += t
        energy += t * (p0 + p2 * rate * rate + computation_power)
    return time, energy, energy / time if time > 0.0 else 0.0
