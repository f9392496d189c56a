"""Wind-corrected guiding-vector-field guidance (paper 001 Eq. 8; de Marina et al., ICRA'17).

For a path φ(p) = a‖p‖² + bᵀp + c (normalised, ‖∇φ‖ = 1 on the path; see
:mod:`eaplan_drake.flight.paths`) with direction s = ±1 and gain k_e [1/m], n = ∇φ(p), H = ∇²φ = 2a
I:

    ṗ_d = s E n − k_e φ n,                    m̂_d = ṗ_d / ‖ṗ_d‖           (guiding field)
    d/dt ṗ_d = (s E − k_e φ I) H ṗ − k_e (nᵀṗ) n                          (along the flight)
    χ̇_d = m̂_d × d/dt m̂_d = (ṗ_d × d/dt ṗ_d) / ‖ṗ_d‖²                   (desired course rate)
    u_ψ = ‖ṗ‖² / (v_a m(ψ)ᵀṗ) · (χ̇_d + k_d e),   e = ṗ̂ × m̂_d            (heading rate)

with ṗ the *measured ground velocity*, ṗ̂ = ṗ/‖ṗ‖, m(ψ) = [cos ψ, sin ψ] and
a × b = a_x b_y − a_y b_x.
Why the factor: with ṗ = v_a m(ψ) + w and constant wind the course χ of ṗ turns at
χ̇ = v_a ψ̇ m(ψ)ᵀṗ / ‖ṗ‖², so u_ψ gives χ̇ = χ̇_d + k_d e exactly. e is the sine of the angle from
the course to the field, so +k_d e turns the course *towards* the field: δ = ∠(ṗ̂, m̂_d) obeys
δ̇ = −k_d sin δ (the authors' MATLAB law has this sign reversed and no wind factor; we do not copy
it). Once aligned, φ̇ = nᵀṗ = −k_e φ ‖n‖² ‖ṗ‖ / ‖ṗ_d‖, so φ → 0 at the rate ≈ k_e ‖ṗ‖.

Guards (the command is finite for every finite input, and always within ±ψ̇_max):

- beyond 90° of course error (ṗ̂ · m̂_d < 0) e is replaced by ±1 (the sign of the cross product,
  +1 when exactly anti-aligned), so the anti-aligned equilibrium of the sine law cannot hold the
  aircraft flying away from the path;
- where the field vanishes (‖ṗ_d‖ < 1e-9: only at a circle's centre, since
  det(sE − k_eφ I) = 1 + (k_eφ)² > 0) m̂_d is taken as the current course and χ̇_d = 0; near it
  the χ̇_d denominator is floored at ‖ṗ_d‖² ≥ 1e-6, and the final saturation bounds the rest;
- ground speed ‖ṗ‖ < 1e-6 m/s: the course is taken from the heading, and the factor
  ‖ṗ‖²/(v_a m(ψ)ᵀṗ) → 0, so the command → 0 (no course is defined);
- m(ψ)ᵀṗ is floored at 0.05 v_a (true values are ≥ v_a − ‖w‖ > 0 whenever ‖w‖ < v_a; an
  inconsistent measurement or wind ≥ airspeed would otherwise flip or blow up the factor);
- non-finite inputs raise ValueError (never a silent NaN); the result is saturated at ±ψ̇_max.

Wind: the wind is not an input here (the measured ground velocity carries it), so a wind at or
above the airspeed is checked where it is known: :func:`CheckWindBelowAirspeed`, or the
``wind_speed`` argument of :class:`VectorFieldGuidance`.
"""

import copy
import math

import numpy as np
from pydrake.systems.framework import LeafSystem

from eaplan_drake.flight.paths import DESCRIPTOR_SIZE
from eaplan_drake.params import GuidanceParams

__all__ = [
    "CheckWindBelowAirspeed",
    "DesiredCourseRate",
    "GuidingVectorField",
    "HeadingRateCommand",
    "VectorFieldGuidance",
]

_FIELD_EPS = 1e-9
"""‖ṗ_d‖ below which the field has no direction (circle centre) [-]."""
_FIELD_FLOOR_SQ = 1e-6
"""Floor of ‖ṗ_d‖² in the χ̇_d denominator [-]."""
_SPEED_EPS = 1e-6
"""Ground speed below which the course is taken from the heading [m/s]."""
_ALONG_FLOOR = 0.05
"""Floor of m(ψ)ᵀṗ as a fraction of v_a [-]."""
_FIELD_EPS_SQ = _FIELD_EPS * _FIELD_EPS
_SPEED_EPS_SQ = _SPEED_EPS * _SPEED_EPS


def CheckWindBelowAirspeed(wind_speed: float, airspeed: float) -> None:
    """Raises ValueError unless 0 ≤ ‖w‖ < v_a (the guidance needs m(ψ)ᵀṗ ≥ v_a − ‖w‖ > 0)."""
    if not (math.isfinite(airspeed) and airspeed > 0.0):
        raise ValueError(f"airspeed must be > 0 m/s, got {airspeed!r}")
    if not (math.isfinite(wind_speed) and 0.0 <= wind_speed < airspeed):
        raise ValueError(
            f"wind_speed must be in [0, airspeed = {airspeed:g}) m/s, got {wind_speed!r}: "
            "the aircraft cannot hold a course against a wind at or above its airspeed"
        )


def _Field(a, bx, by, c, s, ke, x, y):
    """n = ∇φ, k_e φ and ṗ_d = s E n − k_e φ n at (x, y): (n_x, n_y, k_e φ, ṗ_d,x, ṗ_d,y)."""
    nx = 2.0 * a * x + bx
    ny = 2.0 * a * y + by
    kp = ke * (a * (x * x + y * y) + bx * x + by * y + c)
    return nx, ny, kp, s * ny - kp * nx, -s * nx - kp * ny


def _CourseRate(a, s, ke, nx, ny, kp, dx, dy, dn2, vx, vy):
    """χ̇_d = (ṗ_d × d/dt ṗ_d) / max(‖ṗ_d‖², floor) along ṗ = (v_x, v_y), with
    d/dt ṗ_d = (s E − k_e φ I) H ṗ − k_e (nᵀṗ) n, H = 2a I (where the field has a direction)."""
    ta = 2.0 * a
    ndot = nx * vx + ny * vy
    ddx = ta * (s * vy - kp * vx) - ke * ndot * nx
    ddy = ta * (-s * vx - kp * vy) - ke * ndot * ny
    return (dx * ddy - dy * ddx) / (dn2 if dn2 > _FIELD_FLOOR_SQ else _FIELD_FLOOR_SQ)


def GuidingVectorField(path, position) -> np.ndarray:
    """ṗ_d = s E∇φ − k_e φ ∇φ at ``position`` for a descriptor [a, b_x, b_y, c, s, k_e]."""
    a, bx, by, c, s, ke = (float(v) for v in path)
    _, _, _, dx, dy = _Field(a, bx, by, c, s, ke, float(position[0]), float(position[1]))
    return np.array([dx, dy])


def DesiredCourseRate(path, position, ground_velocity) -> float:
    """χ̇_d = (ṗ_d × d/dt ṗ_d) / ‖ṗ_d‖² [rad/s] along the measured ground velocity ṗ (guarded as in
    the module docstring: 0 where the field vanishes)."""
    a, bx, by, c, s, ke = (float(v) for v in path)
    nx, ny, kp, dx, dy = _Field(a, bx, by, c, s, ke, float(position[0]), float(position[1]))
    dn2 = dx * dx + dy * dy
    if dn2 <= _FIELD_EPS_SQ:
        return 0.0
    vx, vy = float(ground_velocity[0]), float(ground_velocity[1])
    return _CourseRate(a, s, ke, nx, ny, kp, dx, dy, dn2, vx, vy)


def HeadingRateCommand(
    position,
    ground_velocity,
    heading: float,
    path,
    airspeed: float,
    k_d: float,
    max_heading_rate: float,
) -> float:
    """u_ψ [rad/s] of the wind-corrected guiding-vector-field law (module docstring), saturated at
    ±max_heading_rate. ``path`` is a descriptor [a, b_x, b_y, c, s, k_e] (its own k_e is used).
    Plain floats (sequences of them for ``position``, ``ground_velocity`` and ``path``)."""
    x, y = position[0], position[1]
    vx, vy = ground_velocity[0], ground_velocity[1]
    a, bx, by, c, s, ke = path
    psi, va = heading, airspeed
    if not math.isfinite(x + y + vx + vy + psi + a + bx + by + c + s + ke):
        raise ValueError(
            "VectorFieldGuidance: non-finite input: "
            f"position=({x}, {y}), ground_velocity=({vx}, {vy}), heading={psi}, "
            f"path=[{a}, {bx}, {by}, {c}, {s}, {ke}]"
        )
    nx, ny, kp, dx, dy = _Field(a, bx, by, c, s, ke, x, y)
    dn2 = dx * dx + dy * dy
    cpsi = math.cos(psi)
    spsi = math.sin(psi)
    v2 = vx * vx + vy * vy
    if v2 > _SPEED_EPS_SQ:
        v = math.sqrt(v2)
        ux, uy = vx / v, vy / v
    else:
        ux, uy = cpsi, spsi
    if dn2 > _FIELD_EPS_SQ:
        dn = math.sqrt(dn2)
        mx, my = dx / dn, dy / dn
        chid = _CourseRate(a, s, ke, nx, ny, kp, dx, dy, dn2, vx, vy)
    else:
        mx, my = ux, uy
        chid = 0.0
    e = ux * my - uy * mx
    if ux * mx + uy * my < 0.0:
        e = -1.0 if e < 0.0 else 1.0
    along = cpsi * vx + spsi * vy
    floor = _ALONG_FLOOR * va
    u = v2 / (va * (along if along > floor else floor)) * (chid + k_d * e)
    if u != u:  # NaN from an overflow (inf · 0) of absurdly large inputs
        raise ValueError(f"VectorFieldGuidance: overflow in the heading-rate command at ({x}, {y})")
    r = max_heading_rate
    return r if u > r else (-r if u < -r else u)


class VectorFieldGuidance(LeafSystem):
    """Heading-rate command that makes a fixed-wing aircraft in wind follow a path function.

    u_ψ = ‖ṗ‖² / (v_a m(ψ)ᵀṗ) · (χ̇_d + k_d ṗ̂ × m̂_d), saturated at ±ψ̇_max, with the guiding field
    ṗ_d = s E∇φ − k_e φ ∇φ of the active path descriptor [a, b_x, b_y, c, s, k_e] (paper 001 Eq. 8;
    the full law, its derivation and its guards are in the :mod:`eaplan_drake.flight.guidance`
    docstring;
    the output is :func:`HeadingRateCommand`). The descriptor carries its own k_e [1/m];
    ``guidance.k_d`` [rad/s] is the course-alignment gain (``guidance.k_e`` is the default the
    plan generators put into descriptors). An all-zero descriptor (no path) commands u_ψ = 0
    (straight flight).

    Args:
        guidance: :class:`~eaplan_drake.params.GuidanceParams` (validated, copied).
        airspeed: v_a [m/s], > 0 (the scenario's ``vehicle.airspeed``).
        max_heading_rate: ψ̇_max [rad/s], > 0 (the plant's, e.g. ``plant.MaxHeadingRate``).
        wind_speed: optional ‖w‖ [m/s]; if given it must be in [0, airspeed) (ValueError
            otherwise). The wind itself is not an input: the measured ground velocity carries it.

    Inputs: ``kinematics`` (5) (x, y, ψ, ṗ_x, ṗ_y) [m, m, rad, m/s, m/s], the plant's output of
    the same name (:data:`~eaplan_drake.flight.plant.AircraftKinematics`: position, heading, ground
    velocity; one port, so one read per evaluation), and ``path`` (the descriptor). All outputs
    are direct feedthrough of the inputs (the plant's ``kinematics`` does not depend on its
    command, so there is no algebraic loop).

    .. pydrake_system::

        name: VectorFieldGuidance
        input_ports:
        - kinematics
        - path
        output_ports:
        - heading_rate_command
    """

    def __init__(
        self,
        guidance: GuidanceParams,
        *,
        airspeed: float,
        max_heading_rate: float,
        wind_speed: float | None = None,
    ):
        super().__init__()
        if not (isinstance(airspeed, int | float) and math.isfinite(airspeed) and airspeed > 0):
            raise ValueError(f"VectorFieldGuidance: airspeed must be > 0 m/s, got {airspeed!r}")
        if not (
            isinstance(max_heading_rate, int | float)
            and math.isfinite(max_heading_rate)
            and max_heading_rate > 0
        ):
            raise ValueError(
                f"VectorFieldGuidance: max_heading_rate must be > 0 rad/s, got {max_heading_rate!r}"
            )
        guidance.Validate("guidance")
        if wind_speed is not None:
            CheckWindBelowAirspeed(float(wind_speed), float(airspeed))
        self._guidance = copy.deepcopy(guidance)
        self._airspeed = float(airspeed)
        self._k_d = float(guidance.k_d)
        self._max_rate = float(max_heading_rate)

        self._kinematics_port = self.DeclareVectorInputPort("kinematics", 5)
        self._path_port = self.DeclareVectorInputPort("path", DESCRIPTOR_SIZE)
        self._command_port = self.DeclareVectorOutputPort(
            "heading_rate_command",
            1,
            self._CalcCommand,
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )

    def max_heading_rate(self) -> float:
        """ψ̇_max [rad/s]."""
        return self._max_rate

    def get_kinematics_input_port(self):
        return self._kinematics_port

    def get_path_input_port(self):
        return self._path_port

    def get_heading_rate_command_output_port(self):
        return self._command_port

    def _CalcCommand(self, context, output):
        x, y, psi, vx, vy = self._kinematics_port.Eval(context).tolist()
        output.SetAtIndex(
            0,
            HeadingRateCommand(
                (x, y),
                (vx, vy),
                psi,
                self._path_port.Eval(context).tolist(),
                self._airspeed,
                self._k_d,
                self._max_rate,
            ),
        )
