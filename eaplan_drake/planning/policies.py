"""Planner policies: what decides c1 [m²] and c2 [table units] every h_T [s].

Each policy is the seam between the :class:`~eaplan_drake.planning.planner.PlannerScheduler` and
a decision rule.

``planner.policy`` in the scenario selects one (:func:`MakePolicy`, by the table
:data:`~eaplan_drake.registry.POLICIES`); a Python user may pass any
:class:`~eaplan_drake.planning.planner.PlannerPolicy` to
:func:`~eaplan_drake.diagram.MakeEaplanDiagram` instead. All share the scheduler's ports.

- ``mpc`` (:class:`MpcPolicy`, default): the mission-feasible MPC of
  :mod:`eaplan_drake.planning.mpc`.
- ``paper`` (:class:`PaperPolicy`): paper 003 Eq. 16 + Alg. 2 as published
  (:class:`~eaplan_drake.planning.paper.Planner`: Def. III.3 output constraint, Eq. 10 line,
  rate-limited path rule); the four reference flights use it.
- ``greedy`` (:class:`GreedyPolicy`): a one-step rule fed the MPC's signals (exact remaining
  time, estimated power, Rint battery) but with no margin and one parameter at a time: c2 is the
  best value whose plan at the current c1 ends at or above the reserve, then c1 moves by at most
  δ1 towards the largest grid value that does too.
- ``greedy_authors`` (:class:`GreedyAuthorsPolicy`): the authors' MATLAB rule: c2 by brute force
  over the table's values held for the horizon, maximising Σ y² subject to y ≤ b·Q_c·V at every
  step end (the lowest if none); c1 moved by ±δ1 each step depending on whether the remaining
  time estimated from the elapsed time, t_rem = (t̂/t̄)(t̄ − t) with t̂ = t(c1) and t̄ = t(c̄1) of the
  Eq. 10 line, exceeds the predicted time to the reserve.
- ``static`` (:class:`StaticPolicy`): hold the initial parameters.
- ``static_takeoff`` (:class:`StaticTakeoffPolicy`): the pilot's baseline, the best static plan
  within the risk ε chosen once at take-off and flown unchanged.
- ``mdp`` (:class:`MdpPolicy`): the best non-clairvoyant policy of the planner's fluid model
  at take-off, a dynamic programme solved once and flown by lookup
  (:mod:`eaplan_drake.planning.mdp`); a yardstick under study, not a better planner.
- ``hindsight``: not a policy of the loop but the best constant pair of a grid flown on the same
  world (:func:`~eaplan_drake.simulation.FlyHindsight`); each of its flights is static.
"""

import copy
import dataclasses
import math
import time

import numpy as np

from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.params import BatteryParams, PlannerParams
from eaplan_drake.planning.belief import SIZE_RESOLUTION
from eaplan_drake.planning.capacity import UNSET, InitialPack, ObservePack, PredictPack
from eaplan_drake.planning.grid_search import DeterminedDecision, MapRelaxed
from eaplan_drake.planning.margins import LEARNT_SIZES, RiskMemory
from eaplan_drake.planning.mdp import (
    SEARCH_GRID,
    MdpGrid,
    MissionMdpFromStep,
    MissionMdpNow,
    Solve,
    SolveConstrained,
)
from eaplan_drake.planning.mpc import MissionProblem, MissionStep, StaircaseSteps
from eaplan_drake.planning.paper import Planner
from eaplan_drake.planning.planner import PlannerDecision, PlannerObservation, PlannerPolicy
from eaplan_drake.planning.relaxation import MissionProgram
from eaplan_drake.planning.static_plan import BestStaticPlan
from eaplan_drake.registry import POLICIES

__all__ = [
    "FALLBACK_DROP",
    "GreedyAuthorsPolicy",
    "GreedyPolicy",
    "MakeGreedyAuthorsPolicy",
    "MakeGreedyPolicy",
    "MakeMpcPolicy",
    "MakePaperPolicy",
    "MakePolicy",
    "MakeStaticPolicy",
    "MpcPolicy",
    "MakeMdpPolicy",
    "MdpPolicy",
    "PaperPolicy",
    "StaticPolicy",
    "StaticTakeoffPolicy",
    "MakeStaticTakeoffPolicy",
]


def _Finite(observation: PlannerObservation) -> bool:
    o = observation
    values = np.concatenate(
        (
            o.energy_coefficients,
            o.remaining_time if o.remaining_time is not None else [],
            o.computation_parameters,
            [o.mean_power_variance, o.soc, o.period, o.coverage_remaining, o.path_parameter],
        )
    )
    return bool(np.all(np.isfinite(values)) and o.period > 0.0)


def _InvalidInput(problem: MissionProblem, memory) -> PlannerDecision:
    """A non-finite observation: the lowest plan, counted as a failed, infeasible step."""
    low = problem.candidates[problem.lowest_candidate]
    return PlannerDecision(
        float(problem.grid[0]), low.copy(), memory, False, False, "invalid input", kind="invalid"
    )


def _Prediction(problem: MissionProblem, plan) -> dict:
    """The :class:`PlannerDecision` fields of what ``plan`` (a :class:`MissionDecision`)
    predicts: its end SoC and the SoC required at the end (reserve + its margin m(t_rem))."""
    return {
        "predicted_end_soc": float(plan.end_soc),
        "required_end_soc": problem.reserve_soc + float(plan.margin),
    }


class StaticPolicy(PlannerPolicy):
    """Holds the initial parameters (paper 003 plans I and II)."""

    name = "static"
    acts = False
    observes_remaining_time = False

    def Plan(self, observation, memory) -> PlannerDecision:
        return PlannerDecision(
            observation.path_parameter, observation.computation_parameters.copy(), memory
        )


class StaticTakeoffPolicy(PlannerPolicy):
    """The pilot's baseline (``static_takeoff``): at its first step (take-off, once the estimate
    has settled) the best static plan whose excess risk under ``planner.fault_model`` is within
    ``planner.risk`` (:func:`~eaplan_drake.planning.static_plan.BestStaticPlan`), then that plan
    unchanged to the end. Memory: [chosen (0 or 1), c1, c2…]."""

    name = "static_takeoff"

    def __init__(self, problem: MissionProblem):
        if problem.risk_reserve is None:
            raise ValueError(
                "planner.policy: static_takeoff prices its plan with the risk reserve; "
                'set planner.reserve: "risk"'
            )
        self.problem = problem

    def InitialMemory(self) -> np.ndarray:
        return np.zeros(2 + self.problem.table.num_parameters)

    def Plan(self, observation, memory) -> PlannerDecision:
        o, pb = observation, self.problem
        if memory[0] > 0.0:
            return PlannerDecision(
                float(memory[1]), memory[2:].copy(), memory, status="held", kind="held"
            )
        if not _Finite(o):
            return _InvalidInput(pb, memory)
        step = pb.Step(o, budget=float(pb.params.risk))
        d = BestStaticPlan(step, float(pb.params.risk))
        held = np.concatenate(([1.0, d.path_parameter], d.computation_parameters))
        return PlannerDecision(
            d.path_parameter,
            d.computation_parameters,
            held,
            True,
            d.feasible,
            "chosen at take-off" if d.feasible else "infeasible at take-off: the lowest plan",
            kind="chosen" if d.feasible else "lowest",
            **_Prediction(pb, d),
        )


class MdpPolicy(PlannerPolicy):
    """The planner's fluid model of the mission solved as an MDP, flown by re-planning (``mdp``).

    At its first step (take-off, as ``static_takeoff``) the mission's MDP
    (:func:`~eaplan_drake.planning.mdp.MissionMdpFromStep`) is solved for the chance constraint
    at ε = ``planner.risk`` (:func:`~eaplan_drake.planning.mdp.SolveConstrained`): its value is
    the model's best (:attr:`figures`), and its Lagrange multiplier μ prices a failure for the
    rest of the flight. At every re-plan, the MDP of the flight's state with the route's own
    remaining times (:func:`~eaplan_drake.planning.mdp.MissionMdpNow`, on ``replan_grid``) is
    solved for that μ, and its first stage's best action is flown: for 1/N of the chosen step's
    remaining time (at least one planner period), or until a drop is detected (the SoC more than
    :data:`FALLBACK_DROP` below what the action spends). Re-planning keeps the model's fraction
    of the survey from drifting away from the route, whose remaining time is whole repetitions.

    Memory: [solved (0/1), take-off time [s], ∫J dt so far, time of the last step [s], J of the
    plan flown, the action (s, k) flown (take-off step and row), the step's remaining time [s]
    at which to re-plan, the SoC [-] and the time [s] it was chosen at]. The take-off solution is
    kept by the policy per take-off time (a pure function of the take-off observation)."""

    name = "mdp"

    def __init__(
        self,
        problem: MissionProblem,
        grid: MdpGrid | None = None,
        replan_grid: MdpGrid = SEARCH_GRID,
    ):
        if problem.risk_reserve is None:
            raise ValueError(
                "planner.policy: mdp prices its plans with the fault model; "
                'set planner.reserve: "risk"'
            )
        self.problem = problem
        self.grid = MdpGrid() if grid is None else grid
        self.replan_grid = replan_grid
        """The grid of the MDP solved afresh at each re-plan."""
        self.figures: dict = {}
        """The take-off figures of the last solve (quality, completion, excess, μ)."""
        self._solutions: dict = {}

    def InitialMemory(self) -> np.ndarray:
        return np.zeros(10)

    def _Lowest(self, memory, why: str, feasible: bool) -> PlannerDecision:
        pb = self.problem
        low = pb.candidates[pb.lowest_candidate]
        return PlannerDecision(
            float(pb.grid[0]), low.copy(), memory, True, feasible, why, kind="lowest"
        )

    def Plan(self, observation, memory) -> PlannerDecision:
        o, pb = observation, self.problem
        if not _Finite(o):
            return _InvalidInput(pb, memory)
        o = dataclasses.replace(o, remaining_time=StaircaseSteps(o.remaining_time, pb.step_length))
        memory = np.array(memory, dtype=float)
        if memory[0] == 0.0:
            step = pb.Step(o, budget=float(pb.params.risk))
            mdp = MissionMdpFromStep(step, o, self.grid) if step.priced else None
            if mdp is not None:
                solution, self.figures = SolveConstrained(mdp, float(pb.params.risk))
                self._solutions[float(o.time)] = solution
            quality = mdp.flown_quality if mdp is not None else 0.0
            memory[:] = (1.0, o.time, quality * o.time, o.time, quality, 0, 0, -1, 0, 0)
        memory[2] += memory[4] * (float(o.time) - memory[3])
        memory[3] = float(o.time)
        solution = self._solutions.get(float(memory[1]))
        if solution is None:
            return self._Lowest(memory, "infeasible at take-off: the lowest plan", False)
        takeoff = solution.mdp
        left = np.array([float(o.remaining_time[j]) for j in takeoff.path_index])
        held, row = int(memory[5]), int(memory[6])
        predicted = memory[8] - takeoff.rates[row] * (float(o.time) - memory[9])
        dropped = float(o.soc) < predicted - FALLBACK_DROP
        if memory[7] > 0.0 and left[held] > memory[7] and not dropped:
            return self._Held(memory, takeoff, held, row, "held")
        flown = max(float(o.time), 1e-9)
        margin = float(o.soc) - pb.reserve_soc
        now = MissionMdpNow(takeoff, left, margin, flown, memory[2] / flown, self.replan_grid)
        if now is None:
            return self._Lowest(memory, "no margin left: the lowest plan", False)
        mdp, index = now
        values = Solve(mdp, solution.penalty).StartActionValues(pb.step_length)[..., 0]
        if not np.max(values) > 0.0:
            return self._Lowest(memory, "lost in the model from here: the lowest plan", False)
        i, row = np.unravel_index(int(np.argmax(values)), values.shape)
        held = index[i]
        until = left[held] - max(left[held] / self.replan_grid.stages, pb.step_length)
        memory[5:] = (held, row, until, float(o.soc), float(o.time))
        return self._Held(memory, takeoff, held, row, "re-planned")

    def _Held(self, memory, mdp, s, k, why):
        """The action (s, k) of the take-off MDP's steps and rows, flown."""
        pb = self.problem
        memory[4] = float(mdp.quality[s, k])
        return PlannerDecision(
            float(pb.grid[mdp.path_index[s]]),
            pb.candidates[k].copy(),
            memory,
            True,
            True,
            f"{why}: c1 of step {s + 1} of {mdp.times.size}, c2 row {k + 1}",
            kind="mdp",
        )


class PaperPolicy(PlannerPolicy):
    """Paper 003 Eq. 16 + Alg. 2 (:class:`~eaplan_drake.planning.paper.Planner`); memory: the warm
    start of its NLP (carried unchanged with integer parameters, where no NLP is needed)."""

    name = "paper"
    observes_remaining_time = False

    def __init__(self, planner: Planner):
        self.planner = planner

    def InitialMemory(self) -> np.ndarray:
        return self.planner.LowestWarmStart()

    def Plan(self, observation, memory) -> PlannerDecision:
        o = observation
        sol = self.planner.Plan(
            o.energy_coefficients,
            o.soc,
            o.period,
            o.coverage_remaining,
            o.computation_parameters,
            o.path_parameter,
            memory,
        )
        return PlannerDecision(
            path_parameter=sol.path_parameter,
            computation_parameters=sol.computation_parameters,
            memory=sol.warm_start,
            success=sol.success,
            feasible=sol.success and sol.feasible,
            status=sol.status,
            solve_time=sol.solve_time,
        )


FALLBACK_DROP = 0.01
"""With ``planner.reserve: risk``, a SoC more than this below the mpc's one-step prediction [-]
is a drop: the policy opens the next, halved, risk budget anchored at that state, or, with
``after_drop: lowest``, flies the lowest plan from then on (the fallback its excess risk
assumes, :mod:`eaplan_drake.planning.risk`)."""


class MpcPolicy(PlannerPolicy):
    """The mission-feasible MPC (:mod:`eaplan_drake.planning.mpc`): the NLP relaxation solved with
    IPOPT (iterations bounded, never wall time), mapped exactly onto the grids.

    Memory: the relaxed solution [c̃1, c̃2] (the next warm start), then, with ``reserve: risk``,
    the :data:`~eaplan_drake.planning.margins.RiskMemory`."""

    name = "mpc"

    def __init__(self, problem: MissionProblem):
        self.problem = problem
        self.program = MissionProgram(problem)
        p = problem.params
        self._risk = p.reserve == "risk"
        self._falls_back = self._risk and p.after_drop == "lowest"
        self._reach = self._risk and p.first_budget == "reach"
        self._budget = float(p.risk) if self._risk else 0.0
        self._warm_size = self.program.variables.size
        self._risk_end = self._warm_size + (len(RiskMemory.Zero()[:]) if self._risk else 0)
        self._learns_capacity = p.capacity == "estimated"
        self.figures: dict = {}
        """The last step's estimate ``pack_health`` ĥ [-] (``capacity: estimated``)."""

    def InitialMemory(self) -> np.ndarray:
        memory = np.zeros(self._warm_size)
        if self._risk:
            tail = RiskMemory.Zero()
            tail.predicted_soc, tail.drops, tail.anchor_end = UNSET, 0.0, UNSET
            tail.anchor_margin, tail.first_budget = 0.0, UNSET
            memory = np.concatenate((memory, tail[:]))
        if self._learns_capacity:
            memory = np.concatenate((memory, InitialPack()[:]))
        self.figures = {}
        return memory

    def Budget(self, drops: int) -> float:
        """ε_k = ε / 2^(k+1) [-]: the excess risk the policy may spend after k detected drops
        (``reserve: risk``); summed over any number of drops it is at most ε. With
        ``first_budget: reach`` the budget before the first drop is larger, the one of
        :meth:`~eaplan_drake.planning.margins.RiskReserve.FirstBudget` (set at the first step)."""
        return self._budget / 2.0 ** (int(drops) + 1)

    def Step(self, observation, memory) -> MissionStep:
        """The :class:`~eaplan_drake.planning.mpc.MissionStep` the policy plans on for this
        observation and memory (with ``reserve: risk``: the budget of the drops detected so far,
        and the anchor where it opened)."""
        return self._Step(observation, memory)[0]

    def _Step(self, observation, memory):
        """(the step, the updated :data:`~eaplan_drake.planning.margins.RiskMemory` or None,
        the updated :data:`~eaplan_drake.planning.capacity.CapacityMemory` or None). The
        remaining times are read by steps of the staircase
        (:func:`~eaplan_drake.planning.mpc.StaircaseSteps`)."""
        o, pb = observation, self.problem
        if o.remaining_time is not None:
            steps = StaircaseSteps(o.remaining_time, pb.step_length)
            o = dataclasses.replace(o, remaining_time=steps)
        pack = None  # capacity: estimated
        if self._learns_capacity:
            pack = ObservePack(memory[self._risk_end :], o.soc, FALLBACK_DROP)
            self.figures["pack_health"] = float(pack.health)
        health = 1.0 if pack is None else float(pack.health)
        if not self._risk:
            return pb.Step(o, health=health), None, pack
        tail = RiskMemory(np.array(memory[self._warm_size : self._risk_end], dtype=float))
        # (UNSET, or a prediction below empty: nothing to compare with)
        if tail.predicted_soc >= 0.0 and o.soc < tail.predicted_soc - FALLBACK_DROP:
            # a drop: a new, halved budget, anchored at this state; its size is remembered
            if tail.drops < LEARNT_SIZES:
                size = math.ceil(round((tail.predicted_soc - o.soc) / SIZE_RESOLUTION, 9))
                setattr(tail, f"size_{int(tail.drops) + 1}", min(size * SIZE_RESOLUTION, 1.0))
            tail.drops, tail.anchor_end = tail.drops + 1.0, UNSET
        anchor = None
        if tail.anchor_end >= 0.0:
            anchor = (tail.anchor_end - float(o.time), tail.anchor_margin)
        seen = range(1, min(int(tail.drops), LEARNT_SIZES) + 1)
        observed = tuple(float(getattr(tail, f"size_{i}")) for i in seen)
        budget = self.Budget(tail.drops)
        if self._reach and tail.drops == 0.0 and o.remaining_time is not None:
            if tail.first_budget < 0.0:  # the first step: τ, the longest plan's time left
                tail.first_budget = pb.risk_reserve.FirstBudget(
                    self._budget, float(np.max(o.remaining_time))
                )
            budget = tail.first_budget
        step = pb.Step(o, budget, anchor, observed, int(tail.drops), health)
        return step, tail, pack

    def Plan(self, observation, memory) -> PlannerDecision:
        o, pb = observation, self.problem
        if not _Finite(o):
            return _InvalidInput(pb, memory)
        step, tail, pack = self._Step(o, memory)
        warm = memory[: self._warm_size]
        if tail is None:
            return self._Remember(o, step, self._Plan(o, warm, step), pack)
        if self._falls_back and tail.drops > 0.0:
            low = step.Lowest()
            d = PlannerDecision(
                low.path_parameter,
                low.computation_parameters,
                warm,
                True,
                bool(low.feasible) or step.NominallyFeasible(),
                "after a SoC drop: the lowest plan to the end",
                kind="lowest",
                **_Prediction(pb, low),
            )
        else:
            d = self._Plan(o, warm, step)
            if tail.anchor_end < 0.0 and step.priced:
                tau_0, m_0 = step.margin.lowest_state
                tail.anchor_end, tail.anchor_margin = float(o.time) + tau_0, m_0
        power = float(pb.table.power(np.asarray(d.computation_parameters, dtype=float)))
        tail.predicted_soc = float(step.SocAt(power, pb.step_length))
        d.memory = np.concatenate((d.memory, tail[:]))
        return self._Remember(o, step, d, pack)

    def _Remember(self, observation, step, decision, pack) -> PlannerDecision:
        """``decision``, its memory followed by ``pack`` (if any) predicted one period ahead."""
        if pack is None:
            return decision
        pb = self.problem
        power = float(pb.table.power(np.asarray(decision.computation_parameters, dtype=float)))
        ahead = float(step.SocAt(power, pb.step_length))
        pack = PredictPack(pack, observation.soc, ahead)
        decision.memory = np.concatenate((decision.memory, pack[:]))
        return decision

    def _Plan(self, observation, memory, step) -> PlannerDecision:
        o = observation
        pb = self.problem
        low = step.Lowest()
        if not step.priced:  # what cannot be priced is infeasible: the lowest plan, said so
            return PlannerDecision(
                low.path_parameter,
                low.computation_parameters,
                memory,
                True,
                False,
                f"unpriced: {step.margin.why}; the lowest plan",
                kind="unpriced",
                **_Prediction(pb, low),
            )
        if not low.feasible:
            nominal = step.NominallyFeasible()
            return PlannerDecision(
                low.path_parameter,
                low.computation_parameters,
                memory,
                True,
                nominal,
                "uncertain: the lowest plan until the estimate settles"
                if nominal
                else "infeasible: the lowest plan ends below reserve + margin",
                kind="lowest",
                **_Prediction(pb, low),
            )
        determined = DeterminedDecision(step)
        if determined is not None:
            # Every relaxed answer maps to this plan (the mapping reads c̃2 only through its
            # bracketing grid points): no solve can change it, so none is run. This also
            # covers a feasible set of (nearly) one point, where interior-point solvers stall.
            return PlannerDecision(
                determined.path_parameter,
                determined.computation_parameters,
                memory,
                True,
                True,
                "determined without a solve",
                kind="determined",
                **_Prediction(pb, determined),
            )
        ok, status, x, solve_time = self._Solve(step, memory)
        if not ok:
            d = step.KeepPathParameter(o.path_parameter)
            return PlannerDecision(
                d.path_parameter,
                d.computation_parameters,
                memory,
                False,
                d.feasible,
                f"solver failed: {status}",
                solve_time,
                kind="fallback",
                **_Prediction(pb, d),
            )
        d = MapRelaxed(step, x[1:])
        return PlannerDecision(
            d.path_parameter,
            d.computation_parameters,
            np.clip(x, 0.0, 1.0),
            True,
            True,
            status,
            solve_time,
            kind="solved",
            **_Prediction(pb, d),
        )

    def _Solve(self, step, memory):
        """(ok, status, x, solve time [s]) of the NLP relaxation of ``step``: from the warm start,
        then (deterministically) from the lowest plan, which is feasible, then from the middle of
        the box; a solver error or a non-finite solution is a failed solve, never raised."""
        t0 = time.perf_counter()
        for start in (memory, np.zeros_like(memory), np.full_like(memory, 0.5)):
            try:
                result = self.program.Solve(step, start)
                ok = result.is_success()
                status = result.get_solution_result().name
                x = result.get_x_val() if ok else None
            except RuntimeError as e:
                ok, status, x = False, f"error: {e}", None
            if ok:
                break
        solve_time = time.perf_counter() - t0
        if ok and not np.all(np.isfinite(x)):
            ok, status = False, "non-finite solution"
        return ok, status, x, solve_time


class GreedyPolicy(PlannerPolicy):
    """One-step rule on the MPC's signals with no margin (see the module docstring)."""

    name = "greedy"

    def __init__(self, problem: MissionProblem):
        self.problem = problem

    def Plan(self, observation, memory) -> PlannerDecision:
        o = observation
        pb = self.problem
        if not _Finite(o):
            return _InvalidInput(pb, memory)
        step = pb.Step(o)
        reserve = pb.reserve_soc
        j_now = int(np.clip(np.searchsorted(pb.grid, o.path_parameter + 1e-9) - 1, 0, None))
        # c2: the best candidate whose plan at the current c1 ends at or above the reserve.
        order = np.lexsort((-pb.candidate_power, -pb.candidate_u2))
        k = pb.lowest_candidate
        for i in order:
            if step.SocAt(float(pb.candidate_power[i]), step.t_rem[j_now]) >= reserve:
                k = int(i)
                break
        # c1: towards the largest grid value that ends at or above the reserve, by at most δ1.
        end = step.SocAt(float(pb.candidate_power[k]), step.t_rem)
        hits = np.flatnonzero(end >= reserve)
        target = float(pb.grid[hits[-1]]) if hits.size else float(pb.grid[0])
        delta = float(pb.params.path_parameter_step)
        c1 = min(max(target, o.path_parameter - delta), o.path_parameter + delta)
        feasible = bool(hits.size)
        return PlannerDecision(c1, pb.candidates[k].copy(), memory, True, feasible, "")


class GreedyAuthorsPolicy(PlannerPolicy):
    """The authors' MATLAB rule (see the module docstring), on the paper planner's model."""

    name = "greedy_authors"
    observes_remaining_time = False

    def __init__(self, planner: Planner):
        self.planner = planner

    def Plan(self, observation, memory) -> PlannerDecision:
        o = observation
        p = self.planner
        if not _Finite(o):
            return PlannerDecision(
                p.coverage_time.bounds[0], p.lower.copy(), memory, False, False, "invalid input"
            )
        N = p.horizon
        f_half = p.ResponseRows(float(o.period)) @ o.energy_coefficients
        g_prev = p.table.power(o.computation_parameters)
        # c2: maximise Σ y² over the horizon subject to y ≤ b·Q_c·V at every step end.
        best, best_score, feasible = None, -math.inf, False
        for c, g in zip(p.candidates, p.candidate_power, strict=True):
            soc, ok = o.soc, True
            score = 0.0
            for k in range(N):
                f3 = f_half[2 * k : 2 * k + 3]
                good, soc_end = p.StepFeasible(f3, g - g_prev, soc)
                ok = ok and bool(good[0])
                soc = float(soc_end[0])
                score += float(f3[2] + g - g_prev) ** 2
            if ok and score > best_score:
                best, best_score, feasible = c, score, True
        c2 = p.lower.copy() if best is None else best.copy()
        dg = np.full(N, p.table.power(c2) - g_prev)
        t_b = p.TimeToReserve(f_half, dg, o.soc)
        # c1: ±δ1 by the remaining time estimated from the elapsed time (Eq. 10 line).
        model = p.coverage_time
        t_bar = model(model.bounds[1])
        t_rem = model(o.path_parameter) / t_bar * max(t_bar - o.time, 0.0)
        step = float(p.params.path_parameter_step)
        c1 = o.path_parameter - step if t_rem > t_b else o.path_parameter + step
        c1 = min(max(c1, model.bounds[0]), model.bounds[1])
        return PlannerDecision(c1, c2, memory, True, feasible, "")


def MakePolicy(
    planner: PlannerParams,
    table: ComputationTable,
    order: int,
    battery: BatteryParams,
    *,
    coverage_time_bounds,
    path_parameter_grid,
    integer: bool = True,
) -> PlannerPolicy:
    """The policy ``planner.policy`` names in :data:`~eaplan_drake.registry.POLICIES`
    (``hindsight`` flights are static).

    ``coverage_time_bounds`` = (t(c̲1), t(c̄1)) [s] of the Eq. 10 line (paper, greedy_authors);
    ``path_parameter_grid`` = the c1 values [m²] of the sequencer's ``remaining_time`` (mpc,
    greedy). Parameters are copied: later changes to the caller's objects do not reach the policy.
    Every registered factory takes these same arguments.
    """
    planner = copy.deepcopy(planner)
    battery = copy.deepcopy(battery)
    planner.Validate("planner")
    battery.Validate("battery")
    return POLICIES.Make(
        planner.policy,
        planner,
        table,
        order,
        battery,
        coverage_time_bounds=coverage_time_bounds,
        path_parameter_grid=path_parameter_grid,
        integer=integer,
    )


def MakeStaticPolicy(planner, table, order, battery, **_) -> PlannerPolicy:
    """``static`` (and ``hindsight``): :class:`StaticPolicy`."""
    return StaticPolicy()


def MakePaperPolicy(planner, table, order, battery, *, coverage_time_bounds, integer, **_):
    """``paper``: :class:`PaperPolicy`, the paper's output MPC."""
    return PaperPolicy(Planner(planner, table, order, battery, coverage_time_bounds, integer))


def MakeGreedyAuthorsPolicy(planner, table, order, battery, *, coverage_time_bounds, integer, **_):
    """``greedy_authors``: :class:`GreedyAuthorsPolicy`."""
    paper = Planner(planner, table, order, battery, coverage_time_bounds, integer)
    return GreedyAuthorsPolicy(paper)


def MakeGreedyPolicy(planner, table, order, battery, *, path_parameter_grid, integer, **_):
    """``greedy``: :class:`GreedyPolicy`, the mission problem with no margin and no reserve."""
    no_margin = copy.deepcopy(planner)
    no_margin.margin_floor = no_margin.margin_sigmas = no_margin.fault_reserve = 0.0
    problem = MissionProblem(no_margin, table, order, battery, path_parameter_grid, integer)
    return GreedyPolicy(problem)


def MakeStaticTakeoffPolicy(planner, table, order, battery, *, path_parameter_grid, integer, **_):
    """``static_takeoff``: :class:`StaticTakeoffPolicy`, the best static plan at take-off."""
    problem = MissionProblem(planner, table, order, battery, path_parameter_grid, integer)
    return StaticTakeoffPolicy(problem)


def MakeMdpPolicy(planner, table, order, battery, *, path_parameter_grid, integer, **_):
    """``mdp``: :class:`MdpPolicy`, the MDP solved at take-off and flown."""
    problem = MissionProblem(planner, table, order, battery, path_parameter_grid, integer)
    return MdpPolicy(problem)


def MakeMpcPolicy(planner, table, order, battery, *, path_parameter_grid, integer, **_):
    """``mpc`` (the default): :class:`MpcPolicy`, the mission-feasible MPC."""
    problem = MissionProblem(planner, table, order, battery, path_parameter_grid, integer)
    return MpcPolicy(problem)
