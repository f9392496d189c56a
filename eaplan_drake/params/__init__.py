"""All parameters of one flight, as one typed dataclass tree loaded from YAML.

Every quantity is SI (m, s, W, V, Ω, Ah for capacity as in the papers, rad internally); angles in
the YAML are degrees only where the key's name ends in ``_deg``. Defaults are the reference
numbers of the authors' simulator (:ref:`design-reference-scenario`, paper 003 Sec. V).

Load with :func:`~eaplan_drake.loading.LoadScenario` (``filename=`` or ``data=``). A misspelt
key, a wrong type or a value outside its physical range raises :class:`ScenarioError` whose
message names the key.

This package's face holds every public name of its modules: the tree by subtree
(:mod:`~eaplan_drake.params.flight`, :mod:`~eaplan_drake.params.energy`,
:mod:`~eaplan_drake.params.planner`, :mod:`~eaplan_drake.params.scenario`), the bounds on the
fields (:mod:`~eaplan_drake.params.bounds`), the rule of the loop's rates
(:mod:`~eaplan_drake.params.periods`); the checks the ``Validate`` methods are made of
(:mod:`~eaplan_drake.params.checks`) and the type walker (:mod:`~eaplan_drake.params.walk`).
"""

from eaplan_drake.errors import ScenarioError
from eaplan_drake.params.bounds import (
    MAX_COMPUTATION_PARAMETERS,
    MAX_COORDINATE,
    MAX_EXPECTED_DROPS,
    MAX_FAULTS,
    MAX_GUIDANCE_GAIN,
    MAX_HORIZON,
    MAX_LOG_PERIOD,
    MAX_LOG_SAMPLES,
    MAX_MAX_STEP,
    MAX_NAME_LENGTH,
    MAX_PLAN_STAGES,
    MAX_PLANNER_PERIOD,
    MAX_PLANNER_STEPS,
    MAX_POLYGON_VERTICES,
    MAX_RATE,
    MAX_STEPS,
    MAX_SURVEY_LINES,
    MAX_TIME_LIMIT,
    MAX_VARIANCE,
    MIN_LOG_PERIOD,
    MIN_MAX_STEP,
    MIN_PLANNER_PERIOD,
)
from eaplan_drake.params.checks import CheckType
from eaplan_drake.params.energy import (
    AUTHORS_K_B,
    NOMINAL_CELL_VOLTAGE,
    PHYSICAL_K_B,
    BatteryFault,
    BatteryParams,
    ComputationParams,
    EnergyModelParams,
    EstimatorParams,
    SensorParams,
)
from eaplan_drake.params.flight import (
    WIND_STAIRCASE_SOURCES,
    CoverageParams,
    GuidanceParams,
    GustParams,
    MotionPowerParams,
    VehicleParams,
    WindDriftParams,
    WindEstimatorParams,
    WindParams,
    WindVector,
)
from eaplan_drake.params.periods import RATE_TOLERANCE, IntegerMultiple, TicksPerPeriod
from eaplan_drake.params.planner import (
    C1_MAX_TOLERANCE,
    FAULT_SIZE_DISTRIBUTIONS,
    PACK_CAPACITY_SOURCES,
    POINT_MODEL_VALUES,
    RESERVE_RULES,
    FaultModelParams,
    PlannerParams,
)
from eaplan_drake.params.scenario import Scenario, SimulationParams

__all__ = [
    "AUTHORS_K_B",
    "BatteryFault",
    "BatteryParams",
    "C1_MAX_TOLERANCE",
    "CheckType",
    "ComputationParams",
    "CoverageParams",
    "EnergyModelParams",
    "EstimatorParams",
    "FAULT_SIZE_DISTRIBUTIONS",
    "FaultModelParams",
    "POINT_MODEL_VALUES",
    "GuidanceParams",
    "GustParams",
    "IntegerMultiple",
    "MAX_COMPUTATION_PARAMETERS",
    "MAX_COORDINATE",
    "MAX_EXPECTED_DROPS",
    "MAX_FAULTS",
    "MAX_GUIDANCE_GAIN",
    "MAX_HORIZON",
    "MAX_LOG_PERIOD",
    "MAX_LOG_SAMPLES",
    "MAX_MAX_STEP",
    "MAX_NAME_LENGTH",
    "MAX_PLANNER_PERIOD",
    "MAX_PLANNER_STEPS",
    "MAX_POLYGON_VERTICES",
    "MAX_RATE",
    "MAX_STEPS",
    "MAX_PLAN_STAGES",
    "MAX_SURVEY_LINES",
    "MAX_TIME_LIMIT",
    "MAX_VARIANCE",
    "MIN_LOG_PERIOD",
    "MIN_MAX_STEP",
    "MIN_PLANNER_PERIOD",
    "NOMINAL_CELL_VOLTAGE",
    "PHYSICAL_K_B",
    "MotionPowerParams",
    "PlannerParams",
    "RATE_TOLERANCE",
    "PACK_CAPACITY_SOURCES",
    "RESERVE_RULES",
    "Scenario",
    "ScenarioError",
    "SensorParams",
    "SimulationParams",
    "TicksPerPeriod",
    "VehicleParams",
    "WIND_STAIRCASE_SOURCES",
    "WindDriftParams",
    "WindEstimatorParams",
    "WindParams",
    "WindVector",
]
