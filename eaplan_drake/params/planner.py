"""The planner-scheduler's parameters, and its belief about battery faults."""

import copy
import dataclasses as dc

import numpy as np

from eaplan_drake.params.bounds import MAX_HORIZON, MAX_PLANNER_PERIOD, MIN_PLANNER_PERIOD
from eaplan_drake.params.checks import (
    _check,
    _finite,
    _in_range,
    _is_int,
    _nonnegative,
    _positive,
    _Shown,
    _vector,
)
from eaplan_drake.params.walk import _Params
from eaplan_drake.registry import POLICIES

POINT_MODEL_VALUES = {
    "prior_drops": 0.0,
    "recorded_drops": 0,
    "recorded_hours": 0.0,
    "prior_size_scale": 1.0,
    "prior_sizes": 0.0,
}
"""The keys of ``planner.fault_model`` that say how the planner's belief learns (not what a world
draws), at their values for a point model (:meth:`FaultModelParams.PointModel`)."""


@dc.dataclass
class FaultModelParams(_Params):
    """What the planner believes about battery faults (``planner.fault_model``), beside the
    scripted ``battery.faults`` (what happens in a flight): SoC drops arrive as a Poisson process
    of rate λ = ``rate`` [1/s], with i.i.d. sizes [-] from ``sizes``. The default covers the
    benchmark's random worlds (0–3 drops of up to 15 % in the first 500 s: 1.5 drops per 500 s,
    sizes uniform in [0, 0.15]). By default the planner doubts it and learns in flight: the rate
    is a belief worth half a drop (``prior_drops``), the sizes before the first drop are believed
    up to ``prior_size_scale`` times the stated ones, and each detected drop's size is learnt
    (``prior_sizes``); what the worlds of a study draw is the stated model. See
    :mod:`eaplan_drake.planning.risk`, :mod:`eaplan_drake.planning.belief`, and the docs' policies
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
    prior_drops: float = 0.5
    """α_0 [-]: with ``planner.reserve: risk``, how many drops the stated ``rate`` is worth: the
    planner then holds the belief λ ~ Gamma(α_0, α_0/``rate``), updated by the records below and
    in flight by every drop it detects and every second flown without one
    (:class:`~eaplan_drake.planning.belief.RateBelief`), in [0, 1e6]; 0: a point rate (with
    records, Jeffreys' 1/2). The default 1/2 is Jeffreys' shape."""
    recorded_drops: int = 0
    """k: the drops a fleet recorded in ``recorded_hours``, in [0, 1e6]."""
    recorded_hours: float = 0.0
    """T: the flight time of the fleet's records [h], in [0, 1e6]; 0: no records."""
    prior_size_scale: float = 2.6667
    """s [-]: with ``planner.reserve: risk``, the planner's sizes before it has seen a drop are the
    stated ones times s (a prior that doubts the label: U[a, b] becomes U[s a, s b], capped at 1),
    in [1, 100]; what the worlds draw stays the stated sizes. 1: the stated sizes."""
    prior_sizes: float = 1.0
    """K [-]: with ``planner.reserve: risk``, how many observed sizes the declared size model is
    worth when the planner learns from the drops it detects in flight (a Dirichlet-process
    predictive, :class:`~eaplan_drake.planning.learnt_sizes.DirichletDrops`), in [0, 1000];
    0: the sizes do not learn. Ignored by the worlds' own faults (``world_fault_model``)."""

    def PointModel(self) -> "FaultModelParams":
        """A copy that holds the stated point model: the same ``rate`` and sizes, none of the
        learning (:data:`POINT_MODEL_VALUES`: no prior drops, no records, the sizes as stated and
        not learnt). What a world's faults are drawn from, and the planner of earlier versions."""
        point = copy.deepcopy(self)
        for key, value in POINT_MODEL_VALUES.items():
            setattr(point, key, value)
        return point

    def HoldsBelief(self) -> bool:
        """Whether the planner holds a belief over the rate (``prior_drops`` or records) rather
        than the point ``rate``."""
        return self.rate > 0.0 and (self.prior_drops > 0.0 or self.recorded_hours > 0.0)

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
        _in_range(self.prior_sizes, f"{key}.prior_sizes", 0.0, 1000.0)
        _in_range(self.prior_drops, f"{key}.prior_drops", 0.0, 1e6)
        _in_range(self.prior_size_scale, f"{key}.prior_size_scale", 1.0, 100.0)
        _in_range(self.recorded_drops, f"{key}.recorded_drops", 0.0, 1e6)
        _check(
            float(self.recorded_drops) == int(self.recorded_drops),
            f"{key}.recorded_drops",
            f"must be a whole number of drops, got {self.recorded_drops:g}",
        )
        _in_range(self.recorded_hours, f"{key}.recorded_hours", 0.0, 1e6)
        _check(
            self.rate > 0.0 or self.recorded_hours == 0.0,
            f"{key}.rate",
            "must be > 0 [1/s] (the prior's mean) with a fleet's records (recorded_hours > 0), "
            "got 0",
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

PACK_CAPACITY_SOURCES = ("nominal", "estimated")
"""Values of ``planner.capacity``: the pack's usable capacity the mpc plans with."""


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
    """Planner policy, one of mpc, paper, greedy, greedy_authors, static, hindsight,
    static_takeoff, mdp."""
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
    reserve: str = "risk"
    """How the mpc policy holds SoC back for faults: ``risk`` (the default: the margin each plan
    needs so that its excess risk under ``fault_model`` is at most ``risk``;
    :mod:`eaplan_drake.planning.risk`) or ``fixed`` (``fault_reserve`` over
    ``fault_reserve_time``, which guarantees completion against drops that fit the reserve but
    states no failure rate)."""
    after_drop: str = "replan"
    """With ``reserve: risk``, what the mpc does once it sees a SoC drop (its SoC more than 0.01
    below the one-step prediction): ``replan`` (keep deciding with the risk constraint) or
    ``lowest`` (fly the lowest plan to the end: the fallback its excess risk assumes)."""
    first_budget: str = "half"
    """With ``reserve: risk``, the excess risk the mpc may spend before its first detected drop:
    ``half`` (ε/2, the default: with ε/2^(k+1) after k drops the budgets sum to ε on every path)
    or ``reach`` ((ε/2)(1 + e^(−λτ/2)), λ the rate believed before the flight and τ the longest
    plan's remaining time at the first step: the later budgets weighed by the chance of reaching
    them, :func:`~eaplan_drake.planning.risk_margin.FirstDropBudget`; between ε/2 and ε)."""
    capacity: str = "nominal"
    """The pack's usable capacity the mpc plans with: ``nominal`` (its label, the default) or
    ``estimated`` (learnt in flight from the SoC it reads against the fall it predicted,
    :mod:`eaplan_drake.planning.capacity`; a worn pack is then priced as worn)."""
    risk: float = 0.05
    """ε, the largest excess risk of a decision with ``reserve: risk`` [-], in (0, 1): the
    probability, under ``fault_model``, that the mission fails although the lowest plan flown from
    the same state would have completed."""
    fault_model: FaultModelParams = dc.field(default_factory=FaultModelParams)
    """The planner's belief about faults (used with ``reserve: risk`` and by ``certify``)."""
    fault_reserve: float = 0.10
    """With ``reserve: fixed``, the SoC the mpc policy holds back for battery faults it cannot
    foresee, on top of the margin [-], in [0, 1). 0.10 covers one fault of the reference plan i's
    size (−6 %, −9 %); measured on 40 random worlds (0–3 drops of 0–15 %,
    benchmarks/bench_policies.py --first-seed 1000), the mpc completed 23 of the 33 missions the
    lowest plan completes with 0, and 31 with 0.10 and with 0.15 (the two lost to two late
    drops); each 0.05 costs quality where nothing fails."""
    fault_reserve_time: float = 300.0
    """With ``reserve: fixed``, τ_f [s]: the fault reserve held for a plan with t seconds of survey
    left is ``fault_reserve`` · min(1, t/τ_f): faults come at a rate, so the exposure, and the
    reserve, shrink as the survey nears its end (the reserve is then spent on quality). 0 holds
    the whole reserve to the end. A margin that does not grow as time passes keeps the mpc
    recursively feasible. Measured on worlds 0–22 of benchmarks/bench_policies.py (21 that the
    lowest plan completes): 300 s completed the same 19 as 0 s, at a mission quality of 0.478
    instead of 0.354."""
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
        self._ValidateReserve(key)
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

    def _ValidateReserve(self, key: str) -> None:
        """The keys of what the mpc holds back: margin, reserve rule, risk and its belief."""
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
            self.policy not in ("static_takeoff", "mdp") or self.reserve == "risk",
            f"{key}.reserve",
            f'must be "risk" with {key}.policy {self.policy} (it prices its plans with '
            f"{key}.fault_model), got {self.reserve!r}",
        )
        _check(
            self.after_drop in ("replan", "lowest"),
            f"{key}.after_drop",
            f'must be "replan" or "lowest", got {self.after_drop!r}',
        )
        _check(
            self.first_budget in ("half", "reach"),
            f"{key}.first_budget",
            f'must be "half" or "reach", got {self.first_budget!r}',
        )
        _check(
            self.capacity in PACK_CAPACITY_SOURCES,
            f"{key}.capacity",
            f"must be one of {', '.join(PACK_CAPACITY_SOURCES)}, got {self.capacity!r}",
        )
        _in_range(self.risk, f"{key}.risk", 1e-6, 1.0 - 1e-6)
        self.fault_model.Validate(f"{key}.fault_model")

    @property
    def is_static(self) -> bool:
        """The planner holds its initial parameters (``static`` and ``hindsight``, whose flights
        are static)."""
        return self.policy in ("static", "hindsight")

    def PathParameterGrid(self):
        """The M equally spaced c1 values over the bounds [m²] (numpy array)."""
        lo, hi = (float(v) for v in self.path_parameter_bounds)
        return np.linspace(lo, hi, int(self.path_parameter_grid_size))
