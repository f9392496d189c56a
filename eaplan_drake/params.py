"""All parameters of one flight, as one typed dataclass tree loaded from YAML.

Every quantity is SI (m, s, W, V, Ω, Ah for capacity as in the papers, rad internally); angles in
the YAML are degrees only where the key's name ends in ``_deg``. Defaults are the reference
numbers of the authors' simulator (:ref:`design-reference-scenario`, paper 003 Sec. V).

Load with :func:`LoadScenario` (``filename=`` or ``data=``). A misspelt key, a wrong type or a
value outside its physical range raises :class:`ScenarioError` whose message names the key.
"""

import dataclasses as dc
import difflib
import functools
import math
import numbers
import re
import types
import typing

import numpy as np

from eaplan_drake.errors import ScenarioError
from eaplan_drake.registry import AIRCRAFT_MODELS, BATTERY_MODELS, POLICIES

__all__ = [
    "BatteryFault",
    "BatteryParams",
    "CheckType",
    "ComputationParams",
    "CoverageParams",
    "EnergyModelParams",
    "EstimatorParams",
    "FaultModelParams",
    "GuidanceParams",
    "MotionPowerParams",
    "PlannerParams",
    "Scenario",
    "ScenarioError",
    "SensorParams",
    "SimulationParams",
    "VehicleParams",
    "WindParams",
    "WindVector",
]


# -- bounds on the fields that set an amount of work --------------------------------------------
# Chosen so that the worst accepted scenario still ends: at most MAX_STEPS integrator steps or
# sensor/estimator events (the reference flight: 1.5e5), MAX_LOG_SAMPLES log samples (1.5e4).


def CheckType(value, kind, name: str, what: str) -> None:
    """Raises :class:`ScenarioError` ``name: expected what, got <type>`` unless ``value`` is a
    ``kind`` (the check of a Python argument that is not a scenario key)."""
    if not isinstance(value, kind):
        raise ScenarioError(f"{name}: expected {what}, got {type(value).__name__}")


MAX_RATE = 1000.0
"""Largest sensor and estimator rate [Hz]."""
MAX_TIME_LIMIT = 20_000.0
"""Largest simulation.time_limit [s]."""
MAX_STEPS = 2e6
"""Largest time_limit × max(sensor.rate, estimator.rate, 1 / max_step) [-]."""
MIN_LOG_PERIOD, MAX_LOG_PERIOD = 1e-3, 1000.0
"""Range of simulation.log_period [s]."""
MAX_LOG_SAMPLES = 2e5
"""Largest time_limit / log_period [-]."""
RATE_TOLERANCE = 1e-9
"""Relative tolerance of "an integer multiple" between the periods of the rates [-]."""


def IntegerMultiple(ratio: float) -> int:
    """n when ``ratio`` is an integer n >= 1 within :data:`RATE_TOLERANCE` (relative, at least
    absolute), else 0: the one test of "an integer multiple" between the rates' periods."""
    n = round(ratio)
    return n if n >= 1 and abs(ratio - n) <= RATE_TOLERANCE * max(ratio, 1.0) else 0


def TicksPerPeriod(period: float, time_step: float | None) -> int:
    """n when ``period`` [s] is an integer multiple n >= 2 of the loop's base tick ``time_step``
    [s] (relative tolerance :data:`RATE_TOLERANCE`), else 1. A system with n > 1 declares its
    event at the tick and acts every n-th tick: Drake's event times k·period and (k·n)·time_step
    differ in the last bit unless n is a power of two, and a sample taken one ulp late would see
    the other systems after their update."""
    if time_step is None or not period > 0.0 or not time_step > 0.0:
        return 1
    n = IntegerMultiple(float(period) / float(time_step))
    return n if n >= 2 else 1


MIN_MAX_STEP, MAX_MAX_STEP = 1e-4, 1.0
"""Range of simulation.max_step [s]."""
MIN_PLANNER_PERIOD, MAX_PLANNER_PERIOD = 0.1, 600.0
"""Range of planner.period [s]."""
MAX_PLANNER_STEPS = 1e5
"""Largest time_limit / planner.period [-]."""
MAX_HORIZON = 100
"""Largest planner.horizon [steps]."""
MAX_VARIANCE = 1e6
"""Largest estimator variance (initial_covariance, process_noise, measurement_noise) [W²]."""
MAX_POLYGON_VERTICES = 100
MAX_COORDINATE = 1e7
"""Largest |x|, |y| of vehicle.initial_position [m] (the guidance overflows near 1e100)."""
MAX_GUIDANCE_GAIN = 1e3
"""Largest guidance.k_e [1/m] (the reference is 0.05; 1e300 overflows the guidance)."""
MAX_SURVEY_LINES = 2000
"""Largest width of the field across the lines / swath_spacing [-] (a 2000-line plan has ≈ 8000
stages and takes ≈ 1 s to build)."""
MAX_FAULTS = 100
MAX_EXPECTED_DROPS = 100.0
"""Largest λ·time_limit of a risk-reserve planner's fault model (bounds its tail sums)."""
MAX_COMPUTATION_PARAMETERS = 8
MAX_NAME_LENGTH = 100
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")


# -- validation helpers -------------------------------------------------------------------------


def _check(cond: bool, key: str, message: str) -> None:
    if not cond:
        raise ScenarioError(f"{key}: {message}")


def _is_int(value) -> bool:
    """An integer (Python or numpy), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _finite(value, key: str) -> float:
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise ScenarioError(f"{key}: expected a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{key}: expected a number, got {value!r}") from None
    _check(math.isfinite(v), key, f"must be finite, got {value!r}")
    return v


def _positive(value, key: str) -> None:
    v = _finite(value, key)
    _check(v > 0.0, key, f"must be > 0, got {v:g}")


def _nonnegative(value, key: str) -> None:
    v = _finite(value, key)
    _check(v >= 0.0, key, f"must be >= 0, got {v:g}")


def _in_range(value, key: str, lo: float, hi: float) -> None:
    v = _finite(value, key)
    _check(lo <= v <= hi, key, f"must be in [{lo:g}, {hi:g}], got {v:g}")


def _vector(value, key: str, size: int | None = None) -> list[float]:
    values = [_finite(v, f"{key}[{i}]") for i, v in enumerate(value)]
    if size is not None:
        _check(len(values) == size, key, f"must have {size} entries, got {len(values)}")
    return values


def _at_most(value, key: str, hi: float, unit: str, why: str) -> None:
    """An upper bound on a field that sets an amount of work; ``why`` says what it bounds."""
    v = _finite(value, key)
    _check(v <= hi, key, f"must be <= {hi:g} {unit} ({why}), got {v:g}")


def _Shown(values) -> str:
    """Numbers as a user writes them: ``[0, -1000]``, not ``array([0., -1000.])``."""
    return "[" + ", ".join(f"{float(v):g}" for v in values) + "]"


# -- the fields of a params dataclass, and nothing else -----------------------------------------


class _Params:
    """Base of every params dataclass: setting an attribute that is not a field raises
    :class:`AttributeError` naming the key (``scenario.planner.enabled = False`` would otherwise
    be accepted and ignored). Construction, ``dc.replace``, ``copy.deepcopy``, pickling and
    pydrake's ``yaml_load_typed`` only ever set fields."""

    __slots__ = ()

    def __setattr__(self, name: str, value) -> None:
        if name not in _FieldNames(type(self)):
            raise AttributeError(_UnknownFieldMessage(type(self), name), name=name, obj=self)
        object.__setattr__(self, name, value)


@functools.cache
def _FieldNames(cls) -> frozenset[str]:
    return frozenset(f.name for f in dc.fields(cls))


@functools.cache
def _Hints(cls) -> dict:
    """The type hints of a dataclass's fields, by name (cached; do not modify)."""
    names = [f.name for f in dc.fields(cls)]
    hints = typing.get_type_hints(cls)
    return {name: hints[name] for name in names}


def _RemovedFieldNote(cls, name: str) -> str:
    """What replaced a removed key, or ""."""
    return _REMOVED_FIELDS.get((cls.__name__, name), "")


def _Suggestion(cls, name) -> str:
    """`` (did you mean 'x'?)`` for the nearest field of ``cls``, or ""."""
    close = difflib.get_close_matches(str(name), sorted(_FieldNames(cls)), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _UnknownFieldMessage(cls, name: str) -> str:
    """One line for setting the non-field ``name`` on a ``cls`` from Python."""
    prefix = _ClassKeys().get(cls)
    full = f"{cls.__name__}.{name}" if prefix is None else (f"{prefix}.{name}" if prefix else name)
    note, close = _RemovedFieldNote(cls, name), _Suggestion(cls, name)
    fields = "" if close or note else f" (fields: {', '.join(sorted(_FieldNames(cls)))})"
    return f"{full}: {cls.__name__} has no field {name!r}{close}{fields}" + (
        f"; {note}" if note else ""
    )


def _UnknownKeyMessage(cls, name, full: str) -> str:
    """One line for the unknown key ``full`` (last part ``name``) of a ``cls`` in YAML."""
    known = ", ".join(sorted(_FieldNames(cls)))
    note = _RemovedFieldNote(cls, name)
    close = _Suggestion(cls, name).strip(" ()")
    return (
        f"{full}: unknown key (known keys here: {known})"
        + (f"; {close}" if close else "")
        + (f"; {note}" if note else "")
    )


@functools.cache
def _ClassKeys() -> dict:
    """The key of each params class in the scenario tree (``PlannerParams`` → ``planner``,
    ``BatteryFault`` → ``battery.faults[i]``, ``Scenario`` → ""); a class found at two keys maps
    to None (its messages then name the class)."""
    keys: dict = {}

    def visit(hint, key: str) -> None:
        if dc.is_dataclass(hint):
            if hint in keys:
                keys[hint] = None if keys[hint] != key else key
                return
            keys[hint] = key
            for name, sub in _Hints(hint).items():
                visit(sub, f"{key}.{name}" if key else name)
        elif typing.get_origin(hint) is list:
            visit(typing.get_args(hint)[0], f"{key}[i]")
        for member in _Members(hint):
            visit(member, key)

    visit(Scenario, "")
    return keys


# -- the tree -----------------------------------------------------------------------------------


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
class WindParams(_Params):
    """Constant wind w = speed · [cos θ_w, sin θ_w]; θ_w is where the wind blows *towards*."""

    speed: float = 5.0
    """‖w‖ [m/s], must be below the airspeed."""
    direction_deg: float = 0.0
    """θ_w, from +x counter-clockwise [deg]; 0 blows towards +x, 90 towards +y."""

    def Validate(self, key: str = "wind") -> None:
        _nonnegative(self.speed, f"{key}.speed")
        _finite(self.direction_deg, f"{key}.direction_deg")

    def Vector(self) -> np.ndarray:
        """w [m/s] (:func:`WindVector`)."""
        return WindVector(self.speed, self.direction_deg)


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
    trigger_radius: float = 2.0
    """ε, a stage switches when the aircraft is within this distance of its triggering point (or
    has passed it) [m], >= 0."""

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


@dc.dataclass
class ComputationParams(_Params):
    """Computation power g(c2) from a measured powprofiler table (paper 003 Sec. III-B)."""

    table: str = "pednet_jetson_nano"
    """A packaged table name (``pednet_jetson_nano``, ``two_parameters``) or a CSV path."""
    initial_parameters: list[float] = dc.field(default_factory=lambda: [10.0])
    """c2(0), one entry per computation parameter (σ of them) [table units, e.g. fps]."""
    integer: bool = True
    """Parameters take only the table's grid values (fps); the planner maps relaxed values back."""

    def Validate(self, key: str = "computation") -> None:
        _check(bool(self.table), f"{key}.table", "must name a table")
        _check(len(self.initial_parameters) >= 1, f"{key}.initial_parameters", "needs >= 1 entry")
        _check(
            len(self.initial_parameters) <= MAX_COMPUTATION_PARAMETERS,
            f"{key}.initial_parameters",
            f"at most {MAX_COMPUTATION_PARAMETERS} entries, got {len(self.initial_parameters)}",
        )
        _vector(self.initial_parameters, f"{key}.initial_parameters")


@dc.dataclass
class EnergyModelParams(_Params):
    """Periodic energy model (paper 003 Eqs. 3–12), scaled form y = C q with q in W."""

    order: int = 3
    """r, Fourier order (state size m = 2r + 1), in [0, 20]."""
    initial_period: float = 46.0
    """T, first guess of the period [s] until one is measured in flight."""
    initial_coefficients: list[float] = dc.field(default_factory=list)
    """q(0) [W] (m entries) or empty: α0 = initial_mean_power, harmonics zero."""
    initial_mean_power: float = 30.0
    """α0(0) [W] used when initial_coefficients is empty."""

    def Validate(self, key: str = "energy_model") -> None:
        _check(
            _is_int(self.order) and 0 <= self.order <= 20,
            f"{key}.order",
            f"must be an integer in [0, 20], got {self.order!r}",
        )
        _positive(self.initial_period, f"{key}.initial_period")
        if self.initial_coefficients:
            _vector(self.initial_coefficients, f"{key}.initial_coefficients", 2 * self.order + 1)
        _nonnegative(self.initial_mean_power, f"{key}.initial_mean_power")


@dc.dataclass
class BatteryFault(_Params):
    """A sudden loss of state of charge at a given time."""

    time: float = 0.0
    """When [s]."""
    soc_drop: float = 0.0
    """How much SoC is lost [-], in (0, 1] (0.06 is −6 %)."""


@dc.dataclass
class BatteryParams(_Params):
    """Rint equivalent circuit (paper 003 Lemma III.3): ḃ = −k_b I(y) / Q_c."""

    voltage: float = 14.8
    """V, internal (open-circuit) voltage [V]."""
    internal_resistance: float = 0.0012
    """R_r [Ω]."""
    capacity: float = 3.2
    """Q_c, nominal capacity [Ah]."""
    k_b: float = 0.00183
    """Battery coefficient [-]; absorbs the Ah-to-seconds conversion of the reference numbers."""
    initial_soc: float = 1.0
    """b(0) [-], in (0, 1]."""
    reserve_soc: float = 0.30
    """Reserve: the flight fails if b reaches it before the survey ends [-], in [0, 1)."""
    faults: list[BatteryFault] = dc.field(default_factory=list)
    """Sudden SoC drops (plan i: −6 % at 93 s, −9 % at 270 s)."""
    model: str = "rint"
    """Battery model, one of :data:`~eaplan_drake.registry.BATTERY_MODELS` (``rint``: the Rint
    circuit above); the battery system and the planner's prediction both use it."""

    def Validate(self, key: str = "battery") -> None:
        BATTERY_MODELS.Check(self.model, f"{key}.model")
        _positive(self.voltage, f"{key}.voltage")
        _positive(self.internal_resistance, f"{key}.internal_resistance")
        _positive(self.capacity, f"{key}.capacity")
        _positive(self.k_b, f"{key}.k_b")
        _in_range(self.initial_soc, f"{key}.initial_soc", 1e-9, 1.0)
        _in_range(self.reserve_soc, f"{key}.reserve_soc", 0.0, 1.0 - 1e-9)
        _check(
            len(self.faults) <= MAX_FAULTS,
            f"{key}.faults",
            f"at most {MAX_FAULTS} faults, got {len(self.faults)}",
        )
        for i, f in enumerate(self.faults):
            _nonnegative(f.time, f"{key}.faults[{i}].time")
            _in_range(f.soc_drop, f"{key}.faults[{i}].soc_drop", 1e-12, 1.0)


@dc.dataclass
class SensorParams(_Params):
    """Power sensor Υ = P_motion + P_computation + noise, sampled periodically."""

    rate: float = 100.0
    """Sampling rate [Hz]."""
    noise_std: float = 0.5
    """Standard deviation of the additive Gaussian noise [W]."""
    dropout_probability: float = 0.0
    """Probability that a sample is lost (output NaN) [-], in [0, 1)."""
    seed: int = 0
    """Seed of the noise and dropout generator, an integer >= 0."""
    averaging: bool = False
    """False (default): each sample is the power at the sample time plus noise of σ =
    ``noise_std``. True: each sample is the mean of the n = native_rate / rate readings of its
    interval, the mean power over it plus noise of σ/√n, and the estimator's R becomes
    ``estimator.measurement_noise`` / n (:mod:`eaplan_drake.energy.sensor`): a sensor reporting
    below
    its native rate, or a simulation on a coarser ``simulation.max_step``, then loses no
    information. Needs rate <= 1 / max_step and estimator.rate <= rate."""
    native_rate: float = 100.0
    """f_r, rate of the readings whose noise is σ = ``noise_std`` [Hz] (the paper's 100 Hz);
    used with ``averaging`` (an integer multiple of ``rate``)."""

    def Validate(self, key: str = "sensor") -> None:
        _positive(self.rate, f"{key}.rate")
        _at_most(self.rate, f"{key}.rate", MAX_RATE, "Hz", "bounds the events per second")
        _nonnegative(self.noise_std, f"{key}.noise_std")
        _positive(self.native_rate, f"{key}.native_rate")
        _at_most(self.native_rate, f"{key}.native_rate", MAX_RATE, "Hz", "bounds the readings")
        _in_range(self.dropout_probability, f"{key}.dropout_probability", 0.0, 1.0 - 1e-9)
        _check(
            _is_int(self.seed) and self.seed >= 0,
            f"{key}.seed",
            f"must be an integer >= 0, got {self.seed!r}",
        )


@dc.dataclass
class EstimatorParams(_Params):
    """Discrete Kalman filter on q (paper 003 Alg. 2 l. 28–29), Joseph-form update."""

    rate: float = 100.0
    """Update rate [Hz] (the sensor's)."""
    initial_covariance: float = 100.0
    """P(0) = p0 · I [W²]."""
    process_noise: float = 1e-6
    """Q = q · I per step [W²]. 1e-6 at 100 Hz keeps \\|ŷ − y\\| < 0.3 W on a σ = 0.5 W sensor
    (1e-4 lets ŷ wander by ≈ ±0.3 W) and still follows an unannounced 1 W step of the mean
    to 1/e in ≈ 1.2 s."""
    measurement_noise: float = 0.25
    """R, variance of the power sensor [W²] (σ = 0.5 W → 0.25)."""
    mean_process_noise: float = 0.0
    """Extra random-walk variance per step on the mean power α0 [W²]: Q_00 = process_noise +
    mean_process_noise (a slowly drifting level, e.g. battery sag or wind change)."""
    aperiodic_time_constant: float = 0.0
    """τ of the aperiodic (AR(1), first-order Gauss–Markov) load state d [s]; 0 = no such state
    (the paper's model, the default), ``.inf`` = random walk. Opt-in: see
    :mod:`eaplan_drake.energy.fourier`; the planner's prediction uses the same model."""
    aperiodic_noise: float = 0.0
    """q_d, intensity of the aperiodic load's driving noise [W²/s] (stationary variance
    q_d τ / 2); used only when aperiodic_time_constant > 0."""

    def Validate(self, key: str = "estimator") -> None:
        _positive(self.rate, f"{key}.rate")
        _at_most(self.rate, f"{key}.rate", MAX_RATE, "Hz", "bounds the events per second")
        _positive(self.initial_covariance, f"{key}.initial_covariance")
        _at_most(
            self.initial_covariance, f"{key}.initial_covariance", MAX_VARIANCE, "W²", "numerics"
        )
        _nonnegative(self.process_noise, f"{key}.process_noise")
        _at_most(self.process_noise, f"{key}.process_noise", MAX_VARIANCE, "W²", "numerics")
        _positive(self.measurement_noise, f"{key}.measurement_noise")
        _at_most(self.measurement_noise, f"{key}.measurement_noise", MAX_VARIANCE, "W²", "numerics")
        tau = self.aperiodic_time_constant
        _check(
            isinstance(tau, (int, float)) and not isinstance(tau, bool) and tau >= 0.0,
            f"{key}.aperiodic_time_constant",
            f"must be >= 0 [s] (0: none, .inf: random walk), got {tau!r}",
        )
        _nonnegative(self.aperiodic_noise, f"{key}.aperiodic_noise")
        _at_most(self.aperiodic_noise, f"{key}.aperiodic_noise", MAX_VARIANCE, "W²/s", "numerics")
        _nonnegative(self.mean_process_noise, f"{key}.mean_process_noise")
        _at_most(
            self.mean_process_noise, f"{key}.mean_process_noise", MAX_VARIANCE, "W²/s", "numerics"
        )

    def ModelOrder(self, order: int):
        """The ``order`` argument of :mod:`eaplan_drake.energy.fourier` for Fourier order r: r
        itself (paper model) or ``AugmentedOrder(r, τ)`` when the aperiodic state is on."""
        if self.aperiodic_time_constant > 0.0:
            from eaplan_drake.energy.fourier import AugmentedOrder

            return AugmentedOrder(int(order), float(self.aperiodic_time_constant))
        return int(order)


@dc.dataclass
class FaultModelParams(_Params):
    """What the planner believes about battery faults (``planner.fault_model``), beside the
    scripted ``battery.faults`` (what happens in a flight): SoC drops arrive as a Poisson process
    of rate λ = ``rate`` [1/s], with i.i.d. sizes [-] from ``sizes``. The default covers the
    benchmark's random worlds (0–3 drops of up to 15 % in the first 500 s: 1.5 drops per 500 s,
    sizes uniform in [0, 0.15]). See :mod:`eaplan_drake.planning.risk`, and the docs' policies
    page for how to estimate λ and the sizes from a fleet's records."""

    rate: float = 0.003
    """λ, drops per second of flight [1/s], in [0, 0.1]."""
    sizes: str = "uniform"
    """Size distribution: ``uniform`` (in ``size_bounds``), ``exponential`` (mean ``size_mean``)
    or ``empirical`` (equally likely ``size_values``)."""
    size_bounds: list[float] = dc.field(default_factory=lambda: [0.0, 0.15])
    """[a, b] of uniform sizes [-], 0 <= a < b <= 1."""
    size_mean: float = 0.05
    """Mean of exponential sizes [-], in [1e-6, 1) (sizes above 1 empty the battery)."""
    size_values: list[float] = dc.field(default_factory=list)
    """The recorded sizes of an empirical distribution [-], each in (0, 1], at most 1000."""

    def Validate(self, key: str = "planner.fault_model") -> None:
        _in_range(self.rate, f"{key}.rate", 0.0, 0.1)
        _check(
            self.sizes in FAULT_SIZE_DISTRIBUTIONS,
            f"{key}.sizes",
            f"must be one of {', '.join(FAULT_SIZE_DISTRIBUTIONS)}, got {self.sizes!r}",
        )
        _vector(self.size_bounds, f"{key}.size_bounds", 2)
        a, b = self.size_bounds
        _check(
            0.0 <= a < b <= 1.0,
            f"{key}.size_bounds",
            f"need 0 <= a < b <= 1 [-], got [{a:g}, {b:g}]",
        )
        mean = _finite(self.size_mean, f"{key}.size_mean")
        _check(
            1e-6 <= mean < 1.0,
            f"{key}.size_mean",
            f"must be in [1e-06, 1) [-] (the mean of exponential sizes), got {mean:g}",
        )
        _check(
            len(self.size_values) <= 1000,
            f"{key}.size_values",
            f"at most 1000 values, got {len(self.size_values)}",
        )
        for i, v in enumerate(self.size_values):
            _in_range(v, f"{key}.size_values[{i}]", 1e-9, 1.0)
        _check(
            self.sizes != "empirical" or len(self.size_values) > 0,
            f"{key}.size_values",
            "an empirical size distribution needs at least one value",
        )


def _CheckPathParameterBounds(bounds, key: str, c1_min: float | None = None) -> None:
    """[lo, hi] finite with c1_min = r_min² − r² <= lo < hi <= 0 [m²] (``c1_min`` when the
    coverage is known), so that the planner's grid of c1 values is ascending."""
    lo, hi = _vector(bounds, key, 2)
    at = "" if c1_min is None else f" = {c1_min:g}"
    _check(
        lo < hi and hi <= C1_MAX_TOLERANCE and (c1_min is None or lo >= c1_min - 1e-6),
        key,
        f"need c1_min = r_min² − r²{at} <= lo < hi <= 0 [m²] (r2 = sqrt(r² + c1) may not "
        f"exceed r), got {_Shown(bounds)}",
    )


C1_MAX_TOLERANCE = 1e-9
"""Largest accepted upper bound of planner.path_parameter_bounds [m²] (0 up to rounding)."""

FAULT_SIZE_DISTRIBUTIONS = ("uniform", "exponential", "empirical")
"""Values of ``planner.fault_model.sizes``."""

RESERVE_RULES = ("risk", "fixed")
"""Values of ``planner.reserve``."""


@dc.dataclass
class PlannerParams(_Params):
    """Planner-scheduler: which policy decides c1 and c2, and its parameters.

    ``policy`` selects (see :mod:`eaplan_drake.planning.policies`): ``mpc`` (default: the
    mission-feasible
    MPC of :mod:`eaplan_drake.planning.mpc`), ``paper`` (paper 003 Eq. 16 + Alg. 2 as published, the
    reproduction), ``greedy`` (one-step rule fed the MPC's signals), ``greedy_authors`` (the
    authors' MATLAB rule), ``static`` (hold the initial parameters) and ``hindsight`` (the best
    constant pair of a grid, each flown on the same world).
    """

    policy: str = "mpc"
    """Planner policy, one of mpc, paper, greedy, greedy_authors, static, hindsight."""
    period: float = 1.0
    """h_T, re-planning step [s]."""
    horizon: int = 6
    """N, horizon in steps of h_T [-] (paper and greedy_authors policies)."""
    warmup: float = 40.0
    """Time before the planner acts [s]: about one period of energy data, before which the
    estimated mean power α̂0 is unreliable (measured on the default flight: off by 20–75 W at
    5–20 s, 6 W at 30 s, < 0.5 W from 40 s on). The paper waits ≈ two periods (80 s, pinned in
    the reference scenarios)."""
    warmup_parameters: str = "lowest"
    """What an acting policy flies before ``warmup``: "lowest" (c̲1 and the table's lowest c2:
    spend nothing before the energy estimate can be trusted; in tight worlds the warm-up at full
    quality already spent the margin) or "initial" (``initial_path_parameters`` and
    ``computation.initial_parameters``, as the paper does; pinned in the reference scenarios).
    A static policy always flies the initial parameters."""
    path_parameter_bounds: list[float] = dc.field(default_factory=lambda: [-1000.0, 0.0])
    """[c1_min, c1_max] [m²], r_min² − r² <= c1_min < c1_max <= 0."""
    initial_path_parameters: list[float] = dc.field(default_factory=lambda: [0.0])
    """c1(0) [m²]."""
    path_parameter_grid_size: int = 21
    """M, number of equally spaced c1 values over the bounds at which the sequencer reports the
    exact remaining survey time; the c1 the mpc and greedy policies may choose [-], in [2, 201]."""
    path_parameter_step: float = 500.0
    """δ1, largest change of c1 per re-planning step [m²] (rate limit of the paper, greedy and
    greedy_authors policies)."""
    path_parameter_deadband: float = 250.0
    """Hysteresis on c1 [m²]: a rise smaller than this is not taken (cuts always are; paper
    policy)."""
    computation_parameter_step: float = 2.0
    """δ2, grid step of integer computation parameters [table units]."""
    path_weight: float = 1.0
    """Weight of the normalised path parameter c̃1 in the objective [-]."""
    computation_weight: float = 1.0
    """Weight of the normalised computation parameters c̃2 in the objective [-]."""
    slack_weight: float = 1e4
    """Exact (L1) penalty on the output-constraint slack: cost slack_weight·Σ s_k [1/W] (paper
    policy)."""
    power_model: str = "quadratic"
    """Smooth g(c) inside the NLPs: "quadratic" (least-squares fit to the table) or "linear"
    (Eq. 11 scaling factors). Grid mapping and predictions always use the exact table."""
    margin_floor: float = 0.02
    """Smallest SoC margin above ``battery.reserve_soc`` the mpc policy plans to end with [-]."""
    margin_sigmas: float = 3.0
    """The mpc margin also grows by this many standard deviations of the predicted end SoC,
    from the estimator's variance of the mean power α0 [-]."""
    reserve: str = "fixed"
    """How the mpc policy holds SoC back for faults: ``fixed`` (``fault_reserve`` over
    ``fault_reserve_time``) or ``risk`` (the margin each plan needs so that its excess risk under
    ``fault_model`` is at most ``risk``; :mod:`eaplan_drake.planning.risk`)."""
    after_drop: str = "replan"
    """With ``reserve: risk``, what the mpc does once it sees a SoC drop (its SoC more than 0.01
    below the one-step prediction): ``replan`` (keep deciding with the risk constraint) or
    ``lowest`` (fly the lowest plan to the end: the fallback its excess risk assumes)."""
    risk: float = 0.05
    """ε, the largest excess risk of a decision with ``reserve: risk`` [-], in (0, 1): the
    probability, under ``fault_model``, that the mission fails although the lowest plan flown from
    the same state would have completed."""
    fault_model: FaultModelParams = dc.field(default_factory=FaultModelParams)
    """The planner's belief about faults (used with ``reserve: risk`` and by ``certify``)."""
    fault_reserve: float = 0.10
    """SoC the mpc policy holds back for battery faults it cannot foresee, on top of the margin
    [-], in [0, 1). 0.10 covers one fault of the reference plan i's size (−6 %, −9 %); measured on
    40 random worlds (0–3 drops of 0–15 %, benchmarks/bench_policies.py --first-seed 1000), the
    mpc completed 23 of the 33 missions the lowest plan completes with 0, and 31 with 0.10 and
    with 0.15 (the two lost to two late drops); each 0.05 costs quality where nothing fails."""
    fault_reserve_time: float = 300.0
    """τ_f [s]: the fault reserve held for a plan with t seconds of survey left is
    ``fault_reserve`` · min(1, t/τ_f): faults come at a rate, so the exposure, and the reserve,
    shrink as the survey nears its end (the reserve is then spent on quality). 0 holds the whole
    reserve to the end. A margin that does not grow as time passes keeps the mpc recursively
    feasible. Measured on worlds 0–22 of benchmarks/bench_policies.py (21 that the lowest plan
    completes): 300 s completed the same 19 as 0 s, at a mission quality of 0.478 instead of
    0.354."""
    solver: str = "ipopt"
    """NLP solver of the paper and mpc programs: "ipopt" or "snopt" (both bundled with Drake)."""
    max_iterations: int = 100
    """Iteration limit per solve [-] (IPOPT iterations, SNOPT major iterations): the only bound
    of a solve in simulation."""
    max_wall_time: float = 0.0
    """Opt-in real-time budget: solver wall-time limit per solve [s]; 0 (every shipped scenario)
    disables it, so that a flight depends on its scenario only, never on the machine's speed."""
    hindsight_path_parameters: int = 5
    """Number of equally spaced c1 values of the hindsight grid (× every table value of c2)."""

    def Validate(self, key: str = "planner") -> None:
        POLICIES.Check(self.policy, f"{key}.policy")
        _in_range(self.period, f"{key}.period", MIN_PLANNER_PERIOD, MAX_PLANNER_PERIOD)
        _check(
            _is_int(self.horizon) and 1 <= self.horizon <= MAX_HORIZON,
            f"{key}.horizon",
            f"must be an integer in [1, {MAX_HORIZON}] (bounds each solve), got {self.horizon!r}",
        )
        _nonnegative(self.warmup, f"{key}.warmup")
        _check(
            self.warmup_parameters in ("lowest", "initial"),
            f"{key}.warmup_parameters",
            f'must be "lowest" or "initial", got {self.warmup_parameters!r}',
        )
        _CheckPathParameterBounds(self.path_parameter_bounds, f"{key}.path_parameter_bounds")
        _vector(self.initial_path_parameters, f"{key}.initial_path_parameters", 1)
        lo, hi = self.path_parameter_bounds
        for i, c in enumerate(self.initial_path_parameters):
            _in_range(c, f"{key}.initial_path_parameters[{i}]", lo, hi)
        _check(
            isinstance(self.path_parameter_grid_size, int)
            and 2 <= self.path_parameter_grid_size <= 201,
            f"{key}.path_parameter_grid_size",
            f"must be an integer in [2, 201], got {self.path_parameter_grid_size!r}",
        )
        _positive(self.path_parameter_step, f"{key}.path_parameter_step")
        _nonnegative(self.path_parameter_deadband, f"{key}.path_parameter_deadband")
        _positive(self.computation_parameter_step, f"{key}.computation_parameter_step")
        _nonnegative(self.path_weight, f"{key}.path_weight")
        _nonnegative(self.computation_weight, f"{key}.computation_weight")
        _check(
            self.path_weight + self.computation_weight > 0.0,
            f"{key}.path_weight",
            "path_weight + computation_weight must be > 0",
        )
        _positive(self.slack_weight, f"{key}.slack_weight")
        _check(
            self.power_model in ("quadratic", "linear"),
            f"{key}.power_model",
            f'must be "quadratic" or "linear", got {self.power_model!r}',
        )
        _in_range(self.margin_floor, f"{key}.margin_floor", 0.0, 1.0 - 1e-9)
        _in_range(self.margin_sigmas, f"{key}.margin_sigmas", 0.0, 100.0)
        _in_range(self.fault_reserve, f"{key}.fault_reserve", 0.0, 1.0 - 1e-9)
        _in_range(self.fault_reserve_time, f"{key}.fault_reserve_time", 0.0, 1e5)
        _check(
            self.reserve in RESERVE_RULES,
            f"{key}.reserve",
            f"must be one of {', '.join(RESERVE_RULES)}, got {self.reserve!r}",
        )
        _check(
            self.after_drop in ("replan", "lowest"),
            f"{key}.after_drop",
            f'must be "replan" or "lowest", got {self.after_drop!r}',
        )
        _in_range(self.risk, f"{key}.risk", 1e-6, 1.0 - 1e-6)
        self.fault_model.Validate(f"{key}.fault_model")
        _check(
            self.solver in ("ipopt", "snopt"),
            f"{key}.solver",
            f'must be "ipopt" or "snopt", got {self.solver!r}',
        )
        _check(
            isinstance(self.max_iterations, int) and 1 <= self.max_iterations <= 10_000,
            f"{key}.max_iterations",
            f"must be an integer in [1, 10000], got {self.max_iterations!r}",
        )
        _nonnegative(self.max_wall_time, f"{key}.max_wall_time")
        _check(
            isinstance(self.hindsight_path_parameters, int)
            and 2 <= self.hindsight_path_parameters <= 101,
            f"{key}.hindsight_path_parameters",
            f"must be an integer in [2, 101], got {self.hindsight_path_parameters!r}",
        )

    @property
    def is_static(self) -> bool:
        """The planner holds its initial parameters (``static`` and ``hindsight``, whose flights
        are static)."""
        return self.policy in ("static", "hindsight")

    def PathParameterGrid(self):
        """The M equally spaced c1 values over the bounds [m²] (numpy array)."""
        lo, hi = (float(v) for v in self.path_parameter_bounds)
        return np.linspace(lo, hi, int(self.path_parameter_grid_size))


_REMOVED_FIELDS = {
    ("PlannerParams", "enabled"): (
        "'enabled' was removed: the planner's switch is 'policy' (policy 'static' holds the "
        "initial parameters, as enabled false did)"
    ),
}
"""Keys that were removed, by (class name, key): what replaced them."""


@dc.dataclass
class SimulationParams(_Params):
    """How long and how finely to simulate."""

    time_limit: float = 1500.0
    """Stop after this much simulated time [s] if nothing else ended the flight."""
    log_period: float = 0.1
    """Sampling period of the flight log [s]."""
    integrator: str = "runge_kutta2"
    """Drake integrator scheme of the aircraft's continuous state (``ResetIntegratorFromFlags``
    names: runge_kutta2, runge_kutta3, runge_kutta5, explicit_euler, ...)."""
    max_step: float = 0.01
    """Integrator (maximum) step [s]; the 100 Hz sensor events cap the step at 0.01 s anyway.
    With ``plant: exact_arc`` it is the plant's fixed update period h [s] instead."""
    plant: str = "exact_arc"
    """Aircraft model, one of :data:`~eaplan_drake.registry.AIRCRAFT_MODELS`: ``exact_arc`` (the
    default), the unicycle stepped exactly every ``max_step`` with the turn rate held over the
    step, as a 100 Hz autopilot holds its command (plant and guidance run once per step;
    ``integrator`` is then unused), or
    ``continuous``, the unicycle integrated by ``integrator`` with the guidance re-evaluated inside
    the step (the loop of releases before 0.2, bit for bit). The two differ by the hold of the
    command, first order in the step: ≤ 0.2 m of track and ≤ 2e-5 of final SoC at 0.01 s on the
    reference flights."""

    def Validate(self, key: str = "simulation") -> None:
        _positive(self.time_limit, f"{key}.time_limit")
        _at_most(self.time_limit, f"{key}.time_limit", MAX_TIME_LIMIT, "s", "bounds a flight")
        _in_range(self.log_period, f"{key}.log_period", MIN_LOG_PERIOD, MAX_LOG_PERIOD)
        _check(
            self.time_limit / self.log_period <= MAX_LOG_SAMPLES,
            f"{key}.log_period",
            f"time_limit / log_period must be <= {MAX_LOG_SAMPLES:g} log samples, got "
            f"{self.time_limit / self.log_period:g}",
        )
        from pydrake.systems.analysis import GetIntegrationSchemes

        schemes = GetIntegrationSchemes()
        _check(
            self.integrator in schemes,
            f"{key}.integrator",
            f"must be one of {', '.join(schemes)}, got {self.integrator!r}",
        )
        _in_range(self.max_step, f"{key}.max_step", MIN_MAX_STEP, MAX_MAX_STEP)
        AIRCRAFT_MODELS.Check(self.plant, f"{key}.plant")


@dc.dataclass
class Scenario(_Params):
    """One flight: every parameter of the closed loop."""

    name: str = "reference"
    description: str = ""
    random_seed: int = -1
    """Seed every random stream of the flight derives from (today: the sensor's noise and
    dropouts), so that a Monte Carlo study varies one key; −1 (default) keeps ``sensor.seed`` as
    given. With a seed s ≥ 0 the sensor uses :meth:`SensorSeed` = a hash of (s, "sensor")."""
    vehicle: VehicleParams = dc.field(default_factory=VehicleParams)
    wind: WindParams = dc.field(default_factory=WindParams)
    coverage: CoverageParams = dc.field(default_factory=CoverageParams)
    guidance: GuidanceParams = dc.field(default_factory=GuidanceParams)
    computation: ComputationParams = dc.field(default_factory=ComputationParams)
    energy_model: EnergyModelParams = dc.field(default_factory=EnergyModelParams)
    battery: BatteryParams = dc.field(default_factory=BatteryParams)
    sensor: SensorParams = dc.field(default_factory=SensorParams)
    estimator: EstimatorParams = dc.field(default_factory=EstimatorParams)
    planner: PlannerParams = dc.field(default_factory=PlannerParams)
    simulation: SimulationParams = dc.field(default_factory=SimulationParams)

    def SensorSeed(self) -> int:
        """The seed the power sensor uses: ``sensor.seed``, or derived from ``random_seed``."""
        if self.random_seed < 0:
            return int(self.sensor.seed)
        return int(np.random.SeedSequence([int(self.random_seed), 1]).generate_state(1)[0])

    def Validate(self) -> "Scenario":
        """Checks every field; raises ScenarioError naming the first bad key. Returns self.

        Types first (a params dataclass where one belongs, lists, booleans that are ``bool``,
        numbers that are numbers; numpy integers become ``int``), then ranges, then the
        cross-field constraints that need no file (those that do: :func:`ResolveScenario
        <eaplan_drake.resolve.ResolveScenario>`)."""
        _Walk(Scenario, self, "", raw=False)
        _check(
            isinstance(self.name, str) and bool(_NAME.fullmatch(self.name)),
            "name",
            "must be a plain file name (letters, digits, _ . + -, not starting with . + -), "
            f"got {self.name!r}",
        )
        _check(
            len(self.name) <= MAX_NAME_LENGTH,
            "name",
            f"at most {MAX_NAME_LENGTH} characters, got {len(self.name)}",
        )
        _check(
            self.random_seed >= -1,
            "random_seed",
            f"must be an integer >= -1, got {self.random_seed!r}",
        )
        for f in dc.fields(self):
            value = getattr(self, f.name)
            if hasattr(value, "Validate"):
                value.Validate(f.name)
        _check(
            self.battery.reserve_soc < self.battery.initial_soc,
            "battery.reserve_soc",
            f"must be below battery.initial_soc = {self.battery.initial_soc:g} (the flight would "
            f"end at once), got {self.battery.reserve_soc:g}",
        )
        sim = self.simulation
        fastest = max(self.sensor.rate, self.estimator.rate, 1.0 / sim.max_step)
        _check(
            sim.time_limit * fastest <= MAX_STEPS,
            "simulation.time_limit",
            f"time_limit × max(sensor.rate, estimator.rate, 1 / max_step) must be <= "
            f"{MAX_STEPS:g} steps, got {sim.time_limit:g} s × {fastest:g} Hz",
        )
        _CheckRates(self)
        expected = self.planner.fault_model.rate * sim.time_limit
        _check(
            self.planner.reserve != "risk" or expected <= MAX_EXPECTED_DROPS,
            "planner.fault_model.rate",
            f"with planner.reserve: risk, rate × simulation.time_limit (the drops expected in a "
            f"flight) must be <= {MAX_EXPECTED_DROPS:g}, got {self.planner.fault_model.rate:g} "
            f"1/s × {sim.time_limit:g} s",
        )
        _check(
            sim.time_limit / self.planner.period <= MAX_PLANNER_STEPS,
            "planner.period",
            f"simulation.time_limit / planner.period must be <= {MAX_PLANNER_STEPS:g} planner "
            f"steps, got {sim.time_limit / self.planner.period:g}",
        )
        _check(
            self.wind.speed < self.vehicle.airspeed,
            "wind.speed",
            f"must be below vehicle.airspeed = {self.vehicle.airspeed:g} m/s, "
            f"got {self.wind.speed:g}",
        )
        c1_min = self.coverage.min_turning_radius**2 - self.coverage.turning_radius**2
        _CheckPathParameterBounds(
            self.planner.path_parameter_bounds, "planner.path_parameter_bounds", c1_min
        )
        return self


def _CheckRates(scenario: Scenario) -> None:
    """Every rate an integer multiple of one base, so that event times coincide: the periods
    simulation.max_step, 1/sensor.rate and 1/estimator.rate [s] are each an integer multiple of
    the smallest of them (relative tolerance :data:`RATE_TOLERANCE`). With sensor.averaging the
    base is max_step (a sample averages whole base steps), native_rate is an integer multiple of
    the sensor's rate and the estimator is no faster than the sensor (each averaged sample is
    used once, with R/n)."""
    h = scenario.simulation.max_step
    periods = {
        "simulation.max_step": (h, f"{h:g} s"),
        "sensor.rate": (1.0 / scenario.sensor.rate, f"{scenario.sensor.rate:g} Hz"),
        "estimator.rate": (1.0 / scenario.estimator.rate, f"{scenario.estimator.rate:g} Hz"),
    }
    base_key = min(periods, key=lambda k: periods[k][0])
    base = periods[base_key][0]
    for key, (period, shown) in periods.items():
        ratio = period / base
        _check(
            IntegerMultiple(ratio) >= 1,
            key,
            f"its period must be an integer multiple of the base period {base:g} s "
            f"({base_key}; every rate an integer multiple of one base, so that event times "
            f"coincide), got {shown} (period {period:g} s = {ratio:g} base periods)",
        )
    if scenario.sensor.averaging:
        _check(
            IntegerMultiple(scenario.sensor.native_rate / scenario.sensor.rate) >= 1,
            "sensor.native_rate",
            f"with sensor.averaging must be an integer multiple of sensor.rate = "
            f"{scenario.sensor.rate:g} Hz, got {scenario.sensor.native_rate:g}",
        )
        _check(
            scenario.sensor.rate <= (1.0 + RATE_TOLERANCE) / h,
            "sensor.rate",
            f"with sensor.averaging must be <= 1 / simulation.max_step = {1.0 / h:g} Hz (a sample "
            f"averages whole base steps), got {scenario.sensor.rate:g}",
        )
        _check(
            scenario.estimator.rate <= scenario.sensor.rate * (1.0 + RATE_TOLERANCE),
            "estimator.rate",
            f"with sensor.averaging must be <= sensor.rate = {scenario.sensor.rate:g} Hz (each "
            f"averaged sample is used once, with R/n), got {scenario.estimator.rate:g}",
        )


# -- the one type walker: YAML data and params objects against the type hints ------------------


def _Members(hint) -> tuple:
    """The members of a Union hint (``X | None``, ``typing.Optional[X]``, ``A | B``), else ()."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return typing.get_args(hint)
    return ()


def _Dataclasses(hint) -> list:
    """The dataclasses a value of ``hint`` may be: [hint], its dataclass members, or []."""
    if dc.is_dataclass(hint):
        return [hint]
    return [m for m in _Members(hint) if dc.is_dataclass(m)]


def _Walk(hint, value, key: str, *, raw: bool, current=None):
    """Checks ``value`` against the type hint ``hint``; raises :class:`ScenarioError` naming
    ``key`` on a mismatch. Returns the value to keep (the same object when nothing changes).

    ``raw=False`` walks a params object (:meth:`Scenario.Validate`): a params dataclass where one
    belongs, numpy integers in integer fields become ``int``, tuples and arrays in list fields
    lists. ``raw=True`` walks YAML data (:mod:`eaplan_drake.loading`) and builds the value: a
    mapping where a dataclass belongs, merged key by key into ``current`` (the value it layers
    over) or a new default instance; an unknown key is named in full; lists replace; integers in
    float fields become floats (as pydrake's ``yaml_load_typed``). Both support ``X | None`` and
    a Union of dataclasses (raw: the first whose fields hold every key given)."""
    if _Members(hint):
        return _WalkUnion(hint, value, key, raw=raw, current=current)
    if dc.is_dataclass(hint):
        if raw:
            if not isinstance(value, dict):
                raise ScenarioError(f"{key}: expected a mapping of keys, got {_Short(value)}")
            target = current if isinstance(current, hint) else hint()
            hints = _Hints(hint)
            for name, v in value.items():
                full = f"{key}.{name}" if key else str(name)
                if name not in hints:
                    raise ScenarioError(_UnknownKeyMessage(hint, name, full))
                sub = getattr(target, name)
                setattr(target, name, _Walk(hints[name], v, full, raw=True, current=sub))
            return target
        if not isinstance(value, hint):
            what = "the scenario" if not key else key
            raise ScenarioError(
                f"{what}: expected a {hint.__name__}, got {type(value).__name__} {_Short(value)}"
            )
        for name, sub_hint in _Hints(hint).items():
            v = getattr(value, name)
            fixed = _Walk(sub_hint, v, f"{key}.{name}" if key else name, raw=False)
            if fixed is not v:
                setattr(value, name, fixed)
        return value
    if typing.get_origin(hint) is list:
        if not raw and isinstance(value, tuple | np.ndarray):
            value = list(np.asarray(value).tolist() if isinstance(value, np.ndarray) else value)
        if not isinstance(value, list):
            raise ScenarioError(f"{key}: expected a list, got {_Short(value)}")
        (item,) = typing.get_args(hint)
        fixed = [_Walk(item, v, f"{key}[{i}]", raw=raw) for i, v in enumerate(value)]
        if raw:
            return fixed  # a new list: a list in a layer replaces the one below
        return value if all(a is b for a, b in zip(fixed, value, strict=True)) else fixed
    if hint in _SCALARS:
        _check(
            _Fits(hint, value, raw), key, f"expected {_Expected(hint, raw)}, got {_Short(value)}"
        )
        if hint is int and type(value) is not int:
            return int(value)
        if hint is float and raw and type(value) is int:
            return float(value)
    return value


_SCALARS = (bool, int, float, str)


def _Fits(hint, value, raw: bool) -> bool:
    """Whether ``value`` is of the kind ``hint`` names (without looking inside)."""
    if hint is type(None):
        return value is None
    if dc.is_dataclass(hint):
        return isinstance(value, dict) if raw else isinstance(value, hint)
    if typing.get_origin(hint) is list:
        return isinstance(value, list) or (not raw and isinstance(value, tuple | np.ndarray))
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool) if raw else _is_int(value)
    if hint is float:
        return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    if hint is str:
        return isinstance(value, str)
    return isinstance(value, typing.get_origin(hint) or hint)


def _Expected(hint, raw: bool) -> str:
    """What a value of ``hint`` is, for a message."""
    if hint is type(None):
        return "null" if raw else "None"
    if dc.is_dataclass(hint):
        return "a mapping of keys" if raw else f"a {hint.__name__}"
    if typing.get_origin(hint) is list:
        return "a list"
    names = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}
    return names.get(hint, f"a {getattr(hint, '__name__', hint)}")


def _WalkUnion(hint, value, key: str, *, raw: bool, current=None):
    """:func:`_Walk` for a Union: the member of the value's exact type, else the first it fits
    (raw mappings: the first dataclass whose fields hold every key, preferring the type of
    ``current``)."""
    members = _Members(hint)
    if value is None and type(None) in members:
        return None
    fitting = [m for m in members if _Fits(m, value, raw)]
    if raw and isinstance(value, dict):
        classes = [m for m in fitting if dc.is_dataclass(m)]
        classes.sort(key=lambda m: not isinstance(current, m))  # stable: current's type first
        holding = [m for m in classes if set(value) <= _FieldNames(m)]
        fitting = holding or classes[:1]  # none holds every key: the first names the unknown one
    exact = [m for m in fitting if m in _SCALARS and type(value) is m]
    if not (exact or fitting):
        expected = " or ".join(dict.fromkeys(_Expected(m, raw) for m in members))
        raise ScenarioError(f"{key}: expected {expected}, got {_Short(value)}")
    member = (exact or fitting)[0]
    sub = current if dc.is_dataclass(member) and isinstance(current, member) else None
    return _Walk(member, value, key, raw=raw, current=sub)


def _Short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
