"""Planner-scheduler (paper 003 Alg. 2): the Drake system and the policy seam.

Every h_T [s] the :class:`PlannerScheduler` hands what it observes (:class:`PlannerObservation`:
q̂ [W], Var(α̂0) [W²], b [-], T [s], the coverage fraction left, the exact remaining time at the
c1 grid [s], the parameters applied now) to a :class:`PlannerPolicy` and applies its
:class:`PlannerDecision` (c1 [m²], c2 [table units]).

Where the rest lives:

- :mod:`eaplan_drake.planning.policies`: the policies (mpc, paper, greedy, greedy_authors,
  static) and :func:`~eaplan_drake.planning.policies.MakePolicy`.
- :mod:`eaplan_drake.planning.prediction`: the pure prediction helpers every policy uses (free
  response, the one Simpson SoC rollout on the battery model, time to reserve, the Eq. 10 line
  and path rule, the smooth table surrogate).
- :mod:`eaplan_drake.planning.paper`: the paper's NLP (Eq. 16) and step
  (:class:`~eaplan_drake.planning.paper.Planner`).
- :mod:`eaplan_drake.planning.mpc`: the mission-feasible MPC (the default policy).

The names of those modules that other code imported from here stay importable from here.
"""

import copy
import dataclasses as dc
import math
import time

import numpy as np
from pydrake.systems.framework import LeafSystem

from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.energy.fourier import StateSize
from eaplan_drake.params import PlannerParams

__all__ = [
    "DECISION_KINDS",
    "PlannerDecision",
    "PlannerObservation",
    "PlannerPolicy",
    "PlannerScheduler",
]


# -- the policy seam ----------------------------------------------------------------------------


@dc.dataclass
class PlannerObservation:
    """What a policy sees at a planner step (the :class:`PlannerScheduler` inputs and state)."""

    time: float
    """t [s]."""
    energy_coefficients: np.ndarray
    """q̂ [W] (2r + 1,)."""
    mean_power_variance: float
    """Var(α̂0) = P_00 of the estimator [W²]."""
    soc: float
    """b [-]."""
    period: float
    """T [s]."""
    coverage_remaining: float
    """Fraction of the survey still to fly [-]."""
    remaining_time: np.ndarray | None
    """Exact remaining time t_rem(c1_j) at the sequencer's c1 grid [s] (M,); None for a policy
    that does not observe it (:attr:`PlannerPolicy.observes_remaining_time`)."""
    path_parameter: float
    """c1 applied now [m²]."""
    computation_parameters: np.ndarray
    """c2 applied now (σ,) [table units]."""


@dc.dataclass
class PlannerDecision:
    """What a policy answers: the parameters to apply and its memory for the next step."""

    path_parameter: float
    """c1 [m²]."""
    computation_parameters: np.ndarray
    """c2 (σ,) [table units]."""
    memory: np.ndarray
    """The policy's memory for the next step (e.g. a warm start), kept in the context."""
    success: bool = True
    """False when the policy's solver failed and a deterministic fallback answered."""
    feasible: bool = True
    """False when the policy's constraint (mpc: completing the survey above the reserve plus the
    margin even at the lowest quality; paper: y ≤ b·Q_c·V) cannot be met."""
    status: str = ""
    solve_time: float = 0.0
    """Wall time of the solver [s] (statistics only; never changes a decision)."""
    predicted_end_soc: float = math.nan
    """The SoC the policy predicts at the end of the survey under the plan it chose [-] (mpc;
    NaN for a policy that does not predict it)."""
    required_end_soc: float = math.nan
    """The SoC the policy requires at the end [-] (mpc: reserve + margin m(t_rem) of the chosen
    c1; NaN for a policy that does not require one)."""
    kind: str = ""
    """How the decision was reached, counted in the statistics (mpc: :data:`DECISION_KINDS`)."""


DECISION_KINDS = {
    "solved": "the NLP solved and its answer mapped onto the grids",
    "determined": "decided exactly on the table's grid, without a solve",
    "fallback": "the solver failed: c1 kept, the best admissible c2",
    "lowest": "the lowest plan: uncertain (the margin not met yet), infeasible, or after a drop",
    "unpriced": "the risk could not be priced: the lowest plan, infeasible",
    "invalid": "an observation not finite: the lowest plan, infeasible",
    "chosen": "static_takeoff: the static plan chosen at take-off",
    "held": "static_takeoff: the plan chosen at take-off, held",
    "mdp": "mdp: the action of the MDP solved at take-off (or held)",
}
"""The kinds of the mpc's (and static_takeoff's) decisions (:attr:`PlannerDecision.kind`)."""


class PlannerPolicy:
    """A planner-scheduler policy: subclass and implement ``Plan(observation, memory)`` (and
    :meth:`InitialMemory` if the policy remembers anything between steps, e.g. a warm start).

    A policy must be a function of its arguments: any memory goes through ``memory`` (it lives in
    the Drake context), so a simulation depends on its scenario only.
    """

    name = "policy"
    acts = True
    """False for a policy that never changes the parameters (no update event is declared)."""
    observes_remaining_time = True
    """False for a policy that never reads ``PlannerObservation.remaining_time`` (it is then
    None, and the sequencer's staircase t_rem(c1_j), one plan regeneration per grid value at each
    stage change, is never computed)."""

    def InitialMemory(self) -> np.ndarray:
        """The memory at t = 0 (a vector; may be empty)."""
        return np.zeros(0)

    def Plan(self, observation: PlannerObservation, memory: np.ndarray) -> PlannerDecision:
        raise NotImplementedError


# -- Drake system -------------------------------------------------------------------------------


class PlannerScheduler(LeafSystem):
    """The planner-scheduler of paper 003 Alg. 2 as a periodic discrete system around a policy.

    Args:
        planner: the planner parameters (copied): h_T = ``period`` [s], ``warmup`` [s] and the
            size M of the c1 grid (``path_parameter_grid_size``) are read here.
        policy: the :class:`PlannerPolicy` that decides (the scheduler never builds one: the
            diagram passes the scenario's, :func:`~eaplan_drake.planning.policies.MakePolicy`, or a
            user's own).
        table: the computation power table (its σ and bounds check the initial c2).
        order: Fourier order r of the energy model, or an ``AugmentedOrder`` (q̂ has
            :func:`~eaplan_drake.energy.fourier.StateSize` entries).
        initial_path_parameter: c1 flown until the first update [m²].
        initial_computation_parameters: c2 flown until the first update (σ,) [table units].

    Every h_T [s], from t = ``warmup`` on, it hands the inputs (q̂ [W], Var(α̂0) [W²],
    b [-], T [s], the coverage fraction left and the exact remaining time at each c1 of the grid
    [s]) and the parameters applied now to ``policy`` (:class:`PlannerPolicy`; see
    :mod:`eaplan_drake.planning.policies`: mpc, paper, greedy, greedy_authors, static) and applies
    its
    answer. Before the warm-up, and always for a policy that does not act, the outputs hold the
    initial parameters. ``mission_feasible`` is 1 while the policy's constraint can be met and 0
    after a step where it cannot (mpc: not even the lowest-quality plan completes the survey above
    the reserve plus the margin; it then flies the lowest plan).

    ``predicted_soc`` is [predicted end SoC, required end SoC] [-] of the last decision
    (:attr:`PlannerDecision.predicted_end_soc`, :attr:`PlannerDecision.required_end_soc`; NaN
    before the first update and for a policy that does not predict them).

    Discrete state: [c1] (group 0), [c2] (group 1), [mission_feasible] (group 2), the policy's
    memory (group 3), [predicted end SoC, required end SoC] (group 4); the outputs are the state
    (no direct feedthrough, so no algebraic loop).
    The solve statistics (:meth:`statistics`) are Python-side attributes of the System, *not*
    Drake state: they accumulate over every context/simulation of this instance
    (:meth:`reset_statistics`) and never change a decision.

    .. pydrake_system::

        name: PlannerScheduler
        input_ports:
        - energy_coefficients
        - mean_power_variance
        - soc
        - period
        - coverage_remaining
        - remaining_time
        output_ports:
        - path_parameters
        - computation_parameters
        - mission_feasible
        - predicted_soc
    """

    def __init__(
        self,
        planner: PlannerParams,
        *,
        policy: PlannerPolicy,
        table: ComputationTable,
        order,
        initial_path_parameter: float,
        initial_computation_parameters,
    ):
        super().__init__()
        if not isinstance(planner, PlannerParams):
            raise ValueError(f"planner: must be a PlannerParams, got {type(planner).__name__}")
        if not isinstance(policy, PlannerPolicy):
            raise ValueError(f"policy: must be a PlannerPolicy, got {type(policy).__name__}")
        planner = copy.deepcopy(planner)
        planner.Validate("planner")
        self._params = planner
        self._policy = policy
        self._table = table
        period, warmup = float(planner.period), float(planner.warmup)
        c2_0 = np.asarray(initial_computation_parameters, dtype=float).reshape(-1)
        if c2_0.size != table.num_parameters or not np.all(np.isfinite(c2_0)):
            raise ValueError(
                f"initial_computation_parameters: expected {table.num_parameters} finite "
                f"value(s), got {initial_computation_parameters!r}"
            )
        if np.any(c2_0 < table.lower) or np.any(c2_0 > table.upper):
            raise ValueError(
                f"initial_computation_parameters: must lie in [{table.lower}, {table.upper}], "
                f"got {c2_0}"
            )
        c1_0 = float(initial_path_parameter)
        if not math.isfinite(c1_0):
            raise ValueError(f"initial_path_parameter: must be finite, got {c1_0!r}")
        m = StateSize(order)
        self._energy_port = self.DeclareVectorInputPort("energy_coefficients", m)
        self._variance_port = self.DeclareVectorInputPort("mean_power_variance", 1)
        self._soc_port = self.DeclareVectorInputPort("soc", 1)
        self._period_port = self.DeclareVectorInputPort("period", 1)
        self._coverage_port = self.DeclareVectorInputPort("coverage_remaining", 1)
        self._remaining_port = self.DeclareVectorInputPort(
            "remaining_time", int(planner.path_parameter_grid_size)
        )
        self._c1_index = self.DeclareDiscreteState(np.array([c1_0]))
        self._c2_index = self.DeclareDiscreteState(c2_0)
        self._feasible_index = self.DeclareDiscreteState(np.ones(1))
        memory = np.asarray(policy.InitialMemory(), dtype=float).reshape(-1)
        self._memory_size = memory.size
        # Drake needs a non-empty group: an empty memory is stored as one unused zero.
        self._memory_index = self.DeclareDiscreteState(memory if memory.size else np.zeros(1))
        self._predicted_index = self.DeclareDiscreteState(np.full(2, np.nan))
        self._path_port = self.DeclareStateOutputPort("path_parameters", self._c1_index)
        self._computation_port = self.DeclareStateOutputPort(
            "computation_parameters", self._c2_index
        )
        self._feasible_port = self.DeclareStateOutputPort("mission_feasible", self._feasible_index)
        self._predicted_port = self.DeclareStateOutputPort("predicted_soc", self._predicted_index)
        if policy.acts:
            self.DeclarePeriodicDiscreteUpdateEvent(period, warmup, self._Update)
        self.reset_statistics()

    @property
    def table(self) -> ComputationTable:
        return self._table

    @property
    def params(self) -> PlannerParams:
        """The scheduler's copy of the planner parameters."""
        return self._params

    @property
    def policy(self) -> PlannerPolicy:
        """The policy that decides (for inspection and benchmarks)."""
        return self._policy

    def reset_statistics(self) -> None:
        """Clears the solve statistics."""
        self._solves = 0
        self._failures = 0
        self._infeasible = 0
        self._kinds: dict[str, int] = {}
        self._first_status: dict[str, str] = {}
        self._solve_times: list[float] = []
        self._step_times: list[float] = []

    def statistics(self) -> dict:
        """Solve statistics since construction / :meth:`reset_statistics` (Python-side).

        Keys: solves (planner steps), failures (failed solves answered by the deterministic
        fallback), infeasible (steps whose policy constraint could not be met), kinds (steps
        per :attr:`PlannerDecision.kind`, for a policy that says), policy_figures (what a
        policy predicted of its mission, e.g. ``mdp``'s take-off value; empty for most),
        first_status (the status of the first step of each kind), solve_times and step_times
        [s] (solver only / the whole step), median_solve_time, p95_solve_time,
        median_step_time, p95_step_time [s] (None before the first solve).
        """

        def pct(v, p):
            return float(np.percentile(v, p)) if v else None

        return {
            "policy": self._policy.name,
            "policy_figures": dict(getattr(self._policy, "figures", {})),
            "solves": self._solves,
            "failures": self._failures,
            "infeasible": self._infeasible,
            "kinds": dict(self._kinds),
            "first_status": dict(self._first_status),
            "solve_times": list(self._solve_times),
            "step_times": list(self._step_times),
            "median_solve_time": pct(self._solve_times, 50),
            "p95_solve_time": pct(self._solve_times, 95),
            "median_step_time": pct(self._step_times, 50),
            "p95_step_time": pct(self._step_times, 95),
        }

    def Observe(self, context) -> PlannerObservation:
        """The observation a policy gets in ``context`` (inputs and applied parameters)."""
        return PlannerObservation(
            time=float(context.get_time()),
            energy_coefficients=np.array(self._energy_port.Eval(context)),
            mean_power_variance=float(self._variance_port.Eval(context)[0]),
            soc=float(self._soc_port.Eval(context)[0]),
            period=float(self._period_port.Eval(context)[0]),
            coverage_remaining=float(self._coverage_port.Eval(context)[0]),
            remaining_time=(
                np.array(self._remaining_port.Eval(context))
                if self._policy.observes_remaining_time
                else None
            ),
            path_parameter=float(context.get_discrete_state(self._c1_index).GetAtIndex(0)),
            computation_parameters=context.get_discrete_state(self._c2_index).get_value().copy(),
        )

    def _Update(self, context, discrete_state) -> None:
        t0 = time.perf_counter()
        memory = context.get_discrete_state(self._memory_index).get_value()
        decision = self._policy.Plan(self.Observe(context), memory[: self._memory_size].copy())
        self._solves += 1
        if not decision.success:
            self._failures += 1
        if not decision.feasible:
            self._infeasible += 1
        if decision.kind:
            self._kinds[decision.kind] = self._kinds.get(decision.kind, 0) + 1
            self._first_status.setdefault(decision.kind, decision.status)
        discrete_state.get_mutable_vector(self._c1_index).SetAtIndex(
            0, float(decision.path_parameter)
        )
        discrete_state.get_mutable_vector(self._c2_index).SetFromVector(
            np.asarray(decision.computation_parameters, dtype=float)
        )
        discrete_state.get_mutable_vector(self._feasible_index).SetAtIndex(
            0, 1.0 if decision.feasible else 0.0
        )
        discrete_state.get_mutable_vector(self._predicted_index).SetFromVector(
            np.array([decision.predicted_end_soc, decision.required_end_soc], dtype=float)
        )
        if self._memory_size:
            discrete_state.get_mutable_vector(self._memory_index).SetFromVector(
                np.asarray(decision.memory, dtype=float).reshape(-1)
            )
        self._solve_times.append(float(decision.solve_time))
        self._step_times.append(time.perf_counter() - t0)
