"""VectorFieldGuidance: the wind-corrected guiding-vector-field law, its guards and its tracking."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.errors import ScenarioError
from eaplan_drake.flight.guidance import (
    CheckWindBelowAirspeed,
    DesiredCourseRate,
    GuidingVectorField,
    HeadingRateCommand,
    VectorFieldGuidance,
)
from eaplan_drake.flight.paths import Circle, Line
from eaplan_drake.flight.plant import (
    FixedWingArcPlant,
    FixedWingDynamics,
    FixedWingPlant,
    GroundVelocity,
    MaxHeadingRate,
)
from eaplan_drake.params import GuidanceParams, VehicleParams

VA = 15.0
WIND = 5.0
RMAX = MaxHeadingRate(VA, math.radians(45.0))
KE = GuidanceParams().k_e
KD = GuidanceParams().k_d
WIND_DIRECTIONS = [k * 45.0 for k in range(8)]


def _Wind(deg, speed=WIND):
    return speed * np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])


def _Cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


# -- the field and the law at single points -----------------------------------------------------


def test_field_is_tangent_on_the_path_and_points_inward_off_it():
    c = Circle([10.0, -5.0], 70.0, s=1.0, k_e=KE)
    on = np.array([80.0, -5.0])
    np.testing.assert_allclose(GuidingVectorField(c.descriptor(), on), [0.0, -1.0], atol=1e-12)
    ccw = Circle([10.0, -5.0], 70.0, s=-1.0, k_e=KE)
    np.testing.assert_allclose(GuidingVectorField(ccw.descriptor(), on), [0.0, 1.0], atol=1e-12)
    outside = GuidingVectorField(c.descriptor(), [110.0, -5.0])
    assert outside[0] < 0.0  # towards the centre
    inside = GuidingVectorField(c.descriptor(), [40.0, -5.0])
    assert inside[0] > 0.0  # away from the centre
    line = Line([0.0, 0.0], [1.0, 0.0], s=1.0, k_e=KE)  # φ = x, s = +1 travels towards −y
    np.testing.assert_allclose(GuidingVectorField(line.descriptor(), [0, 3]), [0, -1], atol=0)
    np.testing.assert_allclose(
        GuidingVectorField(line.descriptor(), [20.0, 0.0]), [-KE * 20.0, -1.0], rtol=1e-15
    )


@pytest.mark.parametrize("s", [1.0, -1.0])
@pytest.mark.parametrize("wind_deg", [0.0, 100.0, 225.0])
def test_command_on_the_circle_is_the_steady_turn_rate(s, wind_deg):
    """On the circle with the course along the field, u = χ̇ V_g² / (V_g² − wᵀṗ), χ̇ = −s V_g/R."""
    R = 70.0
    c = Circle([0.0, 0.0], R, s=s, k_e=KE).descriptor()
    w = _Wind(wind_deg)
    for theta in np.linspace(0.0, 2.0 * math.pi, 13):
        p = R * np.array([math.cos(theta), math.sin(theta)])
        t = GuidingVectorField(c, p)  # unit tangent on the path
        tw = t @ w
        vg = tw + math.sqrt(VA**2 - w @ w + tw**2)  # ground speed along t at airspeed v_a
        pdot = vg * t
        m = (pdot - w) / VA
        psi = math.atan2(m[1], m[0])
        chi_rate = -s * vg / R
        assert DesiredCourseRate(c, p, pdot) == pytest.approx(chi_rate, rel=1e-12)
        expected = chi_rate * vg**2 / (vg**2 - w @ pdot)
        assert abs(expected) < RMAX
        u = HeadingRateCommand(p, pdot, psi, c, VA, KD, RMAX)
        assert u == pytest.approx(expected, rel=1e-12, abs=1e-14)


def test_feedback_turns_the_course_towards_the_field():
    """Line φ = x (s = +1: travel towards −y), no wind, on the path. The field's course rate is
    χ̇_d = −s k_e ẋ there; the feedback adds −sign(δ) k_d sin|δ| for a course δ counter-clockwise
    of the field (it turns back towards it), and the full ±k_d beyond 90°."""
    d = Line([0.0, 0.0], [1.0, 0.0], s=1.0, k_e=KE).descriptor()
    rmax = 10.0  # no saturation here

    def Command(psi, kd):
        pdot = VA * np.array([math.cos(psi), math.sin(psi)])
        return HeadingRateCommand([0.0, 0.0], pdot, psi, d, VA, kd, rmax)

    for delta in (0.1, 0.5, 1.2):
        for sign in (1.0, -1.0):
            psi = -math.pi / 2 + sign * delta
            feedback = Command(psi, KD) - Command(psi, 0.0)
            assert feedback == pytest.approx(-sign * KD * math.sin(delta), rel=1e-12)
            chi_rate = -KE * VA * math.cos(psi)
            assert Command(psi, KD) == pytest.approx(chi_rate + feedback, rel=1e-12)
    for sign in (1.0, -1.0):  # more than 90° off: the full gain, the short way round
        psi = -math.pi / 2 + sign * 2.0
        assert Command(psi, KD) - Command(psi, 0.0) == pytest.approx(-sign * KD, rel=1e-12)
    # Exactly anti-aligned: still a full turn, never the sine law's zero.
    assert abs(Command(math.pi / 2, KD)) == pytest.approx(KD)


def test_wind_factor():
    """On the line φ = x with a course error in wind, u = ‖ṗ‖² / (v_a m(ψ)ᵀṗ) (χ̇_d + k_d e) with
    χ̇_d = −s k_e ẋ; and aligned with the field in wind the command vanishes on a line."""
    d = Line([0.0, 0.0], [1.0, 0.0], s=1.0, k_e=KE).descriptor()
    w = _Wind(30.0)
    psi = 1.3 * math.pi
    pdot = GroundVelocity(psi, w, VA)
    m = np.array([math.cos(psi), math.sin(psi)])
    e = _Cross(pdot / np.linalg.norm(pdot), [0.0, -1.0])
    factor = (pdot @ pdot) / (VA * (m @ pdot))
    u = HeadingRateCommand([0.0, 0.0], pdot, psi, d, VA, KD, 10.0)
    assert u == pytest.approx(factor * (-KE * pdot[0] + KD * e), rel=1e-12)
    # Course along the field (−y) in a crosswind: the heading crabs into the wind, u = 0.
    vg = math.sqrt(VA**2 - 4.0**2)
    m = (np.array([0.0, -vg]) - [4.0, 0.0]) / VA
    psi = math.atan2(m[1], m[0])
    assert HeadingRateCommand([0.0, 0.0], [0.0, -vg], psi, d, VA, KD, 10.0) == pytest.approx(0.0)


def test_command_is_finite_and_bounded_everywhere():
    rng = np.random.default_rng(7)
    c = Circle([10.0, 20.0], 70.0, s=1.0, k_e=KE).descriptor()
    paths = [
        c,
        Circle([0.0, 0.0], 70.0, s=-1.0, k_e=KE).descriptor(),
        Line([5.0, 5.0], [0.3, -1.0], s=-1.0, k_e=KE).descriptor(),
        np.zeros(6),  # no path yet: straight flight
    ]
    centre = [10.0, 20.0]
    special_velocities = [
        [0.0, 0.0],  # zero ground speed
        [1e-9, -1e-9],  # near-zero ground speed
        [1e-3, 0.0],
        [-14.0, 0.0],  # against the heading: m(ψ)ᵀṗ < 0 for ψ = 0
        [0.0, 15.0],  # m(ψ)ᵀṗ = 0 for ψ = 0
        [1e6, -1e6],
    ]
    special_positions = [centre, [10.0 + 1e-12, 20.0], [80.0, 20.0], [1e6, -1e6]]
    for d in paths:
        for p in special_positions:
            for v in special_velocities:
                for psi in (0.0, 2.0, -40.0):
                    u = HeadingRateCommand(p, v, psi, d, VA, KD, RMAX)
                    assert math.isfinite(u) and abs(u) <= RMAX
        for _ in range(300):
            p = rng.uniform(-300.0, 300.0, 2)
            v = rng.uniform(-20.0, 20.0, 2)
            u = HeadingRateCommand(p, v, rng.uniform(-10, 10), d, VA, KD, RMAX)
            assert math.isfinite(u) and abs(u) <= RMAX
    # At the circle's centre the field has no direction: no course-rate feed-forward.
    assert DesiredCourseRate(c, centre, [15.0, 0.0]) == 0.0
    assert HeadingRateCommand(centre, [15.0, 0.0], 0.0, c, VA, KD, RMAX) == 0.0
    # Zero ground speed: no course, no command.
    assert HeadingRateCommand([80.0, 20.0], [0.0, 0.0], 1.0, c, VA, KD, RMAX) == 0.0


def test_non_finite_input_raises():
    d = Line([0.0, 0.0], [1.0, 0.0], k_e=KE).descriptor()
    with pytest.raises(ValueError, match="non-finite input"):
        HeadingRateCommand([math.nan, 0.0], [15.0, 0.0], 0.0, d, VA, KD, RMAX)
    with pytest.raises(ValueError, match="non-finite input"):
        HeadingRateCommand([0.0, 0.0], [15.0, 0.0], math.inf, d, VA, KD, RMAX)


# -- the Drake system ---------------------------------------------------------------------------


def test_constructor_errors():
    g = GuidanceParams()
    with pytest.raises(ValueError, match=r"wind_speed must be in \[0, airspeed = 15\)"):
        VectorFieldGuidance(g, airspeed=15.0, max_heading_rate=RMAX, wind_speed=15.0)
    with pytest.raises(ValueError, match="wind_speed"):
        VectorFieldGuidance(g, airspeed=15.0, max_heading_rate=RMAX, wind_speed=-1.0)
    with pytest.raises(ValueError, match="airspeed must be > 0"):
        VectorFieldGuidance(g, airspeed=0.0, max_heading_rate=RMAX)
    with pytest.raises(ValueError, match="max_heading_rate must be > 0"):
        VectorFieldGuidance(g, airspeed=15.0, max_heading_rate=0.0)
    with pytest.raises(ScenarioError, match=r"guidance\.k_d: must be > 0"):
        VectorFieldGuidance(GuidanceParams(k_d=0.0), airspeed=15.0, max_heading_rate=RMAX)
    with pytest.raises(ValueError, match="wind_speed"):
        CheckWindBelowAirspeed(20.0, 15.0)
    CheckWindBelowAirspeed(14.9, 15.0)
    VectorFieldGuidance(g, airspeed=15.0, max_heading_rate=RMAX, wind_speed=5.0)


def test_ports_and_output_matches_pure_function():
    sys = VectorFieldGuidance(GuidanceParams(), airspeed=VA, max_heading_rate=RMAX)
    sizes = {"kinematics": 5, "path": 6}
    assert sys.num_input_ports() == 2 and sys.num_output_ports() == 1
    for name, size in sizes.items():
        assert sys.GetInputPort(name).size() == size
    assert sys.GetOutputPort("heading_rate_command").size() == 1
    assert sys.get_path_input_port().get_name() == "path"
    assert sys.get_kinematics_input_port().get_name() == "kinematics"
    assert sys.get_heading_rate_command_output_port().get_name() == "heading_rate_command"
    ctx = sys.CreateDefaultContext()
    rng = np.random.default_rng(11)
    d = Circle([3.0, -7.0], 62.0, s=-1.0, k_e=0.03).descriptor()
    for _ in range(10):
        p, v, psi = rng.uniform(-150, 150, 2), rng.uniform(-20, 20, 2), rng.uniform(-7, 7)
        sys.GetInputPort("kinematics").FixValue(ctx, [*p, psi, *v])
        sys.GetInputPort("path").FixValue(ctx, d)
        u = sys.GetOutputPort("heading_rate_command").Eval(ctx)[0]
        assert u == HeadingRateCommand(p, v, psi, d, VA, KD, RMAX)


def test_guidance_keeps_its_own_copy_of_the_gains():
    params = GuidanceParams(k_d=1.0)
    sys = VectorFieldGuidance(params, airspeed=VA, max_heading_rate=RMAX)
    params.k_d = 2.0
    ctx = sys.CreateDefaultContext()
    d = Line([0.0, 0.0], [1.0, 0.0], s=1.0, k_e=KE).descriptor()
    psi = -math.pi / 2 + 0.5
    v = VA * np.array([math.cos(psi), math.sin(psi)])
    sys.GetInputPort("kinematics").FixValue(ctx, [0.0, 0.0, psi, *v])
    sys.GetInputPort("path").FixValue(ctx, d)
    u = sys.GetOutputPort("heading_rate_command").Eval(ctx)[0]
    assert u == HeadingRateCommand([0.0, 0.0], v, psi, d, VA, 1.0, RMAX)


# -- closed-loop tracking (pure functions, fixed-step RK4) --------------------------------------


def _Fly(path, x0, wind, T, h=0.05):
    """RK4 of plant + guidance; returns times and the distance to the path (signed, φ-side)."""
    d = path.descriptor()

    def rate(x):
        v = GroundVelocity(x[2], wind, VA)
        return FixedWingDynamics(
            x, HeadingRateCommand(x[:2], v, x[2], d, VA, KD, RMAX), wind, VA, RMAX
        )

    n = int(round(T / h))
    x = np.asarray(x0, dtype=float)
    xs = np.empty((n, 3))
    for i in range(n):
        k1 = rate(x)
        k2 = rate(x + 0.5 * h * k1)
        k3 = rate(x + 0.5 * h * k2)
        k4 = rate(x + h * k3)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        xs[i] = x
    t = h * np.arange(1, n + 1)
    if path.is_circle:
        dist = np.hypot(*(xs[:, :2] - path.center).T) - path.radius
    else:
        dist = xs[:, :2] @ np.asarray(path.b) + path.c
    return t, dist


T_FLIGHT = 90.0
T_STEADY = 45.0  # convergence from 100 m takes ≤ 25 s at the default k_e (see GuidanceParams)


@pytest.mark.parametrize("s", [1.0, -1.0])
@pytest.mark.parametrize("wind_deg", WIND_DIRECTIONS)
def test_tracks_circle_and_line_in_wind_from_100m(wind_deg, s):
    """15 m/s airspeed, 5 m/s wind: start 100 m off, heading straight away from the path (the
    worst case); converge without leaving a corridor, then stay within 0.5 m (mean ≪ 1 m)."""
    w = _Wind(wind_deg)
    turn_diameter = 2.0 * (VA + WIND) / RMAX  # widest ground turn: 61 m
    corridor = 100.0 + turn_diameter
    # Circle R = 70 m: start 100 m outside, heading radially outward.
    circle = Circle([0.0, 0.0], 70.0, s=s, k_e=KE)
    t, dist = _Fly(circle, [170.0, 0.0, 0.0], w, T_FLIGHT)
    steady = np.abs(dist[t >= T_STEADY])
    assert np.max(np.abs(dist)) < corridor
    assert dist.min() > -1.0  # no overshoot into the circle
    assert steady.max() < 0.5 and steady.mean() < 0.05
    # Line through the origin, normal +x: start at x = −100, heading −x (away from the line).
    line = Line([0.0, 0.0], [1.0, 0.0], s=s, k_e=KE)
    t, dist = _Fly(line, [-100.0, 0.0, math.pi], w, T_FLIGHT)
    steady = np.abs(dist[t >= T_STEADY])
    assert np.max(np.abs(dist)) < corridor
    assert dist.max() < 1.0  # no overshoot across the line
    assert steady.max() < 0.5 and steady.mean() < 0.05


@pytest.mark.parametrize("wind_deg", [0.0, 135.0, 270.0])
def test_converges_from_the_circle_centre(wind_deg):
    """At the centre ∇φ = 0 (no field direction): the command stays finite, the aircraft leaves
    the centre and converges onto the circle from inside. Crossing the field's 1/k_e = 20 m
    boundary layer nearly head-on at up to 20 m/s ground speed, it overshoots by ≤ 2.7 m
    (measured over 8 wind directions, both directions of travel)."""
    circle = Circle([0.0, 0.0], 70.0, s=-1.0, k_e=KE)
    t, dist = _Fly(circle, [0.0, 0.0, 0.3], _Wind(wind_deg), 60.0)
    assert np.all(np.isfinite(dist))
    assert dist.max() < 5.0
    assert np.abs(dist[t >= 40.0]).max() < 0.5


# -- a short Simulator run of plant + guidance ---------------------------------------------------


def _Diagram(path, wind, x0, arc_step=None):
    vehicle = VehicleParams(initial_position=list(x0[:2]), initial_heading_deg=math.degrees(x0[2]))
    builder = DiagramBuilder()
    if arc_step is None:
        plant = builder.AddNamedSystem("plant", FixedWingPlant(vehicle))
    else:
        plant = builder.AddNamedSystem("plant", FixedWingArcPlant(vehicle, step=arc_step))
    guidance = builder.AddNamedSystem(
        "guidance",
        VectorFieldGuidance(
            GuidanceParams(), airspeed=VA, max_heading_rate=MaxHeadingRate(vehicle), wind_speed=WIND
        ),
    )
    w = builder.AddSystem(ConstantVectorSource(np.asarray(wind, dtype=float)))
    p = builder.AddSystem(ConstantVectorSource(path.descriptor()))
    builder.Connect(w.get_output_port(), plant.GetInputPort("wind"))
    builder.Connect(plant.GetOutputPort("kinematics"), guidance.GetInputPort("kinematics"))
    builder.Connect(p.get_output_port(), guidance.GetInputPort("path"))
    builder.Connect(
        guidance.GetOutputPort("heading_rate_command"), plant.GetInputPort("heading_rate_command")
    )
    pos = LogVectorOutput(plant.GetOutputPort("position"), builder, 0.1)
    cmd = LogVectorOutput(guidance.GetOutputPort("heading_rate_command"), builder, 0.1)
    power = LogVectorOutput(plant.GetOutputPort("motion_power"), builder, 0.1)
    return builder.Build(), pos, cmd, power


@pytest.mark.parametrize(
    "integrator, max_step",
    [
        ("runge_kutta2", 0.01),
        ("runge_kutta2", 0.05),
        (None, None),
        ("exact_arc", 0.01),
        ("exact_arc", 0.05),
    ],
)
def test_simulator_plant_and_guidance_on_circle(integrator, max_step):
    """The Diagram (no algebraic loop) tracks a 70 m circle in 5 m/s wind with Drake's
    integrators: RK2 fixed step 0.01 s / 0.05 s, and the default error-controlled RK3; and with
    the exact-arc plant stepped at 0.01 s / 0.05 s (command held over the step)."""
    circle = Circle([0.0, 0.0], 70.0, s=1.0, k_e=KE)
    arc_step = max_step if integrator == "exact_arc" else None
    diagram, pos, cmd, power = _Diagram(circle, _Wind(45.0), [170.0, 0.0, 0.0], arc_step)
    sim = Simulator(diagram)
    if integrator not in (None, "exact_arc"):
        ResetIntegratorFromFlags(sim, integrator, max_step)
    sim.AdvanceTo(80.0)
    ctx = sim.get_context()
    t = pos.FindLog(ctx).sample_times()
    xy = pos.FindLog(ctx).data()
    dist = np.hypot(xy[0], xy[1]) - 70.0
    assert np.all(np.isfinite(xy)) and np.all(np.isfinite(cmd.FindLog(ctx).data()))
    assert np.all(np.abs(cmd.FindLog(ctx).data()) <= RMAX + 1e-12)
    assert np.abs(dist).max() < 100.0 + 2.0 * (VA + WIND) / RMAX
    steady = np.abs(dist[t >= T_STEADY])
    assert steady.max() < 0.5 and steady.mean() < 0.05
    motion = power.FindLog(ctx).data()[0, t >= T_STEADY]
    assert np.all((motion >= 25.0 - 1e-9) & (motion <= 29.3))


def test_simulator_plant_and_guidance_on_line():
    line = Line([0.0, 0.0], [1.0, 1.0], s=-1.0, k_e=KE)
    diagram, pos, cmd, power = _Diagram(line, _Wind(200.0), [0.0, -100.0, 0.0])
    sim = Simulator(diagram)
    ResetIntegratorFromFlags(sim, "runge_kutta2", 0.02)
    sim.AdvanceTo(60.0)
    ctx = sim.get_context()
    t = pos.FindLog(ctx).sample_times()
    xy = pos.FindLog(ctx).data()
    dist = np.abs(xy.T @ np.asarray(line.b) + line.c)
    assert np.all(np.isfinite(xy))
    steady = dist[t >= 40.0]
    assert steady.max() < 0.5
    np.testing.assert_allclose(power.FindLog(ctx).data()[0, t >= 40.0], 25.0, atol=1e-3)
