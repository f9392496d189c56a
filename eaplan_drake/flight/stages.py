"""The stages of a plan and their geometry (paper 003 Def. II.1–II.5): a :class:`Stage` is a
normalised path function φ (line or circle, with its direction of travel s and field gain k_e),
the triggering point p_Γ where the next stage starts and the index of the primitive stage it
repeats (:data:`APPROACH` for the stage that brings the aircraft onto the first line). The
functions here measure a stage: the path length left on it (:func:`PathLeft`), the survey
fraction still to fly (:func:`SurveyFraction`), and the time to fly it at an airspeed in a
constant wind (:func:`StageTime`, with the ground speed :func:`GroundSpeed`; its parts
:func:`LineSpeed` and :func:`ArcTime` time a path without a stage)."""

import dataclasses as dc
import functools
import math
import typing

import numpy as np

from eaplan_drake.flight.paths import PathFunction

__all__ = [
    "ANCHOR_SIZE",
    "APPROACH",
    "NUM_PRIMITIVES",
    "ArcAngle",
    "ArcStart",
    "ArcStartTime",
    "ArcTime",
    "CheckedWind",
    "GroundSpeed",
    "LineSpeed",
    "MakeStage",
    "PathLeft",
    "PathLength",
    "Stage",
    "StagePoints",
    "StageGeometry",
    "StageRemaining",
    "StageTime",
    "SurveyFraction",
    "TurningRadius2",
]

APPROACH = -1
"""Primitive index of the approach stage (not part of the survey)."""
NUM_PRIMITIVES = 4
"""Number of primitive stages of the Zamboni-like motion."""
ANCHOR_SIZE = 4
"""Length of :attr:`Stage.anchor` (the numbers a plan source needs to continue after a stage)."""

_TOL = 1e-9


def _rot_ccw(v) -> np.ndarray:
    return np.array([-v[1], v[0]], dtype=float)


def _rot_cw(v) -> np.ndarray:
    return np.array([v[1], -v[0]], dtype=float)


def TurningRadius2(c1: float, r: float) -> float:
    """r2(c1) = sqrt(r² + c1) [m] (paper 003 Eq. 14)."""
    return math.sqrt(r * r + c1)


@dc.dataclass(frozen=True)
class Stage:
    """One stage Γ_i of a plan (paper 003 Def. II.1–II.5).

    ``entry`` is the point where the stage nominally starts (the previous trigger, or the start
    position projected onto the approach circle) and ``length`` the path length from entry to
    trigger [m]; both serve the coverage time and the remaining fraction.
    """

    index: int
    """Position of the stage in the plan (0 = first)."""
    path: PathFunction
    """Normalised path function with direction s and gain k_e."""
    trigger: tuple[float, float]
    """Triggering point p_Γ [m]."""
    primitive: int
    """Primitive stage 0..3, or −1 (:data:`APPROACH`) for a stage that is not repeated."""
    c1: float
    """Path parameter [m²] the stage was generated with."""
    entry: tuple[float, float]
    """Nominal start point [m]."""
    length: float
    """Nominal path length from entry to trigger [m]."""
    anchor: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
    """:data:`ANCHOR_SIZE` numbers with which the plan source regenerates the later stages."""

    @property
    def is_circle(self) -> bool:
        return self.path.is_circle

    def TriggerTangent(self) -> np.ndarray:
        """Unit direction of travel at the triggering point."""
        t = self.path.tangent(self.trigger)
        return t / np.linalg.norm(t)

    @functools.cached_property
    def geometry(self) -> "StageGeometry":
        """The numbers the per-step tests need, as plain floats (computed once per stage)."""
        tx, ty = (float(v) for v in self.trigger)
        ux, uy = (float(v) for v in self.TriggerTangent())
        if self.path.is_circle:
            ox, oy = (float(v) for v in self.path.center)
            radius = float(self.path.radius)
            ccw = (self.path.s < 0) == (self.path.a > 0)
            angle = math.atan2(ty - oy, tx - ox)
        else:
            ox = oy = radius = angle = 0.0
            ccw = False
        return StageGeometry(
            tx, ty, ux, uy, self.path.is_circle, ox, oy, radius, ccw, angle, float(self.length)
        )

    @functools.cached_property
    def descriptor(self) -> np.ndarray:
        """The path descriptor ``[a, b_x, b_y, c, s, k_e]`` (read-only array)."""
        d = self.path.descriptor()
        d.flags.writeable = False
        return d


class StageGeometry(typing.NamedTuple):
    """A stage's triggering geometry as floats: trigger p_Γ = (tx, ty) [m], unit direction of
    travel t̂_Γ = (ux, uy) there, and for a circle its centre o = (ox, oy) [m], radius [m],
    direction (ccw) and the angle of p_Γ about o [rad]; ``length`` the stage's length [m]."""

    tx: float
    ty: float
    ux: float
    uy: float
    is_circle: bool
    ox: float
    oy: float
    radius: float
    ccw: bool
    trigger_angle: float
    length: float


_TWO_PI = 2.0 * math.pi


def MakeStage(index, path, trigger, primitive, c1, entry, length, anchor) -> Stage:
    """A :class:`Stage` from points and numbers of any float type (numpy scalars or arrays of
    two), stored as Python floats: trigger and entry [m], c1 [m²], length [m], anchor."""
    return Stage(
        index=index,
        path=path,
        trigger=(float(trigger[0]), float(trigger[1])),
        primitive=primitive,
        c1=float(c1),
        entry=(float(entry[0]), float(entry[1])),
        length=float(length),
        anchor=tuple(float(a) for a in anchor),
    )


def PathLeft(stage: Stage, position=None) -> float:
    """Path length [m] left on ``stage`` from ``position`` to its triggering point, at most the
    stage's length (all of it when ``position`` is None): on a line the distance to p_Γ along
    t̂_Γ (≥ 0), on a circle R times the angle from p to p_Γ in the direction of travel."""
    g = stage.geometry
    if position is None:
        return g.length
    px, py = position[0], position[1]
    if g.is_circle:
        a_p = math.atan2(py - g.oy, px - g.ox)
        d = (g.trigger_angle - a_p) if g.ccw else (a_p - g.trigger_angle)
        return min(g.length, g.radius * (d % _TWO_PI))
    return min(g.length, max(0.0, (g.tx - px) * g.ux + (g.ty - py) * g.uy))


def StageRemaining(stage: Stage, position=None) -> float:
    """Survey length [m] left on ``stage`` from ``position`` (:func:`PathLeft`; 0 for the
    approach, which is not part of the survey)."""
    if stage.primitive == APPROACH:
        return 0.0
    return PathLeft(stage, position)


def SurveyFraction(stage: Stage, position, rest_length: float, total_length: float) -> float:
    """Fraction [0, 1] of the survey still to fly: (L_rest + L_stage(p)) / L_total with L_rest
    [m] the survey length after ``stage``, L_stage(p) = :func:`StageRemaining` and L_total [m]
    the survey length of the whole plan (0 when L_total ≤ 0)."""
    if total_length <= 0.0:
        return 0.0
    return min(1.0, max(0.0, (rest_length + StageRemaining(stage, position)) / total_length))


def ArcAngle(path: PathFunction, start, end) -> float:
    """Angle [rad] swept on circle ``path`` from ``start`` to ``end`` in its direction of travel,
    in [0, 2π). Points off the circle are projected radially."""
    o = path.center
    a0 = math.atan2(start[1] - o[1], start[0] - o[0])
    a1 = math.atan2(end[1] - o[1], end[0] - o[0])
    # A positive normalised circle (a > 0) travels clockwise for s = +1; a < 0 reverses it.
    ccw = (path.s < 0) == (path.a > 0)
    d = (a1 - a0) if ccw else (a0 - a1)
    d = d % (2.0 * math.pi)
    if d > 2.0 * math.pi - 1e-9:
        d = 0.0
    return d


def PathLength(path: PathFunction, start, end) -> float:
    """Length [m] along ``path`` from ``start`` to ``end`` (lines: the projection on the direction
    of travel, ≥ 0; circles: the arc in the direction of travel)."""
    if path.is_circle:
        return path.radius * ArcAngle(path, start, end)
    t = path.tangent(end)
    t = t / np.linalg.norm(t)
    return max(0.0, float(np.dot(np.asarray(end, float) - np.asarray(start, float), t)))


def GroundSpeed(course, airspeed: float, wind=(0.0, 0.0)) -> float:
    """Ground speed [m/s] along the unit course ``course`` at ``airspeed`` [m/s] in ``wind`` [m/s]:
    v_g = wᵀt̂ + sqrt(v_a² − (w × t̂)²) (the heading is crabbed into the wind)."""
    t = np.asarray(course, dtype=float)
    w = np.asarray(wind, dtype=float)
    cross = w[0] * t[1] - w[1] * t[0]
    return float(np.dot(w, t) + math.sqrt(airspeed * airspeed - cross * cross))


def StageTime(stage: Stage, airspeed: float, wind=(0.0, 0.0)) -> float:
    """Time [s] to fly ``stage`` from its entry to its trigger at ``airspeed`` in constant
    ``wind`` (exact on the nominal path; midpoint rule over the arc for circles)."""
    w = CheckedWind(airspeed, wind)
    if stage.length <= 0.0:
        return 0.0
    path = stage.path
    if not path.is_circle:
        return stage.length / LineSpeed(path, stage.trigger, airspeed, w)
    return ArcTime(path, stage.entry, stage.length, airspeed, w)


def CheckedWind(airspeed: float, wind) -> np.ndarray:
    """``wind`` [m/s] as an array; ValueError unless 0 < ‖wind‖ < ``airspeed`` [m/s]."""
    w = np.asarray(wind, dtype=float)
    if not airspeed > 0.0 or not math.hypot(*w) < airspeed:
        raise ValueError(f"StageTime: need 0 < |wind| < airspeed, got {w} and {airspeed}")
    return w


def LineSpeed(path: PathFunction, point, airspeed: float, w: np.ndarray) -> float:
    """Ground speed [m/s] along the line ``path`` at ``point`` [m] (:func:`GroundSpeed` along its
    direction of travel) at ``airspeed`` [m/s] in wind ``w`` [m/s]. The same number at every
    point of a line: its tangent s E ∇φ = s E (0·p + b) is s E b up to the signs of zeros, which
    change no product or sum of :func:`GroundSpeed`."""
    t = path.tangent(point)
    return GroundSpeed(t / np.linalg.norm(t), airspeed, w)


def ArcTime(path: PathFunction, entry, length: float, airspeed: float, w: np.ndarray) -> float:
    """Time [s] to fly ``length`` [m] (> 0) on the circle ``path`` from ``entry`` [m] at
    ``airspeed`` [m/s] in wind ``w`` [m/s] (the circle part of :func:`StageTime`)."""
    return ArcStartTime(ArcStart(path, entry), length, airspeed, float(w[0]), float(w[1]))


def ArcStart(path: PathFunction, entry) -> tuple[float, float, bool]:
    """(radius [m], angle [rad] of ``entry`` [m] about the centre, counter-clockwise?) of the
    circle ``path``: what :func:`ArcTime` needs of the circle and its entry, independent of the
    wind (a plan may keep it for the arcs it times in many winds)."""
    o = path.center
    ccw = (path.s < 0) == (path.a > 0)
    a0 = math.atan2(entry[1] - o[1], entry[0] - o[0])
    return float(path.radius), a0, ccw


def ArcStartTime(start: tuple, length: float, airspeed: float, wx: float, wy: float) -> float:
    """:func:`ArcTime` of the arc of ``length`` [m] (> 0) that begins at ``start``
    (:func:`ArcStart`), at ``airspeed`` [m/s] in the wind (wx, wy) [m/s] (Python floats)."""
    if not (wx or wy):  # still air
        return length / airspeed
    radius, a0, ccw = start
    return _ArcTime(float(length), radius, a0, ccw, float(airspeed), wx, wy)


@functools.lru_cache(maxsize=4096)
def _ArcTime(length, radius, a0, ccw, airspeed, wx, wy) -> float:
    """Time [s] on a circle arc of ``length`` [m] and ``radius`` [m] entered at angle a0 [rad]
    (counter-clockwise when ``ccw``) at ``airspeed`` [m/s] in wind (wx, wy) [m/s]: the midpoint
    rule over ≈ 720 points per turn. A pure function of its floats, cached (a plan repeats the
    same circles, and the sequencer's staircase re-times the rest of the plan at each stage)."""
    angle = length / radius
    n = max(16, int(math.ceil(angle / (2 * math.pi) * 720)))
    theta = a0 + (np.arange(n) + 0.5) / n * angle * (1.0 if ccw else -1.0)
    sign = 1.0 if ccw else -1.0
    tx, ty = -np.sin(theta) * sign, np.cos(theta) * sign
    cross = wx * ty - wy * tx
    vg = wx * tx + wy * ty + np.sqrt(airspeed**2 - cross**2)
    return float(np.sum(length / n / vg))


def StagePoints(stage, step: float = 2.0) -> np.ndarray:
    """Points [m] (k × 2) of a plan stage from its entry to its trigger: the segment of a line,
    or the arc of a circle in the direction of travel, sampled every ≈ ``step`` metres."""
    entry = np.asarray(stage.entry, dtype=float)
    if not stage.is_circle:
        return np.array([entry, np.asarray(stage.trigger, dtype=float)])
    o, r = np.asarray(stage.path.center, dtype=float), float(stage.path.radius)
    v, t = entry - o, stage.path.tangent(entry)
    sign = 1.0 if v[0] * t[1] - v[1] * t[0] > 0 else -1.0  # counter-clockwise: +1
    n = 2 + int(stage.length / step)
    a = math.atan2(v[1], v[0]) + sign * np.linspace(0.0, stage.length / r, n)
    return o + r * np.column_stack([np.cos(a), np.sin(a)])
