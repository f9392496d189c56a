"""Randomised worlds: a base scenario with wind, battery faults and sensor drawn from a seed.

A *world* is everything a policy does not choose: the wind, the battery faults, the sensor's
noise, dropouts and seed. :func:`DrawWorld` draws one reproducibly from an integer seed (numpy's
``default_rng``), so the same seed gives the same world on any machine and in any process; the
policies are then flown on identical worlds (:func:`WithPolicy`).
"""

import copy
import dataclasses as dc

import numpy as np

from eaplan_drake.flight.coverage import PlanSource
from eaplan_drake.flight.stages import StageTime
from eaplan_drake.params import BatteryFault, Scenario
from eaplan_drake.planning.planner import PlannerObservation

__all__ = [
    "BruteForceAgreement",
    "DrawWorld",
    "LowestPlan",
    "RandomPlannerObservation",
    "WithPolicy",
    "WorldDistribution",
]


@dc.dataclass(frozen=True)
class WorldDistribution:
    """Ranges the worlds are drawn from (each uniform unless said otherwise)."""

    max_wind_speed: float = 12.0
    """‖w‖ in [0, max] [m/s]; the direction uniform in [0, 360) deg."""
    max_faults: int = 3
    """Number of SoC drops, an integer in [0, max]."""
    max_soc_drop: float = 0.15
    """Size of each drop in (0, max] [-]."""
    fault_window: tuple[float, float] = (0.0, 500.0)
    """Time of each drop [s]."""
    noise_std: tuple[float, float] = (0.1, 3.0)
    """Sensor noise standard deviation [W]."""
    max_dropout_probability: float = 0.3
    """Probability that a sensor sample is lost, in [0, max]."""


def DrawWorld(base: Scenario, seed: int, distribution: WorldDistribution | None = None) -> Scenario:
    """A copy of ``base`` with the world drawn from ``seed`` (an integer >= 0); its name is
    ``<base name>_w<seed>``. The policy and its parameters are the base's; the estimator's
    measurement variance R is set to the drawn sensor noise (the sensor's data sheet)."""
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise ValueError(f"seed: must be an integer >= 0, got {seed!r}")
    d = WorldDistribution() if distribution is None else distribution
    rng = np.random.default_rng(int(seed))
    s = copy.deepcopy(base)
    s.name = f"{base.name}_w{int(seed)}"
    s.wind.speed = float(rng.uniform(0.0, d.max_wind_speed))
    s.wind.direction_deg = float(rng.uniform(0.0, 360.0))
    n = int(rng.integers(0, d.max_faults + 1))
    times = np.sort(rng.uniform(*d.fault_window, size=n))
    drops = rng.uniform(0.0, d.max_soc_drop, size=n)
    s.battery.faults = [
        BatteryFault(time=float(t), soc_drop=float(max(x, 1e-6)))
        for t, x in zip(times, drops, strict=True)
    ]
    s.sensor.noise_std = float(rng.uniform(*d.noise_std))
    s.sensor.dropout_probability = float(rng.uniform(0.0, d.max_dropout_probability))
    s.sensor.seed = int(rng.integers(0, 2**31 - 1))
    s.estimator.measurement_noise = s.sensor.noise_std**2
    return s.Validate()


def WithPolicy(world: Scenario, policy: str, **planner) -> Scenario:
    """A copy of ``world`` flown with ``policy`` (``planner.policy``); ``planner`` keywords set
    further :class:`~eaplan_drake.params.PlannerParams` fields (e.g. the static lowest plan:
    ``WithPolicy(w, "static", initial_path_parameters=[-1000.0])`` plus its c2)."""
    s = copy.deepcopy(world)
    s.planner.policy = policy
    for key, value in planner.items():
        if not hasattr(s.planner, key):
            raise ValueError(f"planner.{key}: unknown key")
        setattr(s.planner, key, value)
    return s.Validate()


def LowestPlan(world: Scenario) -> Scenario:
    """A copy of ``world`` flown with the static lowest-quality plan (c1 = c̲1, c2 = the table's
    lowest grid point): the reference of what can be finished on that world."""
    from eaplan_drake.energy.computation import LoadComputationTable

    table = LoadComputationTable(world.computation.table)
    s = WithPolicy(
        world, "static", initial_path_parameters=[float(world.planner.path_parameter_bounds[0])]
    )
    s.computation.initial_parameters = [float(v) for v in table.lower]
    return s.Validate()


def RandomPlannerObservation(
    rng: np.random.Generator,
    plan: PlanSource,
    path_parameter_grid,
    computation_values,
    *,
    order: int = 3,
    period: float = 46.0,
    airspeed: float = 15.0,
) -> PlannerObservation:
    """A planner observation as in flight (for tests and benchmarks of the planner): ``plan`` at
    a random c1 of the grid, a random stage and point on it, a random wind (0–12 m/s, any
    direction) and the exact remaining times at the grid [s]; a random energy state (mean
    26–40 W, harmonics σ = 1.5 W), Var(α̂0) 1e-5–1e-1 W², SoC 0.32–1 and a random current c2 out
    of ``computation_values``."""
    grid = np.asarray(path_parameter_grid, dtype=float)
    c1 = float(rng.choice(grid))
    stages = plan.Stages(c1)
    stage = stages[int(rng.integers(0, len(stages)))]
    speed, direction = rng.uniform(0.0, 12.0), rng.uniform(0.0, 2.0 * np.pi)
    wind = speed * np.array([np.cos(direction), np.sin(direction)])
    left = rng.uniform(0.0, 1.0) * StageTime(stage, airspeed, wind)
    t_rem = np.array(
        [left + plan.TimeAfter(stage.index, stage.anchor, c, airspeed, wind) for c in grid]
    )
    q = np.concatenate(([rng.uniform(26.0, 40.0)], rng.normal(0.0, 1.5, 2 * order)))
    return PlannerObservation(
        time=100.0,
        energy_coefficients=q,
        mean_power_variance=float(10 ** rng.uniform(-5, -1)),
        soc=float(rng.uniform(0.32, 1.0)),
        period=period,
        coverage_remaining=0.5,
        remaining_time=t_rem,
        path_parameter=c1,
        computation_parameters=np.array([float(rng.choice(computation_values))]),
    )


def BruteForceAgreement(
    policy, plan: PlanSource, path_parameter_grid, computation_values, rng, states: int
) -> tuple[int, int]:
    """(agreeing, total) over ``states`` random feasible planner states
    (:func:`RandomPlannerObservation`): how often an mpc-like ``policy``'s first move (its
    decision, carrying its memory from state to state as in flight) equals the exact discrete
    optimum of the step it plans on (``policy.Step(o, memory).BruteForce()``); states whose
    lowest plan is infeasible are skipped. Only the warm start is carried: the states are
    unrelated, so the rest of the memory (the risk reserve's drop count and anchor) starts
    afresh for each."""
    initial = policy.InitialMemory()
    warm = policy.program.variables.size
    memory = initial
    agree = total = 0
    while total < states:
        o = RandomPlannerObservation(rng, plan, path_parameter_grid, computation_values)
        step = policy.Step(o, memory)
        if not step.Lowest().feasible:
            continue
        d = policy.Plan(o, memory)
        expected = step.BruteForce()
        memory = np.concatenate((d.memory[:warm], initial[warm:]))
        total += 1
        agree += d.path_parameter == expected.path_parameter and np.array_equal(
            d.computation_parameters, expected.computation_parameters
        )
    return agree, total
