"""One resolution step between a scenario's YAML and its diagram: load the files, check every
cross-field constraint, hand the systems checked values.

:func:`ResolveScenario` loads the computation table and the plan (a ``.pln`` file or the generated
Zamboni-like coverage), then checks what no single field can:

- ``computation.initial_parameters``: one per table parameter, each inside the table's range;
- the plan: at most :data:`~eaplan_drake.params.bounds.MAX_PLAN_STAGES` stages; every
  triggering point p_Γ on (within ``max(ε, 1 m)`` of) its own path, ε =
  ``coverage.trigger_radius``;
- ε small against the plan: at most a quarter of the shortest distance between consecutive
  triggering points (a larger ε switches stages before the aircraft gets there);
- every circle flyable at the bank limit: in still air R ≥ v_a / ψ̇_max, and in the scenario's
  wind the peak heading rate the ground circle needs (:func:`PeakCircleHeadingRate`) at most
  :data:`WIND_TURN_TOLERANCE` × ψ̇_max.

Every violation is a :class:`~eaplan_drake.params.ScenarioError` naming the key, and
``file:line:col`` for tables and plan files. Distances in m, rates in rad/s.
"""

import copy
import dataclasses as dc
from pathlib import Path

import numpy as np

from eaplan_drake.energy.computation import ComputationTable, LoadComputationTable
from eaplan_drake.energy.fourier import ModelOrder
from eaplan_drake.errors import MissingExtraError, ScenarioError
from eaplan_drake.flight.coverage import CheckCoverageGeometry, PlanSource
from eaplan_drake.flight.paths import PathFunction
from eaplan_drake.flight.planfile import PlanFile
from eaplan_drake.flight.plant import MaxHeadingRate
from eaplan_drake.loading import ResolveFilePaths
from eaplan_drake.params import MAX_EXPECTED_DROPS, MAX_PLAN_STAGES, MAX_SURVEY_LINES, Scenario
from eaplan_drake.registry import PLAN_SOURCES

__all__ = [
    "Derive",
    "MakePlanSource",
    "PlanSourceName",
    "PeakCircleHeadingRate",
    "ResolveScenario",
    "ResolvedScenario",
    "StartParameters",
    "TriggerDistance",
    "WIND_TURN_TOLERANCE",
]


WIND_TURN_TOLERANCE = 1.25
"""How far above ψ̇_max the peak heading rate of a circle in wind may be [-]. At the downwind
point the aircraft then flies wide for a moment and the guidance brings it back; the shipped
robustness study (wind ≤ 10 m/s on the 62.45 m circle at 15 m/s, 45°) needs up to 1.02×, the
policy benchmark's 12 m/s worlds 1.19×."""

MIN_TRIGGER_OFFSET = 1.0
"""A triggering point may always be this far from its path [m] (rounding in plan files)."""


@dc.dataclass(frozen=True)
class ResolvedScenario:
    """A validated scenario with its loaded computation table and plan source, and the values
    the systems derive from it, computed once (the compile step of a flight)."""

    scenario: Scenario
    table: ComputationTable
    plan: PlanSource
    start: tuple[float, list[float]] = (0.0, [])
    """(c1 [m²], c2) flown until the planner first acts (:func:`StartParameters`)."""
    model_order: object = 0
    """The estimator's model order: r, or an ``AugmentedOrder`` with the aperiodic state."""
    path_parameter_grid: np.ndarray = dc.field(default_factory=lambda: np.zeros(0))
    """The M values of c1 [m²] of the sequencer's ``remaining_time`` and the mpc's grid."""
    wind: np.ndarray = dc.field(default_factory=lambda: np.zeros(2))
    """The constant wind w [m/s] (east, north)."""
    coverage_time_bounds: tuple[float, float] = (0.0, 0.0)
    """(t(c̲1), t(c̄1)) [s] of the plan in the wind: the Eq. 10 line of the paper's policies."""
    initial_coefficients: np.ndarray = dc.field(default_factory=lambda: np.zeros(0))
    """q(0) [W] of the estimator (m = 2r + 1 entries): ``energy_model.initial_coefficients``, or
    α0 = ``energy_model.initial_mean_power`` and zero harmonics."""
    sensor_seed: int = 0
    """The power sensor's seed (:meth:`~eaplan_drake.params.Scenario.SensorSeed`)."""


def TriggerDistance(path: PathFunction, point) -> float:
    """Distance [m] from ``point`` to the line or circle of the normalised ``path``:
    \\|φ(p)\\| for a line (φ is the signed distance), | ‖p − o‖ − R | for a circle."""
    p = np.asarray(point, dtype=float).reshape(2)
    if path.is_circle:
        return float(abs(np.linalg.norm(p - path.center) - path.radius))
    return float(abs(path.value(p)))


def PeakCircleHeadingRate(radius: float, airspeed: float, wind_speed: float) -> float:
    """The largest heading rate ψ̇ [rad/s] needed to fly a ground circle of ``radius`` R [m] at
    ``airspeed`` v_a [m/s] in a constant wind of ``wind_speed`` w < v_a [m/s].

    With β the angle between the wind and the course, the ground speed is
    V_g = w cos β + sqrt(v_a² − w² sin² β), and ψ̇ = V_g² / (R sqrt(v_a² − w² sin² β)) (the
    course turns at V_g / R, the heading at that rate divided by cos(χ − ψ)); the maximum over
    β (at β = 0, downwind, for w < v_a: (v_a + w)² / (R v_a)) is evaluated on a 1° grid.
    """
    r, va, w = float(radius), float(airspeed), float(wind_speed)
    if not (r > 0.0 and va > 0.0 and 0.0 <= w < va):
        raise ValueError(
            f"PeakCircleHeadingRate: need R > 0, v_a > 0, 0 <= w < v_a, got {r, va, w}"
        )
    beta = np.deg2rad(np.arange(0.0, 360.0, 1.0))
    root = np.sqrt(va**2 - (w * np.sin(beta)) ** 2)
    vg = w * np.cos(beta) + root
    return float(np.max(vg**2 / (r * root)))


def ResolveScenario(scenario: Scenario, base_dir: str | Path | None = None) -> ResolvedScenario:
    """Validates ``scenario``, loads its table and plan and checks the cross-field constraints
    (module docstring); relative file paths are taken against ``base_dir`` if given (the
    scenario file's folder; :func:`~eaplan_drake.loading.LoadScenario` does this already).
    Raises :class:`ScenarioError` with one line naming the key."""
    if not isinstance(scenario, Scenario):
        raise ScenarioError(
            f"ResolveScenario: expected a Scenario (e.g. LoadNamedScenario('plan_i')), got "
            f"{type(scenario).__name__}"
        )
    scenario.Validate()
    if base_dir is not None:
        scenario = ResolveFilePaths(copy.deepcopy(scenario), base_dir)
    table = _Table(scenario)
    plan = _Plan(scenario, table)
    _CheckPlan(scenario, plan)
    resolved = Derive(scenario, table, plan)
    _CheckExposure(resolved)
    return resolved


def _CheckExposure(resolved: ResolvedScenario) -> None:
    """With the risk reserve, the survey at the lowest plan must be one the fault model's risk
    tables can price: λ t(c̲1) at most ``MAX_EXPECTED_DROPS`` expected drops. Known before
    take-off from the fault rate, the airspeed and the survey's size, so refused here naming
    them, not found by the planner in flight."""
    s = resolved.scenario
    if s.planner.reserve != "risk" or s.planner.policy not in ("mpc", "static_takeoff"):
        return
    rate = float(s.planner.fault_model.rate)
    t_low = float(min(resolved.coverage_time_bounds))
    if rate * t_low > MAX_EXPECTED_DROPS:
        raise ScenarioError(
            f"planner.fault_model.rate: {rate:g}/s × {t_low:.0f} s of survey at the lowest plan "
            f"(vehicle.airspeed = {s.vehicle.airspeed:g} m/s, the survey's size) = "
            f"{rate * t_low:.1f} expected drops; the risk reserve prices at most "
            f"{MAX_EXPECTED_DROPS:g} (a faster aircraft, a smaller survey or a lower rate)"
        )


def Derive(scenario: Scenario, table: ComputationTable, plan: PlanSource) -> ResolvedScenario:
    """The :class:`ResolvedScenario` of a checked scenario, table and plan (its derived values
    computed once); ``plan`` may be any plan source (a caller's own)."""
    wind = scenario.wind.Vector()
    planner = scenario.planner
    return ResolvedScenario(
        scenario=scenario,
        table=table,
        plan=plan,
        start=StartParameters(scenario, table),
        model_order=ModelOrder(
            scenario.energy_model.order, scenario.estimator.aperiodic_time_constant
        ),
        path_parameter_grid=planner.PathParameterGrid(),
        wind=wind,
        coverage_time_bounds=tuple(
            plan.CoverageTimeBounds(planner.path_parameter_bounds, scenario.vehicle.airspeed, wind)
        ),
        initial_coefficients=_InitialCoefficients(scenario.energy_model),
        sensor_seed=scenario.SensorSeed(),
    )


def _InitialCoefficients(energy_model) -> np.ndarray:
    """q(0) [W]: the configured coefficients, or α0 = initial mean power and zero harmonics."""
    if energy_model.initial_coefficients:
        return np.asarray(energy_model.initial_coefficients, dtype=float)
    q0 = np.zeros(2 * energy_model.order + 1)
    q0[0] = energy_model.initial_mean_power
    return q0


def _Table(scenario: Scenario) -> ComputationTable:
    key = "computation.table"
    try:
        table = LoadComputationTable(scenario.computation.table)
    except (ValueError, OSError) as e:
        raise ScenarioError(f"{key}: {_OneLine(e)}") from None
    c = scenario.computation.initial_parameters
    if len(c) != table.num_parameters:
        raise ScenarioError(
            f"computation.initial_parameters: the table {table.source} has "
            f"{table.num_parameters} parameter(s), got {len(c)} value(s)"
        )
    for i, (v, lo, hi) in enumerate(zip(c, table.lower, table.upper, strict=True)):
        if not lo <= v <= hi:
            raise ScenarioError(
                f"computation.initial_parameters[{i}]: must be in the table's range "
                f"[{lo:g}, {hi:g}], got {v:g}"
            )
    return table


def StartParameters(scenario: Scenario, table) -> tuple[float, list[float]]:
    """(c1 [m²], c2 [table units]) flown from t = 0 until the planner first acts: the lowest plan
    (c̲1, the table's lowest c2) when ``planner.warmup_parameters`` is "lowest" and the policy
    acts, else the initial parameters (``planner.initial_path_parameters``,
    ``computation.initial_parameters``)."""
    p = scenario.planner
    if p.warmup_parameters == "lowest" and not p.is_static:
        return float(p.path_parameter_bounds[0]), [float(v) for v in table.lower]
    return float(p.initial_path_parameters[0]), list(scenario.computation.initial_parameters)


def _Plan(scenario: Scenario, table: ComputationTable) -> PlanSource:
    c1_0, _ = StartParameters(scenario, table)
    key = _PlanKey(scenario.coverage)
    if PlanSourceName(scenario.coverage) == "zamboni":
        _CheckZamboniGeometry(scenario.coverage)
    try:
        return MakePlanSource(scenario, initial_c1=c1_0)
    except (ValueError, OSError, RecursionError, RuntimeError, MissingExtraError) as e:
        raise ScenarioError(f"{key}: {_OneLine(e)}") from None


def PlanSourceName(coverage) -> str:
    """The :data:`~eaplan_drake.registry.PLAN_SOURCES` name of a scenario's plan: ``plan_file``
    when ``coverage.plan_file`` is set, ``field`` when ``coverage.field`` is, else ``zamboni``."""
    if coverage.plan_file:
        return "plan_file"
    return "field" if coverage.field else "zamboni"


def _PlanKey(coverage) -> str:
    """The scenario key that names the plan in messages."""
    return {"plan_file": "coverage.plan_file", "field": "coverage.field"}.get(
        PlanSourceName(coverage), "coverage"
    )


def MakePlanSource(scenario: Scenario, *, initial_c1: float) -> PlanSource:
    """The plan source of ``scenario`` (:data:`~eaplan_drake.registry.PLAN_SOURCES`,
    :func:`PlanSourceName`), starting with ``initial_c1`` [m²] (:func:`StartParameters`).
    Raises ValueError (or OSError for a file)."""
    return PLAN_SOURCES.Make(PlanSourceName(scenario.coverage), scenario, initial_c1)


def _CheckZamboniGeometry(coverage, key: str = "coverage") -> None:
    """The generated plan's field: convex, not degenerate, the line edge valid, large enough for
    one repetition and at most :data:`~eaplan_drake.params.MAX_SURVEY_LINES` lines across (bounds
    the plan's size). A ``.pln`` plan is checked by its own reader instead."""
    try:
        width = CheckCoverageGeometry(coverage, key).width
    except (ValueError, RuntimeError, OverflowError) as e:
        raise ScenarioError(str(e).splitlines()[0] if str(e) else f"{key}: {e!r}") from None
    if width / coverage.swath_spacing > MAX_SURVEY_LINES:
        raise ScenarioError(
            f"{key}.polygon: the field is {width:g} m across the lines, more than "
            f"{MAX_SURVEY_LINES} lines of swath_spacing = {coverage.swath_spacing:g} m (bounds the "
            f"plan's size)"
        )


def _CheckPlan(scenario: Scenario, plan: PlanSource) -> None:
    is_file = isinstance(plan, PlanFile)
    key = _PlanKey(scenario.coverage)
    lo, hi = (float(v) for v in scenario.planner.path_parameter_bounds)
    eps = float(scenario.coverage.trigger_radius)
    v_a = float(scenario.vehicle.airspeed)
    w = float(scenario.wind.speed)
    rate_max = MaxHeadingRate(scenario.vehicle)
    shortest = np.inf
    for c1 in sorted({lo, hi, float(scenario.planner.initial_path_parameters[0])}):
        try:
            stages = plan.Stages(c1)
        except (ValueError, RuntimeError) as e:
            raise ScenarioError(f"{key}: at c1 = {c1:g} m²: {_OneLine(e)}") from None
        if len(stages) > MAX_PLAN_STAGES:
            raise ScenarioError(
                f"{key}: the plan has {len(stages)} stages at c1 = {c1:g} m², at most "
                f"{MAX_PLAN_STAGES} allowed"
            )
        for i, stage in enumerate(stages):
            where = _StageWhere(plan, i, key)
            if is_file:
                off = TriggerDistance(stage.path, stage.trigger)
                allowed = max(eps, MIN_TRIGGER_OFFSET)
                if not off <= allowed:
                    raise ScenarioError(
                        f"{where}: triggering point ({stage.trigger[0]:g}, {stage.trigger[1]:g}) "
                        f"is {off:g} m off its path at c1 = {c1:g} m² (at most "
                        f"max(trigger_radius, {MIN_TRIGGER_OFFSET:g} m) = {allowed:g} m)"
                    )
            if stage.is_circle:
                _CheckCircle(where, stage.path.radius, v_a, w, rate_max)
        for a, b in zip(stages[:-1], stages[1:], strict=True):
            shortest = min(shortest, float(np.hypot(*np.subtract(a.trigger, b.trigger))))
    if np.isfinite(shortest) and not eps <= 0.25 * shortest:
        raise ScenarioError(
            f"coverage.trigger_radius: must be <= {0.25 * shortest:g} m (a quarter of the shortest "
            f"distance between consecutive triggering points of the plan), got {eps:g}"
        )


def _CheckCircle(where: str, radius: float, v_a: float, w: float, rate_max: float) -> None:
    if v_a / radius > rate_max:
        raise ScenarioError(
            f"{where}: a circle of radius {radius:g} m is not flyable at the bank limit even in "
            f"still air (needs R >= v_a / ψ̇_max = {v_a / rate_max:g} m)"
        )
    peak = PeakCircleHeadingRate(radius, v_a, w)
    if peak > WIND_TURN_TOLERANCE * rate_max:
        raise ScenarioError(
            f"{where}: a circle of radius {radius:g} m in {w:g} m/s wind needs a heading rate of "
            f"{peak:.3g} rad/s, more than {WIND_TURN_TOLERANCE:g} × the bank limit's "
            f"{rate_max:.3g} rad/s (vehicle.max_bank_angle_deg, wind.speed)"
        )


def _StageWhere(plan: PlanSource, i: int, key: str) -> str:
    if isinstance(plan, PlanFile) and i < len(plan.specs):
        spec = plan.specs[i]
        return f"{key}: {plan.source}:{spec.trigger_line}:1"
    return f"{key}.min_turning_radius: stage {i}"


def _OneLine(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return text or type(e).__name__
