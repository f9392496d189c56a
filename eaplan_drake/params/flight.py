"""The aircraft's and the survey's parameters: vehicle, motion power, wind, coverage and
guidance."""

import dataclasses as dc

import numpy as np

from eaplan_drake.params.bounds import (
    MAX_COORDINATE,
    MAX_DRIFT_ANGLE_DEG,
    MAX_DRIFT_SPEED,
    MAX_GUIDANCE_GAIN,
    MAX_GUST_LENGTH_SCALE,
    MAX_GUST_SIGMA,
    MAX_POLYGON_VERTICES,
    MIN_WIND_TIME_CONSTANT,
)
from eaplan_drake.params.checks import (
    _at_most,
    _check,
    _finite,
    _in_range,
    _is_int,
    _nonnegative,
    _positive,
    _vector,
)
from eaplan_drake.params.walk import _Params


@dc.dataclass
class MotionPowerParams(_Params):
    """Propulsion (motion) power of the fixed-wing aircraft, in W.

    Load-factor model: P_m = level_power · (1 − induced_fraction + induced_fraction · n²), with
    n = sqrt(1 + (v_a ψ̇ / g)²) the load factor of a coordinated turn at heading rate ψ̇ [rad/s].
    Defaults calibrated on the authors' logs (plant.py docstring): 25 W on lines, ≈ 28.7 W at the
    sharpest point of a reference turn in 5 m/s wind, survey mean ≈ 25.8 W (log: 26.2 W).
    """

    level_power: float = 25.0
    """Straight-and-level motion power at the airspeed [W]."""
    induced_fraction: float = 0.5
    """Share of the level power that scales with n² (induced drag) [-], in [0, 1]."""

    def Validate(self, key: str = "vehicle.motion_power") -> None:
        _positive(self.level_power, f"{key}.level_power")
        _in_range(self.induced_fraction, f"{key}.induced_fraction", 0.0, 1.0)


@dc.dataclass
class VehicleParams(_Params):
    """Fixed-wing unicycle ṗ = v_a [cos ψ, sin ψ] + w, ψ̇ = u with \\|u\\| ≤ g tan(φ_max) / v_a."""

    airspeed: float = 15.0
    """v_a, constant airspeed [m/s]."""
    max_bank_angle_deg: float = 45.0
    """φ_max, bank-angle limit that bounds the heading rate [deg], in (0, 80]."""
    initial_position: list[float] = dc.field(default_factory=lambda: [-100.0, 220.0])
    """p(0) = (x, y) [m]."""
    initial_heading_deg: float = 270.0
    """ψ(0), from +x counter-clockwise [deg]."""
    motion_power: MotionPowerParams = dc.field(default_factory=MotionPowerParams)

    def Validate(self, key: str = "vehicle") -> None:
        _positive(self.airspeed, f"{key}.airspeed")
        _in_range(self.max_bank_angle_deg, f"{key}.max_bank_angle_deg", 1e-3, 80.0)
        for i, v in enumerate(_vector(self.initial_position, f"{key}.initial_position", 2)):
            _check(
                abs(v) <= MAX_COORDINATE,
                f"{key}.initial_position[{i}]",
                f"must be in [-{MAX_COORDINATE:g}, {MAX_COORDINATE:g}] m (numerics), got {v:g}",
            )
        _finite(self.initial_heading_deg, f"{key}.initial_heading_deg")
        self.motion_power.Validate(f"{key}.motion_power")


@dc.dataclass
class GustParams(_Params):
    """Dryden turbulence added to the mean wind (the low-altitude forms of MIL-HDBK-1797;
    :mod:`eaplan_drake.flight.wind`): longitudinal and lateral gusts u, v [m/s] along and across
    the aircraft's heading, each of standard deviation σ, with the length scales L_u = L and
    L_v = L / 2. Off (σ = 0) by default."""

    sigma: float = 0.0
    """σ = σ_u = σ_v, the gusts' intensity [m/s], in [0, 10]; 0 = no gusts."""
    length_scale: float = 200.0
    """L = L_u = 2 L_v, the longitudinal length scale [m], in [1, 10000] (200 m is the
    MIL-HDBK-1797 low-altitude L_u at ≈ 50 m above ground)."""

    def Validate(self, key: str = "wind.gusts") -> None:
        _in_range(self.sigma, f"{key}.sigma", 0.0, MAX_GUST_SIGMA)
        _in_range(self.length_scale, f"{key}.length_scale", 1.0, MAX_GUST_LENGTH_SCALE)

    @property
    def on(self) -> bool:
        return self.sigma > 0.0


@dc.dataclass
class WindDriftParams(_Params):
    """The mean wind's speed and direction changing over the flight: a ramp plus a seeded random
    walk, clipped into [0, ``max_speed``] (:mod:`eaplan_drake.flight.wind`). Off (every rate and
    σ zero) by default."""

    speed_rate: float = 0.0
    """Ramp of the mean wind speed [m/s per minute], in [-10, 10]."""
    direction_rate_deg: float = 0.0
    """Ramp of the direction the mean wind blows towards [deg per minute], in [-180, 180]."""
    speed_sigma: float = 0.0
    """Random walk of the speed: the standard deviation of its change over one minute [m/s], in
    [0, 10]."""
    direction_sigma_deg: float = 0.0
    """Random walk of the direction: the standard deviation of its change over one minute [deg],
    in [0, 180]."""
    max_speed: float = 12.0
    """The drifting speed is clipped into [0, max_speed] [m/s]; with drift on it must be below
    ``vehicle.airspeed`` and at least ``wind.speed``."""

    def Validate(self, key: str = "wind.drift") -> None:
        _in_range(self.speed_rate, f"{key}.speed_rate", -MAX_DRIFT_SPEED, MAX_DRIFT_SPEED)
        _in_range(
            self.direction_rate_deg,
            f"{key}.direction_rate_deg",
            -MAX_DRIFT_ANGLE_DEG,
            MAX_DRIFT_ANGLE_DEG,
        )
        _in_range(self.speed_sigma, f"{key}.speed_sigma", 0.0, MAX_DRIFT_SPEED)
        _in_range(self.direction_sigma_deg, f"{key}.direction_sigma_deg", 0.0, MAX_DRIFT_ANGLE_DEG)
        _nonnegative(self.max_speed, f"{key}.max_speed")

    @property
    def on(self) -> bool:
        return any(
            v != 0.0
            for v in (
                self.speed_rate,
                self.direction_rate_deg,
                self.speed_sigma,
                self.direction_sigma_deg,
            )
        )


@dc.dataclass
class WindEstimatorParams(_Params):
    """The aircraft's wind estimate from its ground velocity and air data (airspeed, heading):
    a first-order low-pass of ṗ − v_a [cos ψ, sin ψ] (:mod:`eaplan_drake.flight.wind_estimator`)."""

    time_constant: float = 10.0
    """τ_ŵ, the filter's time constant [s], in [0.01, 1000]: longer averages more gusts out and
    lags a drifting wind by more (by rate × τ_ŵ on a ramp)."""

    def Validate(self, key: str = "wind.estimator") -> None:
        _in_range(self.time_constant, f"{key}.time_constant", MIN_WIND_TIME_CONSTANT, 1000.0)


WIND_STAIRCASE_SOURCES = ("scenario", "estimated", "truth")
"""Values of ``wind.staircase``: the wind the sequencer prices its remaining-time staircase in."""


@dc.dataclass
class WindParams(_Params):
    """The wind w [m/s]: a mean wind w̄ = speed · [cos θ_w, sin θ_w] (θ_w is where the wind blows
    *towards*), constant by default, that may drift, plus gusts; and the wind the sequencer's
    remaining-time staircase is priced in."""

    speed: float = 5.0
    """‖w̄(0)‖ [m/s], must be below the airspeed."""
    direction_deg: float = 0.0
    """θ_w(0), from +x counter-clockwise [deg]; 0 blows towards +x, 90 towards +y."""
    gusts: GustParams = dc.field(default_factory=GustParams)
    drift: WindDriftParams = dc.field(default_factory=WindDriftParams)
    seed: int = 0
    """Seed of the gusts' and the drift's draws, an integer >= 0 (derived from the scenario's
    ``random_seed`` instead when that is >= 0)."""
    estimator: WindEstimatorParams = dc.field(default_factory=WindEstimatorParams)
    staircase: str = "scenario"
    """The wind of the sequencer's remaining-time staircase: ``scenario`` (default) the constant
    ``speed`` and ``direction_deg`` above, as known at take-off; ``estimated`` the aircraft's
    estimate (``estimator``), re-read at every stage switch; ``truth`` the true mean wind w̄(t)
    (an oracle), re-read at every stage switch."""

    def Validate(self, key: str = "wind") -> None:
        _nonnegative(self.speed, f"{key}.speed")
        _finite(self.direction_deg, f"{key}.direction_deg")
        self.gusts.Validate(f"{key}.gusts")
        self.drift.Validate(f"{key}.drift")
        _check(
            _is_int(self.seed) and self.seed >= 0,
            f"{key}.seed",
            f"must be an integer >= 0, got {self.seed!r}",
        )
        self.estimator.Validate(f"{key}.estimator")
        _check(
            self.staircase in WIND_STAIRCASE_SOURCES,
            f"{key}.staircase",
            f"must be one of {', '.join(WIND_STAIRCASE_SOURCES)}, got {self.staircase!r}",
        )

    def Vector(self) -> np.ndarray:
        """w̄(0) [m/s] (:func:`WindVector`)."""
        return WindVector(self.speed, self.direction_deg)

    @property
    def changes(self) -> bool:
        """True when the wind changes in flight (gusts or drift on)."""
        return self.gusts.on or self.drift.on


def WindVector(speed: float, direction_deg: float) -> np.ndarray:
    """w = speed · [cos θ_w, sin θ_w] [m/s], θ_w [deg] the direction the wind blows towards."""
    theta = np.deg2rad(direction_deg)
    return speed * np.array([np.cos(theta), np.sin(theta)])


@dc.dataclass
class CoverageParams(_Params):
    """Zamboni-like coverage of a convex polygon (paper 003 Sec. IV-A, Alg. 1)."""

    polygon: list[list[float]] = dc.field(
        default_factory=lambda: [[-120.0, 11.0], [-120.0, 146.0], [180.0, 146.0], [180.0, 11.0]]
    )
    """Vertices v of the convex survey area [m], any order."""
    line_edge: int = 0
    """Index i of the polygon edge (v_i, v_{i+1}) the survey lines are parallel to."""
    swath_spacing: float = 10.0
    """x_d, line spacing at c1 = 0 [m]."""
    turning_radius: float = 70.0
    """r, ideal turning radius [m]; r1 = r + x_d/2 and r2(c1) = sqrt(r² + c1)."""
    min_turning_radius: float = 62.449979983983983
    """r_min [m]; bounds the path parameter: c1 ∈ [r_min² − r², 0] (sqrt(3900) → [−1000, 0])."""
    plan_file: str = ""
    """Optional authors'-format ``.pln`` plan to fly instead of generating one ("" = generate;
    "reference" = the packaged authors' plan)."""
    field: str = ""
    """Optional field to survey instead of ``polygon``: a GeoJSON, KML or QGroundControl ``.plan``
    file (WGS84; holes allowed; needs the ``[field]`` extra), read in the local east-north frame
    of its first vertex ("" = ``polygon``; ``funen_field`` = the packaged illustrative field; a
    relative path is taken from the scenario's folder)."""
    field_polygon: int = -1
    """Which polygon of a ``field`` file holding several (0-based, in file order) is surveyed;
    -1 (the default) for a file that holds one."""
    field_cells: str = "best"
    """How a ``field`` is split into cells: ``convex``, ``monotone`` (the classic boustrophedon
    cells) or ``best`` (whichever flies shorter)."""
    trigger_radius: float = 2.0
    """ε, a stage switches when the aircraft is within this distance of its triggering point (or
    has passed it) [m], >= 0."""
    ground_alt: float = 0.0
    """Altitude of the ground at home, the launch point [m AMSL], for the missions a ``field``
    survey exports (Paparazzi's altitudes are AMSL; MAVLink's are above home). Set it to the
    field's elevation."""
    home: list[float] = dc.field(default_factory=list)
    """Home, the launch point of a ``field`` survey's missions, [λ, φ] [deg WGS84]; empty: the
    first line's start."""
    airspace_margin: float = -1.0
    """M, how far beyond a ``field`` the declared airspace reaches [m], the missions' inclusion
    geofence; < 0 (default): the smallest that works, derived from the turning radius, the line
    spacing and the wind (:mod:`eaplan_drake.field.airspace`). A smaller value is refused."""
    no_fly_holes: bool = False
    """The ``field``'s holes are no-fly zones (exclusion geofences) that the planned route and the
    simulated flight keep 10 m clear of, instead of areas that are not surveyed but may be
    overflown (default)."""
    mission_end: str = "rtl"
    """How a ``field`` survey's missions end: ``rtl`` (return to launch) or ``land`` (an approach
    and a landing at home)."""

    def Validate(self, key: str = "coverage") -> None:
        _check(len(self.polygon) >= 3, f"{key}.polygon", "needs at least 3 vertices")
        _check(
            len(self.polygon) <= MAX_POLYGON_VERTICES,
            f"{key}.polygon",
            f"at most {MAX_POLYGON_VERTICES} vertices, got {len(self.polygon)}",
        )
        for i, v in enumerate(self.polygon):
            _vector(v, f"{key}.polygon[{i}]", 2)
        _in_range(self.line_edge, f"{key}.line_edge", 0, len(self.polygon) - 1)
        _positive(self.swath_spacing, f"{key}.swath_spacing")
        _positive(self.turning_radius, f"{key}.turning_radius")
        _positive(self.min_turning_radius, f"{key}.min_turning_radius")
        _check(
            self.min_turning_radius <= self.turning_radius,
            f"{key}.min_turning_radius",
            f"r_min = {self.min_turning_radius:g} must be <= turning_radius r = "
            f"{self.turning_radius:g}",
        )
        _nonnegative(self.trigger_radius, f"{key}.trigger_radius")
        _check(
            not (self.field and self.plan_file),
            f"{key}.field",
            "give a field or a plan_file, not both",
        )
        _check(
            _is_int(self.field_polygon) and -1 <= self.field_polygon <= 10_000,
            f"{key}.field_polygon",
            f"must be an integer in [-1, 10000] (-1: the file's only polygon), got "
            f"{self.field_polygon!r}",
        )
        _check(
            self.field_cells in ("best", "convex", "monotone"),
            f"{key}.field_cells",
            f"must be one of best, convex, monotone, got {self.field_cells!r}",
        )
        _in_range(self.ground_alt, f"{key}.ground_alt", -9000.0, 9000.0)
        _check(
            isinstance(self.airspace_margin, (int, float)) and -1e9 < self.airspace_margin < 1e5,
            f"{key}.airspace_margin",
            f"must be < 100000 m (< 0: derived), got {self.airspace_margin!r}",
        )
        if self.home:
            lon, lat = _vector(self.home, f"{key}.home", 2)
            _in_range(lon, f"{key}.home[0]", -180.0, 180.0)
            _in_range(lat, f"{key}.home[1]", -90.0, 90.0)
        _check(
            self.mission_end in ("rtl", "land"),
            f"{key}.mission_end",
            f"must be one of rtl, land, got {self.mission_end!r}",
        )


@dc.dataclass
class GuidanceParams(_Params):
    """Guiding vector field gains (paper 001 Eq. 8) for unit-gradient path functions.

    Tuned at 15 m/s airspeed in 5 m/s wind (tests/test_guidance.py): from 100 m off a line or a
    70 m circle the distance falls below 0.5 m within ≈ 25 s without overshoot; k_e = 0.1 starts
    to overshoot (≈ 1.4 m), k_e = 0.02 takes ≈ 35 s. k_d barely matters in [0.5, 2] rad/s.
    """

    k_e: float = 0.05
    """Convergence gain of the field on φ [1/m] (φ normalised so that ‖∇φ‖ = 1 on the path);
    plan generators put it into each path descriptor, the guidance uses the descriptor's. Once the
    course is aligned, φ decays at the rate ≈ k_e · ground speed."""
    k_d: float = 1.0
    """Course-alignment gain [rad/s]: the course error δ obeys δ̇ = −k_d sin δ."""

    def Validate(self, key: str = "guidance") -> None:
        _positive(self.k_e, f"{key}.k_e")
        _at_most(self.k_e, f"{key}.k_e", MAX_GUIDANCE_GAIN, "1/m", "numerics")
        _positive(self.k_d, f"{key}.k_d")
