"""Boustrophedon cell decomposition of a field with holes, and the sweep direction.

Survey lines run along the unit direction u(θ) = (cos θ, sin θ) [local east-north, θ from east,
counter-clockwise, in [0°, 180°)]. In the frame rotated by −θ the lines are horizontal and the
sweep goes up (+y'). Every vertex of the field (outer ring and holes) gives a horizontal
*event line*; between two consecutive event lines (a *slab*) no vertex lies strictly inside, so
the field's part in the slab is a set of trapezoids, each bounded by two of the field's edges
and the two event lines (found by the even-odd rule along the slab's middle).

A trapezoid joins the cell of the one below it when each is the other's only neighbour across
their event line (no hole or boundary vertex splits or merges the free space there: Choset's
boustrophedon rule), and, with ``convex=True`` (the default), when the joined cell stays
convex. The classic boustrophedon cells (``convex=False``) are monotone along the sweep but not
always convex; the convex cells refine them where a boundary bends inwards. Every cell is built
from the same edge crossings, so neighbouring cells share their corners exactly: the cells'
areas sum to the field's and their union is the field (to rounding).

:func:`SweepLines` places the survey lines of a cell at the line spacing x_d [m], centred
across it; :func:`ChooseSweepDirection` tries the directions of the field's edges (and a grid of
``step_deg``) and keeps the one with the fewest lines (each line ends in a turn), then the
shortest line length. Lengths in m, angles in degrees.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.field.geodesy import Require

__all__ = [
    "Cell",
    "ChooseSweepDirection",
    "Decompose",
    "Decomposition",
    "IsConvex",
    "SweepChoice",
    "SweepLines",
]

_REL = 1e-12


@dc.dataclass(frozen=True)
class Cell:
    """One cell: a polygon [m] in the local frame, counter-clockwise, not closed."""

    vertices: np.ndarray
    """(k, 2) vertices [m]."""
    bottom: float
    """y' of its lowest event line [m] (in the frame rotated by −θ)."""
    top: float
    """y' of its highest event line [m]."""


@dc.dataclass(frozen=True)
class Decomposition:
    """The cells of a field for the sweep direction θ."""

    theta_deg: float
    """θ, the direction of the lines [deg from east, counter-clockwise], in [0, 180)."""
    cells: tuple[Cell, ...]
    """In the order of the sweep (by bottom, then left)."""
    trapezoids: int
    """Number of trapezoids the cells were joined from."""
    convex: bool = True
    """Whether the cells were kept convex (else monotone along the sweep)."""


def _Rotation(theta_deg: float) -> np.ndarray:
    """R(−θ): local → rotated frame (row vectors: p' = p @ R.T)."""
    t = math.radians(theta_deg)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, s], [-s, c]])


def IsConvex(vertices, tolerance: float = 1e-9) -> bool:
    """Whether the polygon (k, 2) [m] is convex: no turn to the right beyond ``tolerance`` ×
    (its size)², for either winding."""
    p = np.asarray(vertices, dtype=float)
    a = np.roll(p, -1, axis=0) - p
    b = np.roll(a, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    scale = tolerance * float(np.ptp(p, axis=0).max()) ** 2
    return bool(np.all(cross >= -scale) or np.all(cross <= scale))


def _Edges(rings) -> np.ndarray:
    """(m, 4) edges (x0, y0, x1, y1) of every ring, not horizontal, with y0 < y1."""
    out = []
    for ring in rings:
        q = np.roll(ring, -1, axis=0)
        for (x0, y0), (x1, y1) in zip(ring, q, strict=True):
            if y0 == y1:
                continue
            out.append((x0, y0, x1, y1) if y0 < y1 else (x1, y1, x0, y0))
    return np.asarray(out, dtype=float)


def _X(edge, y: float) -> float:
    """x of ``edge`` at height y (exact at its endpoints)."""
    x0, y0, x1, y1 = edge
    if y == y0:
        return float(x0)
    if y == y1:
        return float(x1)
    return float(x0 + (x1 - x0) * (y - y0) / (y1 - y0))


def _Simplify(points: list) -> np.ndarray:
    """Drops repeated and collinear consecutive points of a closed ring."""
    p = [pt for i, pt in enumerate(points) if i == 0 or pt != points[i - 1]]
    if len(p) > 1 and p[0] == p[-1]:
        p.pop()
    arr = np.asarray(p, dtype=float)
    scale = _REL * float(np.ptp(arr, axis=0).max()) ** 2
    while len(arr) > 3:
        a = arr - np.roll(arr, 1, axis=0)
        b = np.roll(arr, -1, axis=0) - arr
        flat = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) <= scale
        if not flat.any():
            break
        arr = arr[np.arange(len(arr)) != int(np.argmax(flat))]
    return arr


class _Chain:
    """Trapezoids joined into one cell: left and right boundary points, bottom to top."""

    def __init__(self, left_edge, right_edge, y0, y1):
        self.left = [(_X(left_edge, y0), y0), (_X(left_edge, y1), y1)]
        self.right = [(_X(right_edge, y0), y0), (_X(right_edge, y1), y1)]
        self.bottom, self.top = y0, y1

    def Ring(self, extra=None) -> list:
        left, right = self.left, self.right
        if extra is not None:
            left, right = left + extra.left, right + extra.right
        return right + left[::-1]

    def Extend(self, other) -> None:
        self.left += other.left
        self.right += other.right
        self.top = other.top


def Decompose(field_polygon, theta_deg: float, *, convex: bool = True) -> Decomposition:
    """The cells of ``field_polygon`` (a ``shapely.Polygon`` [m], holes allowed, valid) for lines
    along θ = ``theta_deg`` [deg] (see the module docstring); a ``shapely.MultiPolygon`` gives
    the cells of all its parts."""
    if getattr(field_polygon, "geom_type", "") == "MultiPolygon":
        return _DecomposeParts(field_polygon.geoms, theta_deg, convex)
    theta = float(theta_deg) % 180.0
    R = _Rotation(theta)
    rings = [np.asarray(field_polygon.exterior.coords)[:-1] @ R.T]
    rings += [np.asarray(h.coords)[:-1] @ R.T for h in field_polygon.interiors]
    edges = _Edges(rings)
    levels = np.unique(np.concatenate([r[:, 1] for r in rings]))
    open_cells: list[tuple[tuple[float, float], _Chain]] = []  # (top interval, chain) below
    done: list[_Chain] = []
    trapezoids = 0
    for y0, y1 in zip(levels[:-1], levels[1:], strict=True):
        y0, y1 = float(y0), float(y1)
        mid = 0.5 * (y0 + y1)
        spanning = edges[(edges[:, 1] < mid) & (edges[:, 3] > mid)]
        order = np.argsort([_X(e, mid) for e in spanning])
        spanning = spanning[order]
        pieces = []
        for k in range(0, len(spanning) - 1, 2):
            left, right = spanning[k], spanning[k + 1]
            pieces.append((_Chain(left, right, y0, y1), (_X(left, y0), _X(right, y0))))
        trapezoids += len(pieces)

        def overlaps(a, b):
            return min(a[1], b[1]) - max(a[0], b[0]) > 0.0

        below = [
            [j for j, (iv, _) in enumerate(open_cells) if overlaps(iv, bot)] for _, bot in pieces
        ]
        above = [
            [i for i, (_, bot) in enumerate(pieces) if overlaps(iv, bot)] for iv, _ in open_cells
        ]
        new_open, used = [], set()
        for i, (piece, _) in enumerate(pieces):
            chain = piece
            if len(below[i]) == 1 and len(above[below[i][0]]) == 1:
                j = below[i][0]
                candidate = open_cells[j][1]
                ring = _Simplify(candidate.Ring(piece))
                if not convex or IsConvex(ring):
                    candidate.Extend(piece)
                    chain = candidate
                    used.add(j)
            new_open.append(((chain.left[-1][0], chain.right[-1][0]), chain))
        done += [c for j, (_, c) in enumerate(open_cells) if j not in used]
        open_cells = new_open
    done += [c for _, c in open_cells]
    done.sort(key=lambda c: (c.bottom, c.left[0][0]))
    cells = []
    for chain in done:
        ring = _Simplify(chain.Ring()) @ R  # back to the local frame
        cells.append(Cell(vertices=ring, bottom=chain.bottom, top=chain.top))
    return Decomposition(
        theta_deg=theta, cells=tuple(cells), trapezoids=trapezoids, convex=bool(convex)
    )


def _DecomposeParts(parts, theta_deg: float, convex: bool) -> Decomposition:
    """The cells of several polygons, together, in the order of the sweep."""
    ds = [Decompose(p, theta_deg, convex=convex) for p in parts]
    R = _Rotation(theta_deg)
    cells = sorted(
        (c for d in ds for c in d.cells),
        key=lambda c: (c.bottom, float(np.min((np.asarray(c.vertices) @ R.T)[:, 0]))),
    )
    theta = float(theta_deg) % 180.0
    return Decomposition(theta, tuple(cells), sum(d.trapezoids for d in ds), bool(convex))


def SweepLines(cell: Cell, theta_deg: float, spacing: float) -> list[np.ndarray]:
    """The survey lines of a ``cell`` (convex, or monotone along the sweep) along θ [deg] at
    ``spacing`` x_d [m]: n = ⌈h/x_d⌉ chords of the cell (h = top − bottom) x_d apart, centred
    across it (x_d/2 from its bottom and top when h is a multiple of x_d; one line in the middle
    of a cell lower than x_d); each a (2, 2) array (start, end) [m], alternately left-to-right and
    back in the rotated frame."""
    if not (math.isfinite(spacing) and spacing > 0.0):
        raise ValueError(f"line spacing: must be finite and > 0 [m], got {spacing!r}")
    R = _Rotation(theta_deg)
    ring = np.asarray(cell.vertices) @ R.T
    height = cell.top - cell.bottom
    count = max(1, math.ceil(height / spacing - 1e-9))
    offset = 0.5 * (height - (count - 1) * spacing)
    ys = cell.bottom + offset + spacing * np.arange(count)
    lines = []
    q = np.roll(ring, -1, axis=0)
    for k, y in enumerate(ys):
        xs = []
        for (x0, y0), (x1, y1) in zip(ring, q, strict=True):
            if (y0 - y) * (y1 - y) < 0.0 or (y0 == y and y1 != y) or (y1 == y and y0 != y):
                xs.append(x0 + (x1 - x0) * (y - y0) / (y1 - y0))
        if len(xs) < 2:
            continue
        a, b = min(xs), max(xs)
        seg = np.array([[a, y], [b, y]]) if k % 2 == 0 else np.array([[b, y], [a, y]])
        lines.append(seg @ R)
    return lines


@dc.dataclass(frozen=True)
class SweepChoice:
    """The chosen sweep direction and what it costs."""

    decomposition: Decomposition
    """The cells for the chosen θ."""
    lines: int
    """Number of survey lines over all cells [-]."""
    line_length: float
    """Their total length [m]."""
    candidates: int
    """How many directions were tried [-]."""


def _Cost(field_polygon, theta, spacing, convex):
    d = Decompose(field_polygon, theta, convex=convex)
    lines = [ln for c in d.cells for ln in SweepLines(c, theta, spacing)]
    length = float(sum(np.linalg.norm(ln[1] - ln[0]) for ln in lines))
    return d, len(lines), length


def ChooseSweepDirection(
    field_polygon, spacing: float, *, step_deg: float = 5.0, convex: bool = True, cost=None
) -> SweepChoice:
    """The sweep direction θ with the fewest survey lines at ``spacing`` x_d [m] (ties: the
    shortest total line length, then the smallest θ), among the directions of the field's edges
    and the multiples of ``step_deg`` [deg] in [0, 180). ``cost(decomposition)``, when given,
    replaces the number of lines (e.g. the length of the route flown over the cells)."""
    Require("shapely")
    parts = getattr(field_polygon, "geoms", [field_polygon])
    rings = [np.asarray(p.exterior.coords) for p in parts]
    rings += [np.asarray(h.coords) for p in parts for h in p.interiors]
    angles = set()
    for ring in rings:
        d = np.diff(ring, axis=0)
        angles.update(round(math.degrees(math.atan2(dy, dx)) % 180.0, 9) for dx, dy in d)
    if step_deg > 0.0:
        angles.update(float(a) for a in np.arange(0.0, 180.0, step_deg))
    best = None
    for theta in sorted(angles):
        d, n, length = _Cost(field_polygon, theta, spacing, convex)
        key = (n if cost is None else cost(d), n, round(length, 6), theta)
        if best is None or key < best[0]:
            best = (key, d, n, length)
    _, d, n, length = best
    return SweepChoice(decomposition=d, lines=n, line_length=length, candidates=len(angles))
