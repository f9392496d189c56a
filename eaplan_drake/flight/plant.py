"""Fixed-wing aircraft: unicycle at constant airspeed in wind, with a motion (propulsion) power.

Kinematics (:ref:`design-aircraft`, paper 001 Sec. III-A), state (x, y, ψ) [m, m, rad]:

    ṗ = v_a m(ψ) + w,   m(ψ) = [cos ψ, sin ψ],      ψ̇ = sat(u, ψ̇_max),

with the airspeed v_a [m/s] constant, w [m/s] the wind, u [rad/s] the commanded heading rate and
the turn-rate limit of a coordinated turn at the bank-angle limit φ_max:

    ψ̇_max = g tan(φ_max) / v_a.

Motion power (load-factor model). In a coordinated level turn at heading rate ψ̇ the load factor
is n = sqrt(1 + (v_a ψ̇ / g)²) (tan φ = v_a ψ̇ / g). At constant airspeed the parasitic share of the
straight-and-level power P_level is unchanged and the induced share (∝ lift² ∝ n²) grows with n²:

    P_m(ψ̇) = P_level · (1 − f + f n²)                                   [W]

with f the induced share of P_level (:class:`~eaplan_drake.params.MotionPowerParams`). Calibration
against the authors' logs (``reference/seewald2022/plan_I`` and ``plan_II``, ``energy_resized.csv``
minus the computation power g(c2) of the PedNet table): the reference flight's motion power
spans 22.1–28.9 W (30.1 W in the first seconds of plan II) with a time mean of 26.2 W (plan I) and
25.9 W (plan II). The authors' simulator flies at a nearly constant *ground* speed (14.8–16.1 m/s
in ``position_resized.csv``), so its power follows head-/tailwind, which a constant-airspeed
aircraft cannot reproduce; we therefore match the level and the mean instead of the shape:
P_level = 25 W, f = 0.5 (an induced share typical of a small aircraft near its minimum-power
speed) give, on the reference survey at 15 m/s in 5 m/s wind from 0°, 25.0 W on the lines, up to
≈ 28.7 W on the downwind side of the 75 m circle (29.2 W on a 70 m circle: ψ̇ = 0.381 rad/s, where
the ground speed is 20 m/s) and a survey mean of ≈ 25.8 W; with the 10.2 W of the detector at
10 fps the total is ≈ 35.2–39.4 W (log: 32.3–39.1 W), with 5.2 W at 2 fps ≈ 30.2–34.4 W.
The model's full range is :func:`MotionPowerRange`: [P_level, P_level (1 + f tan² φ_max)] =
[25, 37.5] W at φ_max = 45° (the top only in saturated turns, e.g. while converging onto a path).

Exact step (``simulation.plant: exact_arc``). With v_a, w and the heading rate ω held over a
step h the unicycle flies a circular arc relative to the air; with θ = ω h

    p(t + h) = p + v_a h [S(θ) m(ψ) + C(θ) m⊥(ψ)] + w h,   ψ(t + h) = ψ + θ,
    S(θ) = sin θ / θ,   C(θ) = (1 − cos θ) / θ = sin(θ/2) S(θ/2),   m⊥(ψ) = [−sin ψ, cos ψ],

the closed form of x += v_a/ω (sin(ψ + θ) − sin ψ) + w_x h, y −= v_a/ω (cos(ψ + θ) − cos ψ) − w_y h
without its cancellation as ω → 0 (S by its series for θ within ±1e-4, C through the half angle).

All functions here are pure and take float (math) or, where the plant needs it, AutoDiffXd and
symbolic Expression scalars (``pydrake.math``); the systems :class:`FixedWingPlant` (continuous,
integrated by the simulator) and :class:`FixedWingArcPlant` (discrete, exact over each step) call
them. :func:`MakeFixedWingPlant` builds the one ``simulation.plant`` names.
"""

import copy
import math

import numpy as np
import pydrake.math as pm
from pydrake.common.containers import namedview
from pydrake.systems.framework import BasicVector_, LeafSystem, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from eaplan_drake.params import MotionPowerParams, SimulationParams, VehicleParams
from eaplan_drake.registry import AIRCRAFT_MODELS

__all__ = [
    "GRAVITY",
    "AircraftKinematics",
    "AircraftState",
    "ArcStep",
    "CheckedCommand",
    "FixedWingArcPlant",
    "FixedWingDynamics",
    "FixedWingPlant",
    "FixedWingPlant_",
    "GroundVelocity",
    "LoadFactor",
    "MakeContinuousPlant",
    "MakeExactArcPlant",
    "MakeFixedWingPlant",
    "MaxHeadingRate",
    "MotionPower",
    "MotionPowerCoefficients",
    "MotionPowerRange",
    "NonFiniteCommandError",
    "SaturatedHeadingRate",
    "WrapToPi",
]

GRAVITY = 9.81
"""g [m/s²]."""

AircraftState = namedview("AircraftState", ["x", "y", "heading"])
"""The aircraft's state (x, y, ψ) [m, m, rad] as a named view of a 3-vector."""

AircraftKinematics = namedview("AircraftKinematics", ["x", "y", "heading", "vx", "vy"])
"""The ``kinematics`` output (x, y, ψ, ṗ_x, ṗ_y) [m, m, rad, m/s, m/s]: the pose and the ground
velocity, what the guidance reads (one port, one read per step)."""

_SINC_SERIES_BELOW = 1e-4
"""|θ| below which S(θ) = sin θ / θ is taken from its series 1 − θ²/6 (next term < 1e-18)."""


_REAL = (float, int)
"""The Python scalar types the float branches take (a tuple: ``isinstance`` with it is ≈ 3×
cheaper than with ``float | int``, and these checks run several times per plant step)."""


def _Math(x):
    """``math`` for a float scalar, ``pydrake.math`` for AutoDiffXd and Expression."""
    return math if isinstance(x, _REAL) else pm


def MaxHeadingRate(vehicle_or_airspeed, max_bank_angle: float | None = None) -> float:
    """ψ̇_max = g tan(φ_max) / v_a [rad/s].

    Call as ``MaxHeadingRate(vehicle)`` with :class:`~eaplan_drake.params.VehicleParams` (uses
    ``airspeed`` and ``max_bank_angle_deg``) or as ``MaxHeadingRate(airspeed, max_bank_angle)``
    with v_a [m/s] and φ_max [rad].
    """
    if isinstance(vehicle_or_airspeed, VehicleParams):
        if max_bank_angle is not None:
            raise ValueError("MaxHeadingRate: give a VehicleParams or (airspeed, max_bank_angle)")
        airspeed = float(vehicle_or_airspeed.airspeed)
        max_bank_angle = math.radians(vehicle_or_airspeed.max_bank_angle_deg)
    else:
        airspeed = float(vehicle_or_airspeed)
        if max_bank_angle is None:
            raise ValueError("MaxHeadingRate: max_bank_angle [rad] is missing")
    if not (math.isfinite(airspeed) and airspeed > 0.0):
        raise ValueError(f"MaxHeadingRate: airspeed must be > 0 m/s, got {airspeed!r}")
    if not (0.0 < max_bank_angle < 0.5 * math.pi):
        raise ValueError(
            f"MaxHeadingRate: max_bank_angle must be in (0, pi/2) rad, got {max_bank_angle!r}"
        )
    return GRAVITY * math.tan(max_bank_angle) / airspeed


def LoadFactor(airspeed, heading_rate):
    """n = sqrt(1 + (v_a ψ̇ / g)²) [-] of a coordinated level turn (numpy-broadcasting)."""
    return np.sqrt(1.0 + (np.asarray(airspeed) * np.asarray(heading_rate) / GRAVITY) ** 2)


def MotionPowerCoefficients(airspeed: float, params: MotionPowerParams) -> tuple[float, float]:
    """(P_0, P_2) [W, W s²] of P_m = P_0 + P_2 ψ̇²: P_0 = P_level, P_2 = P_level f (v_a / g)²
    (P_level (1 − f + f n²) with n² − 1 = (v_a ψ̇ / g)²)."""
    k = float(airspeed) / GRAVITY
    return float(params.level_power), float(params.level_power * params.induced_fraction * k * k)


def MotionPower(heading_rate, coefficients):
    """P_m = P_0 + P_2 ψ̇² [W] at the heading rate ψ̇ [rad/s] with ``coefficients`` (P_0, P_2) of
    :func:`MotionPowerCoefficients` (numpy-broadcasting; any scalar type)."""
    p0, p2 = coefficients
    return p0 + p2 * heading_rate * heading_rate


def MotionPowerRange(vehicle: VehicleParams) -> tuple[float, float]:
    """(min, max) motion power [W] of the vehicle: straight flight and a turn at ψ̇_max, i.e.
    [P_level, P_level (1 + f tan² φ_max)], independent of the airspeed."""
    coefficients = MotionPowerCoefficients(vehicle.airspeed, vehicle.motion_power)
    return coefficients[0], float(MotionPower(MaxHeadingRate(vehicle), coefficients))


def _GroundVelocity(heading, wind, airspeed) -> tuple:
    m = _Math(heading)
    return airspeed * m.cos(heading) + wind[0], airspeed * m.sin(heading) + wind[1]


def GroundVelocity(heading, wind, airspeed) -> np.ndarray:
    """ṗ = v_a [cos ψ, sin ψ] + w [m/s] (any scalar type)."""
    return np.array(_GroundVelocity(heading, wind, airspeed))


class NonFiniteCommandError(ValueError):
    """The heading-rate command u is NaN or infinite: an upstream failure, never a turn."""


def CheckedCommand(u) -> float:
    """u [rad/s] as a float; :class:`NonFiniteCommandError` if it is NaN or ±inf (a NaN would
    otherwise pass ``min``/``max`` saturation as a full-rate turn)."""
    u = float(u)
    if not math.isfinite(u):
        raise NonFiniteCommandError(f"FixedWingPlant: heading_rate_command is not finite: {u}")
    return u


def SaturatedHeadingRate(u, max_heading_rate: float):
    """sat(u, ψ̇_max) = max(−ψ̇_max, min(ψ̇_max, u)) [rad/s] (any scalar type); a non-finite float
    u raises :class:`NonFiniteCommandError`."""
    r = max_heading_rate
    if isinstance(u, _REAL):
        u = CheckedCommand(u)
        return -r if u < -r else (r if u > r else u)
    return pm.max(-r, pm.min(r, u))


def FixedWingDynamics(state, heading_rate_command, wind, airspeed, max_heading_rate):
    """f(x, u, w) = [v_a cos ψ + w_x, v_a sin ψ + w_y, sat(u, ψ̇_max)] for x = (x, y, ψ) (any
    scalar type); a non-finite float u raises :class:`NonFiniteCommandError`."""
    vx, vy = _GroundVelocity(state[2], wind, airspeed)
    return np.array([vx, vy, SaturatedHeadingRate(heading_rate_command, max_heading_rate)])


def _Sinc(theta, m):
    """S(θ) = sin θ / θ (series 1 − θ²/6 for |θ| < 1e-4); ``m`` is ``_Math(theta)`` (any scalar
    type: the branch is taken on the value of an AutoDiffXd)."""
    if abs(theta if m is math else theta.value()) < _SINC_SERIES_BELOW:
        return 1.0 - theta * theta / 6.0
    return m.sin(theta) / theta


def ArcStep(state, heading_rate, wind, airspeed, step) -> tuple:
    """x(t + h) = (x, y, ψ) of the unicycle from ``state`` = (x, y, ψ) with the heading rate ω
    [rad/s], the wind w [m/s] and the airspeed v_a [m/s] held over the step h [s], exactly (module
    docstring): p + v_a h [S(θ) m(ψ) + C(θ) m⊥(ψ)] + w h, ψ + θ, θ = ω h. Float or AutoDiffXd
    scalars; a tuple of three scalars (no array: the exact-arc plant unpacks it every step)."""
    x, y, psi = state
    theta = heading_rate * step
    half = 0.5 * theta
    mt = _Math(theta)
    s = _Sinc(theta, mt)
    c = mt.sin(half) * _Sinc(half, mt)
    m = _Math(psi)
    cos_psi, sin_psi = m.cos(psi), m.sin(psi)
    d = airspeed * step
    return (
        x + d * (s * cos_psi - c * sin_psi) + wind[0] * step,
        y + d * (s * sin_psi + c * cos_psi) + wind[1] * step,
        psi + theta,
    )


def WrapToPi(angle):
    """The angle wrapped into [−π, π) [rad] (the plant's ``heading`` output is *not* wrapped)."""
    return (np.asarray(angle) + math.pi) % (2.0 * math.pi) - math.pi


def MakeFixedWingPlant(vehicle: VehicleParams, simulation: SimulationParams):
    """The plant ``simulation.plant`` names in :data:`~eaplan_drake.registry.AIRCRAFT_MODELS`:
    :class:`FixedWingPlant` (``continuous``) or :class:`FixedWingArcPlant` stepped every
    ``simulation.max_step`` (``exact_arc``)."""
    return AIRCRAFT_MODELS.Make(simulation.plant, vehicle, simulation)


def MakeContinuousPlant(vehicle: VehicleParams, simulation: SimulationParams):
    """``simulation.plant: continuous``: :class:`FixedWingPlant`, integrated by the simulator."""
    return FixedWingPlant(vehicle)


def MakeExactArcPlant(vehicle: VehicleParams, simulation: SimulationParams):
    """``simulation.plant: exact_arc``: :class:`FixedWingArcPlant` stepped every
    ``simulation.max_step``."""
    return FixedWingArcPlant(vehicle, step=simulation.max_step)


class _FixedWingPorts:
    """Parameters, inputs, the ``motion_power`` output and the accessors shared by
    :class:`FixedWingPlant` and :class:`FixedWingArcPlant` (each declares its own ``position``,
    ``heading`` and ``ground_velocity`` outputs between :meth:`_DeclareInputs` and
    :meth:`_DeclareMotionPowerPort`, so the port order is the same)."""

    def _DeclareInputs(self, vehicle: VehicleParams):
        self._vehicle = vehicle
        self._airspeed = float(vehicle.airspeed)
        self._max_rate = MaxHeadingRate(vehicle)
        self._power_coefficients = MotionPowerCoefficients(self._airspeed, vehicle.motion_power)
        self._u_port = self.DeclareVectorInputPort("heading_rate_command", 1)
        self._wind_port = self.DeclareVectorInputPort("wind", 2)

    def _DeclareMotionPowerPort(self):
        self._motion_power_port = self.DeclareVectorOutputPort(
            "motion_power",
            1,
            self._CalcMotionPower,
            prerequisites_of_calc={self._u_port.ticket()},
        )

    @staticmethod
    def _PoseVector(position, heading) -> np.ndarray:
        value = np.zeros(3)
        pose = AircraftState(value)
        pose.x, pose.y = position
        pose.heading = heading
        return value

    @classmethod
    def _InitialState(cls, vehicle: VehicleParams) -> np.ndarray:
        return cls._PoseVector(vehicle.initial_position, math.radians(vehicle.initial_heading_deg))

    # -- accessors ----------------------------------------------------------------------------

    def max_heading_rate(self) -> float:
        """ψ̇_max [rad/s]."""
        return self._max_rate

    def airspeed(self) -> float:
        """v_a [m/s]."""
        return self._airspeed

    def get_heading_rate_command_input_port(self):
        return self._u_port

    def get_wind_input_port(self):
        return self._wind_port

    def get_position_output_port(self):
        return self._position_port

    def get_heading_output_port(self):
        return self._heading_port

    def get_ground_velocity_output_port(self):
        return self._ground_velocity_port

    def get_kinematics_output_port(self):
        return self._kinematics_port

    def get_motion_power_output_port(self):
        return self._motion_power_port

    # -- outputs ------------------------------------------------------------------------------

    def _AppliedRate(self, context):
        return SaturatedHeadingRate(self._u_port.Eval(context).item(0), self._max_rate)

    def _CalcMotionPower(self, context, output):
        output.SetAtIndex(0, MotionPower(self._AppliedRate(context), self._power_coefficients))


class _ContinuousFixedWing(_FixedWingPorts):
    """The outputs of the state and the dynamics of :class:`FixedWingPlant`, in any scalar type
    (the template's class adds the ``LeafSystem_[T]`` base and the constructor)."""

    def _DeclareStateOutputs(self):
        """The ``position``, ``heading`` and ``ground_velocity`` outputs."""
        xc = self.xc_ticket()
        self._position_port = self.DeclareVectorOutputPort(
            "position", 2, self._CalcPosition, prerequisites_of_calc={xc}
        )
        self._heading_port = self.DeclareVectorOutputPort(
            "heading", 1, self._CalcHeading, prerequisites_of_calc={xc}
        )
        self._ground_velocity_port = self.DeclareVectorOutputPort(
            "ground_velocity",
            2,
            self._CalcGroundVelocity,
            prerequisites_of_calc={xc, self._wind_port.ticket()},
        )

    def _DeclareKinematicsPort(self):
        """The ``kinematics`` output (declared after ``motion_power``)."""
        self._kinematics_port = self.DeclareVectorOutputPort(
            "kinematics",
            5,
            self._CalcKinematics,
            prerequisites_of_calc={self.xc_ticket(), self._wind_port.ticket()},
        )

    def _StateList(self, context):
        return context.get_continuous_state_vector().CopyToVector().tolist()

    def _CalcPosition(self, context, output):
        x, y, _ = self._StateList(context)
        output.SetAtIndex(0, x)
        output.SetAtIndex(1, y)

    def _CalcHeading(self, context, output):
        _, _, heading = self._StateList(context)
        output.SetAtIndex(0, heading)

    def _CalcGroundVelocity(self, context, output):
        _, _, heading = self._StateList(context)
        wind = self._wind_port.Eval(context).tolist()
        vx, vy = _GroundVelocity(heading, wind, self._airspeed)
        output.SetAtIndex(0, vx)
        output.SetAtIndex(1, vy)

    def _CalcKinematics(self, context, output):
        x, y, heading = self._StateList(context)
        wind = self._wind_port.Eval(context).tolist()
        output.SetFromVector([x, y, heading, *_GroundVelocity(heading, wind, self._airspeed)])

    def DoCalcTimeDerivatives(self, context, derivatives):
        derivatives.SetFromVector(
            FixedWingDynamics(
                self._StateList(context),
                self._u_port.Eval(context)[0],
                self._wind_port.Eval(context).tolist(),
                self._airspeed,
                self._max_rate,
            )
        )


@TemplateSystem.define("FixedWingPlant_")
def FixedWingPlant_(T):
    """Scalar-type template of :class:`FixedWingPlant` (float, AutoDiffXd, Expression)."""

    class Impl(_ContinuousFixedWing, LeafSystem_[T]):
        """Fixed-wing unicycle at constant airspeed in wind, with its motion power (continuous).

        ṗ = v_a [cos ψ, sin ψ] + w,   ψ̇ = sat(u, ψ̇_max),   ψ̇_max = g tan(φ_max) / v_a,
        P_m = P_level (1 − f + f n²),   n² = 1 + (v_a ψ̇ / g)²   (see the module docstring;
        :func:`FixedWingDynamics`, :func:`MotionPower`).

        Continuous state (x, y, ψ) [m, m, rad] (:data:`AircraftState`), initialised from
        ``vehicle.initial_position`` and ``vehicle.initial_heading_deg``; ``vehicle`` is copied.
        Ports:

        - ``heading_rate_command`` (1) u [rad/s], saturated here at ±ψ̇_max; a NaN or infinite
          command raises :class:`NonFiniteCommandError` (``Simulate`` ends the flight with status
          ``numerical_failure``), never a full-rate turn;
        - ``wind`` (2) w [m/s] (connect e.g. a ConstantVectorSource);
        - ``position`` (2) p [m], depends on the state only;
        - ``heading`` (1) ψ [rad], the state, *not wrapped* (continuous through full turns; use
          :func:`WrapToPi` for display), depends on the state only;
        - ``ground_velocity`` (2) ṗ = v_a m(ψ) + w [m/s], depends on the state and ``wind`` (not
          on the command, so plant + guidance form no algebraic loop);
        - ``motion_power`` (1) P_m [W] at the saturated heading rate, i.e. the power of the rate
          applied from now on (direct feedthrough of the command only);
        - ``kinematics`` (5) (x, y, ψ, ṗ) [m, m, rad, m/s, m/s] (:data:`AircraftKinematics`):
          position, heading and ground velocity in one vector, the guidance's input.

        Supports scalar conversion (ToAutoDiffXd, ToSymbolic).

        .. pydrake_system::

            name: FixedWingPlant
            input_ports:
            - heading_rate_command
            - wind
            output_ports:
            - position
            - heading
            - ground_velocity
            - motion_power
            - kinematics
        """

        def _construct(self, vehicle: VehicleParams, converter=None):
            LeafSystem_[T].__init__(self, converter)
            vehicle.Validate("vehicle")
            vehicle = copy.deepcopy(vehicle)
            self.DeclareContinuousState(BasicVector_[T](self._InitialState(vehicle)))
            self._DeclareInputs(vehicle)
            self._DeclareStateOutputs()
            self._DeclareMotionPowerPort()
            self._DeclareKinematicsPort()

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other._vehicle, converter=converter)

        def SetPose(self, context, position, heading):
            """Sets (x, y) [m] and ψ [rad] in ``context``."""
            context.get_mutable_continuous_state_vector().SetFromVector(
                self._PoseVector(position, heading)
            )

    return Impl


FixedWingPlant = FixedWingPlant_[None]
"""The float instantiation: ``FixedWingPlant(vehicle: VehicleParams)``."""


class FixedWingArcPlant(_FixedWingPorts, LeafSystem):
    """Fixed-wing unicycle stepped exactly over a fixed step h, the turn rate held (discrete).

    Every h [s] (offset 0): ω = sat(u, ψ̇_max) from the command at the step's start, then
    (x, y, ψ) ← :func:`ArcStep` (the exact arc with v_a, w and ω held over the step; module
    docstring). The command is read once per step, so plant and guidance run once per step
    (measured on plan i: 1.04 guidance evaluations per 0.01 s step, against 2.27 for the
    continuous :class:`FixedWingPlant` under RK2). The plant is exact for the held command; the
    closed loop differs from the continuous one by that hold, to first order in h (reference
    survey, c1 = −1000: ≤ 0.18 m at h = 0.01 s and ≤ 0.018 m at h = 0.001 s from a 1 kHz
    continuous run, whose own RK2 at 0.01 s is within 1.3 mm of it).

    ``motion_power`` stays direct feedthrough of the command rather than a state output (the
    rate applied over the last step): the command is computed once per step and cached, so a
    state output would save no guidance evaluation, and it would hand the sensor the power of
    the step just flown, one step late.

    Args:
        vehicle: :class:`~eaplan_drake.params.VehicleParams` (validated, copied).
        step: h [s], > 0 (the scenario's ``simulation.max_step``; make every other rate an integer
            multiple of it so event times coincide).

    Discrete state, one group: ``kinematics`` (x, y, ψ, ṗ_x, ṗ_y) [m, m, rad, m/s, m/s]
    (:data:`AircraftKinematics`; ψ not wrapped, ṗ = v_a m(ψ) + w, :func:`GroundVelocity`), the
    pose initialised from ``vehicle.initial_position`` and ``vehicle.initial_heading_deg``. The
    ``kinematics`` output is this group (a state output port: no Python call per read, one read
    per step by the guidance); ``position``, ``heading`` and ``ground_velocity`` are its parts.
    The ground velocity is computed where the wind is read: by the initialization event
    (``Simulator.Initialize``), by every update (from the new heading) and by :meth:`SetPose`
    when the ``wind`` input has a value; it is NaN in a context none of these has touched. For
    the constant wind of a flight it is, bit for bit, GroundVelocity(ψ, w) of the heading in the
    state (what a callback output would compute at every read); a wind input that changes
    between steps reaches it at the next update (so, unlike :class:`FixedWingPlant`'s, it is not
    direct feedthrough of ``wind``).

    Ports and units as :class:`FixedWingPlant`; ``motion_power`` (direct feedthrough of the
    command) is the power of the rate applied over the step that starts now, which a sensor
    sampling at the same instant holds over that step. Float only (no scalar conversion).

    .. pydrake_system::

        name: FixedWingArcPlant
        input_ports:
        - heading_rate_command
        - wind
        output_ports:
        - position
        - heading
        - ground_velocity
        - motion_power
        - kinematics
    """

    def __init__(self, vehicle: VehicleParams, *, step: float):
        super().__init__()
        vehicle.Validate("vehicle")
        if not (isinstance(step, int | float) and math.isfinite(step) and step > 0.0):
            raise ValueError(f"FixedWingArcPlant: step must be > 0 s, got {step!r}")
        vehicle = copy.deepcopy(vehicle)
        self._step = float(step)
        kinematics = np.full(5, np.nan)
        kinematics[:3] = self._InitialState(vehicle)
        self._kinematics_index = self.DeclareDiscreteState(kinematics)
        self.DeclareInitializationDiscreteUpdateEvent(self._Initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(self._step, 0.0, self._Update)
        self._DeclareInputs(vehicle)
        state = {self.discrete_state_ticket(self._kinematics_index)}
        self._position_port = self.DeclareVectorOutputPort(
            "position", 2, self._CalcPosition, prerequisites_of_calc=state
        )
        self._heading_port = self.DeclareVectorOutputPort(
            "heading", 1, self._CalcHeading, prerequisites_of_calc=state
        )
        self._ground_velocity_port = self.DeclareVectorOutputPort(
            "ground_velocity", 2, self._CalcGroundVelocity, prerequisites_of_calc=state
        )
        self._DeclareMotionPowerPort()
        self._kinematics_port = self.DeclareStateOutputPort("kinematics", self._kinematics_index)

    def time_step(self) -> float:
        """h [s]."""
        return self._step

    def SetPose(self, context, position, heading):
        """Sets (x, y) [m] and ψ [rad] in ``context``, and the ground velocity from them if the
        ``wind`` input has a value (NaN otherwise, until the next update)."""
        pose = self._PoseVector(position, heading)
        wind = (
            self._wind_port.Eval(context).tolist()
            if self._wind_port.HasValue(context)
            else [math.nan, math.nan]
        )
        kinematics = [*pose.tolist(), *_GroundVelocity(float(pose[2]), wind, self._airspeed)]
        context.get_mutable_discrete_state().set_value(self._kinematics_index, kinematics)

    # The update handlers read the state from ``discrete_state``: Drake fills it with the
    # context's discrete state before calling them. One numpy view, read and written in place.

    def _Initialize(self, context, discrete_state):
        k = discrete_state.get_mutable_value(self._kinematics_index)
        wind = self._wind_port.Eval(context).tolist()
        k[3], k[4] = _GroundVelocity(k.item(2), wind, self._airspeed)

    def _Update(self, context, discrete_state):
        k = discrete_state.get_mutable_value(self._kinematics_index)
        x, y, psi = k.tolist()[:3]
        wind = self._wind_port.Eval(context).tolist()
        x, y, psi = ArcStep(
            (x, y, psi), self._AppliedRate(context), wind, self._airspeed, self._step
        )
        vx, vy = _GroundVelocity(psi, wind, self._airspeed)
        k[0] = x
        k[1] = y
        k[2] = psi
        k[3] = vx
        k[4] = vy

    def _Kinematics(self, context) -> list:
        return context.get_discrete_state(self._kinematics_index).get_value().tolist()

    def _CalcPosition(self, context, output):
        x, y = self._Kinematics(context)[:2]
        output.SetAtIndex(0, x)
        output.SetAtIndex(1, y)

    def _CalcHeading(self, context, output):
        output.SetAtIndex(0, self._Kinematics(context)[2])

    def _CalcGroundVelocity(self, context, output):
        vx, vy = self._Kinematics(context)[3:]
        output.SetAtIndex(0, vx)
        output.SetAtIndex(1, vy)
