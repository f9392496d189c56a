"""Bounds on the scenario fields that set an amount of work, and on the numerics.

Chosen so that the worst accepted scenario still ends: at most :data:`MAX_STEPS` integrator steps
or sensor/estimator events (the reference flight: 1.5e5), :data:`MAX_LOG_SAMPLES` log samples
(1.5e4).
"""

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
"""Largest number of coverage.polygon vertices [-]."""
MAX_COORDINATE = 1e7
"""Largest \\|x\\|, \\|y\\| of vehicle.initial_position [m] (the guidance overflows near 1e100)."""
MAX_GUIDANCE_GAIN = 1e3
"""Largest guidance.k_e [1/m] (the reference is 0.05; 1e300 overflows the guidance)."""
MAX_PLAN_STAGES = 10_000
"""Largest number of stages of a plan [-] (bounds the sequencer's and planner's work)."""
MAX_SURVEY_LINES = 2000
"""Largest width of the field across the lines / swath_spacing [-] (a 2000-line plan has ≈ 8000
stages and takes ≈ 1 s to build)."""
MAX_FAULTS = 100
"""Largest number of battery.faults [-]."""
MAX_EXPECTED_DROPS = 100.0
"""Largest λ·time_limit of a risk-reserve planner's fault model (bounds its tail sums)."""
MAX_COMPUTATION_PARAMETERS = 8
"""Largest number of computation parameters σ (computation.initial_parameters) [-]."""
MAX_NAME_LENGTH = 100
"""Largest length of a scenario's name [characters]."""
MAX_GUST_SIGMA = 10.0
"""Largest wind.gusts.sigma [m/s] (severe turbulence near the ground is ≈ 3–4 m/s)."""
MAX_GUST_LENGTH_SCALE = 10_000.0
"""Largest wind.gusts.length_scale [m]."""
MAX_DRIFT_SPEED = 10.0
"""Largest \\|wind.drift.speed_rate\\| [m/s per minute] and wind.drift.speed_sigma [m/s]."""
MAX_DRIFT_ANGLE_DEG = 180.0
"""Largest \\|wind.drift.direction_rate_deg\\| [deg per minute] and
wind.drift.direction_sigma_deg [deg]."""
MIN_WIND_TIME_CONSTANT = 0.01
"""Smallest wind.estimator.time_constant [s]."""
MAX_POWER_OFFSET = 100.0
"""Largest \\|computation.power_offset\\| [W]."""
MIN_BATTERY_HEALTH = 0.1
"""Smallest battery.health [-]."""
