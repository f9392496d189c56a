"""Fixed-wing aircraft: unicycle at constant airspeed in wind, with a motion (propulsion) power.

Kinematics (DESIGN.md "Aircraft", paper 001 Sec. III-A), state (x, y, ψ) [m, m, rad]:

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

All functions here are pure (numpy/float, no Drake); :class:`FixedWingPlant` is the thin Drake
system around them.
"""

import math

import numpy as np
from pydrake.systems.framework import BasicVector_, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from eaplan_drake.params import MotionPowerParams, VehicleParams

__all__ = [
    "GRAVITY",
    "FixedWingDynamics",
    "FixedWingPlant",
    "FixedWingPlant_",
    "GroundVelocity",
    "LoadFactor",
    "MaxHeadingRate",
    "MotionPower",
    "MotionPowerRange",
    "NonFiniteCommandError",
    "CheckedCommand",
    "WrapToPi",
]

GRAVITY = 9.81
"""g [m/s²]."""


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


def MotionPower(airspeed, heading_rate, params: MotionPowerParams):
    """P_m = P_level (1 − f + f n²) [W] at heading rate ψ̇ [rad/s] (numpy-broadcasting).

    n² − 1 = (v_a ψ̇ / g)², so this is P_level (1 + f (v_a ψ̇ / g)²).
    """
    k = np.asarray(airspeed) * np.asarray(heading_rate) / GRAVITY
    return params.level_power * (1.0 + params.induced_fraction * k * k)


def MotionPowerRange(vehicle: VehicleParams) -> tuple[float, float]:
    """(min, max) motion power [W] of the vehicle: straight flight and a turn at ψ̇_max.

    max = P_level (1 + f tan² φ_max), independent of the airspeed.
    """
    mp = vehicle.motion_power
    tan_phi = math.tan(math.radians(vehicle.max_bank_angle_deg))
    return mp.level_power, mp.level_power * (1.0 + mp.induced_fraction * tan_phi**2)


def GroundVelocity(heading, wind, airspeed: float) -> np.ndarray:
    """ṗ = v_a [cos ψ, sin ψ] + w [m/s]."""
    w = np.asarray(wind, dtype=float)
    return airspeed * np.array([math.cos(heading), math.sin(heading)]) + w


class NonFiniteCommandError(ValueError):
    """The heading-rate command u is NaN or infinite: an upstream failure, never a turn."""


def CheckedCommand(u) -> float:
    """u [rad/s] as a float; :class:`NonFiniteCommandError` if it is NaN or ±inf (a NaN would
    otherwise pass ``min``/``max`` saturation as a full-rate turn)."""
    u = float(u)
    if not math.isfinite(u):
        raise NonFiniteCommandError(f"FixedWingPlant: heading_rate_command is not finite: {u}")
    return u


def FixedWingDynamics(state, heading_rate_command, wind, airspeed, max_heading_rate):
    """f(x, u, w) = [v_a cos ψ + w_x, v_a sin ψ + w_y, sat(u, ψ̇_max)] for x = (x, y, ψ);
    a non-finite u raises :class:`NonFiniteCommandError`."""
    psi = float(state[2])
    u = min(max(CheckedCommand(heading_rate_command), -max_heading_rate), max_heading_rate)
    return np.array(
        [
            airspeed * math.cos(psi) + float(wind[0]),
            airspeed * math.sin(psi) + float(wind[1]),
            u,
        ]
    )


def WrapToPi(angle):
    """The angle wrapped into [−π, π) [rad] (the plant's ``heading`` output is *not* wrapped)."""
    return (np.asarray(angle) + math.pi) % (2.0 * math.pi) - math.pi


@TemplateSystem.define("FixedWingPlant_")
def FixedWingPlant_(T):
    """Scalar-type template of :class:`FixedWingPlant` (float, AutoDiffXd, Expression)."""

    if T is float:
        cos, sin, smin, smax = math.cos, math.sin, min, max
    else:
        import pydrake.math as pm

        cos, sin, smin, smax = pm.cos, pm.sin, pm.min, pm.max

    class Impl(LeafSystem_[T]):
        """Fixed-wing unicycle at constant airspeed in wind, with its motion power.

        ṗ = v_a [cos ψ, sin ψ] + w,   ψ̇ = sat(u, ψ̇_max),   ψ̇_max = g tan(φ_max) / v_a,
        P_m = P_level (1 − f + f n²),   n² = 1 + (v_a ψ̇ / g)²   (see the module docstring).

        Continuous state (x, y, ψ) [m, m, rad], initialised from ``vehicle.initial_position`` and
        ``vehicle.initial_heading_deg``. Ports:

        - ``heading_rate_command`` (1) u [rad/s], saturated here at ±ψ̇_max; a NaN or infinite
          command raises :class:`NonFiniteCommandError` (``Simulate`` ends the flight with status
          ``numerical_failure``), never a full-rate turn;
        - ``wind`` (2) w [m/s] (connect e.g. a ConstantVectorSource);
        - ``position`` (2) p [m], depends on the state only;
        - ``heading`` (1) ψ [rad], the integrated state, *not wrapped* (continuous through full
          turns; use :func:`WrapToPi` for display), depends on the state only;
        - ``ground_velocity`` (2) ṗ = v_a m(ψ) + w [m/s], depends on the state and ``wind`` (not
          on the command, so plant + guidance form no algebraic loop);
        - ``motion_power`` (1) P_m [W] at the saturated heading rate (direct feedthrough of the
          command only).

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
        """

        def _construct(self, vehicle: VehicleParams, converter=None):
            LeafSystem_[T].__init__(self, converter)
            vehicle.Validate("vehicle")
            self._vehicle = vehicle
            self._airspeed = float(vehicle.airspeed)
            self._max_rate = MaxHeadingRate(vehicle)
            mp = vehicle.motion_power
            k = self._airspeed / GRAVITY
            # P_m = c0 + c2 ψ̇², precomputed.
            self._p0 = float(mp.level_power)
            self._p2 = float(mp.level_power * mp.induced_fraction * k * k)

            x0 = [*vehicle.initial_position, math.radians(vehicle.initial_heading_deg)]
            self._initial_state = np.array(x0, dtype=float)
            self.DeclareContinuousState(BasicVector_[T](self._initial_state))
            self._u_port = self.DeclareVectorInputPort("heading_rate_command", 1)
            self._wind_port = self.DeclareVectorInputPort("wind", 2)
            xc = {self.xc_ticket()}
            self._position_port = self.DeclareVectorOutputPort(
                "position", 2, self._CalcPosition, prerequisites_of_calc=xc
            )
            self._heading_port = self.DeclareVectorOutputPort(
                "heading", 1, self._CalcHeading, prerequisites_of_calc=xc
            )
            self._ground_velocity_port = self.DeclareVectorOutputPort(
                "ground_velocity",
                2,
                self._CalcGroundVelocity,
                prerequisites_of_calc={
                    self.xc_ticket(),
                    self.input_port_ticket(self._wind_port.get_index()),
                },
            )
            self._motion_power_port = self.DeclareVectorOutputPort(
                "motion_power",
                1,
                self._CalcMotionPower,
                prerequisites_of_calc={self.input_port_ticket(self._u_port.get_index())},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other._vehicle, converter=converter)

        # -- accessors ------------------------------------------------------------------------

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

        def get_motion_power_output_port(self):
            return self._motion_power_port

        def SetPose(self, context, position, heading):
            """Sets (x, y) [m] and ψ [rad] in ``context``."""
            context.get_mutable_continuous_state_vector().SetFromVector(
                np.array([position[0], position[1], heading], dtype=float)
            )

        # -- callbacks ------------------------------------------------------------------------

        def DoCalcTimeDerivatives(self, context, derivatives):
            psi = context.get_continuous_state_vector().GetAtIndex(2)
            u = self._u_port.Eval(context)[0]
            if T is float:
                u = CheckedCommand(u)
            w = self._wind_port.Eval(context)
            r = self._max_rate
            v = self._airspeed
            d = derivatives.get_mutable_vector()
            d.SetAtIndex(0, v * cos(psi) + w[0])
            d.SetAtIndex(1, v * sin(psi) + w[1])
            d.SetAtIndex(2, smax(-r, smin(r, u)))

        def _CalcPosition(self, context, output):
            x = context.get_continuous_state_vector()
            output.SetAtIndex(0, x.GetAtIndex(0))
            output.SetAtIndex(1, x.GetAtIndex(1))

        def _CalcHeading(self, context, output):
            output.SetAtIndex(0, context.get_continuous_state_vector().GetAtIndex(2))

        def _CalcGroundVelocity(self, context, output):
            psi = context.get_continuous_state_vector().GetAtIndex(2)
            w = self._wind_port.Eval(context)
            output.SetAtIndex(0, self._airspeed * cos(psi) + w[0])
            output.SetAtIndex(1, self._airspeed * sin(psi) + w[1])

        def _CalcMotionPower(self, context, output):
            r = self._max_rate
            u = self._u_port.Eval(context)[0]
            if T is float:
                u = CheckedCommand(u)
            u = smax(-r, smin(r, u))
            output.SetAtIndex(0, self._p0 + self._p2 * u * u)

    return Impl


FixedWingPlant = FixedWingPlant_[None]
"""The float instantiation: ``FixedWingPlant(vehicle: VehicleParams)``."""
