"""The route over a decomposed field: survey lines, the turns between them, transits between
cells; its length, and its time and energy at the lowest plan.

Within a cell the lines are flown in a Zamboni-like order (paper 003 Sec. IV-A): with J =
⌈2 r_min / x_d⌉, blocks of up to 2(J + 1) consecutive lines are flown i, i + h, i + 1, i + 1 + h,
… (h = half the block, rounded up: J + 1 in a full block), so that in a full block the outgoing
turns join lines (J + 1) x_d apart and the return turns lines J x_d ≥ 2 r_min apart (the
paper's r1 = r + x_d/2 and r2 = r at c1 = 0, with r = J x_d / 2).

A turn is one circle through the end of a line and the start of the next: a half circle of
radius a (half the distance between the two points) when a ≥ r_min, else a *loop* of radius
r_min whose centre lies beyond the two points (the aircraft swings out and comes round; arc
2π − 2 asin(a / r_min)). Cells are visited greedily, each time the nearest start (either end of
its first or last line) of an unvisited cell, joined by a straight transit.

Lengths in m, angles in rad, times in s, powers in W, energies in J; in still air.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.field.decompose import Decomposition, SweepLines

__all__ = ["Leg", "MakeRoute", "Route", "RouteEnergy", "ZamboniOrder"]


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
    """Turn centre [m] (turns only)."""
    radius: float = 0.0
    """Turn radius R [m] (turns only)."""
    ccw: bool = True
    """Turn direction: counter-clockwise (left) or clockwise (turns only)."""
    angle: float = 0.0
    """Turn angle flown [rad] (turns only), in (0, 2π)."""
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
    def loops(self) -> int:
        """Turns flown as loops (the two lines closer than 2 r_min)."""
        return sum(1 for leg in self.legs if leg.kind == "turn" and leg.angle > math.pi + 1e-9)


def ZamboniOrder(n: int, jump: int) -> list[int]:
    """The order 0..n−1 of a cell's lines for return turns at least ``jump`` J lines apart in
    full blocks (see the module docstring)."""
    order = []
    block = 2 * (jump + 1)
    for first in range(0, n, block):
        m = min(block, n - first)
        h = (m + 1) // 2
        for i in range(h):
            order.append(first + i)
            if i + h < m:
                order.append(first + i + h)
    return order


def _Turn(end, start, direction, r_min: float, cell: int) -> Leg:
    """The circle from ``end`` (travelling along ``direction``) to ``start``."""
    end, start = np.asarray(end, float), np.asarray(start, float)
    chord = start - end
    a = 0.5 * float(np.linalg.norm(chord))
    if a == 0.0:
        raise ValueError("a turn between two lines needs two distinct points")
    n = chord / (2.0 * a)
    forward = np.array([n[1], -n[0]])
    if forward @ direction < 0.0:
        forward = -forward
    radius = max(a, r_min)
    h = math.sqrt(max(radius * radius - a * a, 0.0))
    center = 0.5 * (end + start) + h * forward
    ccw = float(direction[0] * chord[1] - direction[1] * chord[0]) > 0.0
    angle = 2.0 * math.pi - 2.0 * math.asin(min(a / radius, 1.0))
    return Leg(
        "turn",
        tuple(end),
        tuple(start),
        radius * angle,
        tuple(center),
        radius,
        ccw,
        angle,
        cell,
    )


def _CellLines(decomposition: Decomposition, spacing: float) -> list[list[np.ndarray]]:
    return [SweepLines(c, decomposition.theta_deg, spacing) for c in decomposition.cells]


def _Ordered(lines: list[np.ndarray], jump: int, reverse: bool, flip: bool) -> list[np.ndarray]:
    seq = lines[::-1] if reverse else lines
    ordered = [seq[k] for k in ZamboniOrder(len(seq), jump)]
    out = []
    for k, ln in enumerate(ordered):  # alternate directions along the flight order
        forward = (k % 2 == 0) != flip
        base = ln if (ln[1] - ln[0]) @ (lines[0][1] - lines[0][0]) > 0 else ln[::-1]
        out.append(base if forward else base[::-1])
    return out


def MakeRoute(
    decomposition: Decomposition, spacing: float, min_turning_radius: float, start=None
) -> Route:
    """The route over the cells of ``decomposition`` at line spacing x_d = ``spacing`` [m] with
    turns of at least ``min_turning_radius`` r_min [m], from ``start`` [m] (default: the first
    cell's first line)."""
    if not (math.isfinite(min_turning_radius) and min_turning_radius > 0.0):
        raise ValueError(f"min turning radius: must be > 0 [m], got {min_turning_radius!r}")
    jump = max(1, math.ceil(2.0 * min_turning_radius / spacing - 1e-9))
    cell_lines = _CellLines(decomposition, spacing)
    todo = [i for i, lines in enumerate(cell_lines) if lines]
    legs: list[Leg] = []
    position = None if start is None else np.asarray(start, float)
    while todo:
        best = None
        for i in todo:
            for reverse in (False, True):
                for flip in (False, True):
                    seq = _Ordered(cell_lines[i], jump, reverse, flip)
                    d = 0.0 if position is None else float(np.linalg.norm(seq[0][0] - position))
                    if best is None or d < best[0]:
                        best = (d, i, seq)
        d, i, seq = best
        todo.remove(i)
        if position is not None and d > 0.0:
            legs.append(Leg("transit", tuple(position), tuple(seq[0][0]), d))
        for k, ln in enumerate(seq):
            if k:
                direction = seq[k - 1][1] - seq[k - 1][0]
                direction = direction / np.linalg.norm(direction)
                legs.append(_Turn(seq[k - 1][1], ln[0], direction, min_turning_radius, i))
            legs.append(
                Leg(
                    "line", tuple(ln[0]), tuple(ln[1]), float(np.linalg.norm(ln[1] - ln[0])), cell=i
                )
            )
        position = seq[-1][1]
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
        rate = airspeed / leg.radius if leg.kind == "turn" else 0.0
        time += t
        energy += t * (p0 + p2 * rate * rate + computation_power)
    return time, energy, energy / time if time > 0.0 else 0.0
