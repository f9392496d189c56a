"""The mission as a finite Markov decision process under the planner's fluid model, with a chance
constraint, solved by dynamic programming: the best non-clairvoyant policy *of that model*
(``planner.policy: mdp``; :doc:`/mdp`, which also says how far that model is from the route).

Plain numpy, deterministic. Units: time [s], SoC fractions [-], quality [-].

**The model** is the one the planner prices with at take-off (the first planner step, as
:mod:`~eaplan_drake.planning.static_plan`), nothing else:

- the remaining-time staircase read by its steps
  (:func:`~eaplan_drake.planning.mpc.StaircaseSteps`): step s flies t_s [s] of survey from
  take-off, t_0 < t_1 < ...; its best plan is its largest c1 (same time and energy, more
  quality), so the MDP's path choices are the steps;
- progress (assumption A1 of :mod:`~eaplan_drake.planning.risk`, the planner's "fraction · t(c1)"):
  the survey is a fraction p ∈ [0, 1] flown; flying step s advances p at 1/t_s per second, so a
  switch of step keeps the fraction flown;
- SoC: the computation row k (power g_k) spends the margin at the constant rate r_k [1/s], the
  prediction's mean over the lowest plan's time plus the uncertainty term z s_b σ of the step;
  the margin is the SoC above b_res, where a flight ends lost (certify's count; the mpc's
  floor m_floor is a hedge of its own, not part of the mission);
- faults: drops of :attr:`~eaplan_drake.planning.margins.RiskReserve.stated_model` (Poisson rate λ,
  i.i.d. sizes), the model the worlds are drawn from;
- quality: the mission quality is the time mean over the whole flight of
  J = w1 c̃1 + w2 c̃2 (the summary's, warm-up included); a mission whose margin goes below 0
  (SoC never rises: the end is the lowest point) is lost, with quality 0.

**The MDP.** Decision epochs are the N progress stages p_n = n/N. The state at stage n is
(m, T, Q̄): the margin m, the time flown T and the quality so far Q̄ = A/T (A = ∫ J dt). Action
(s, k) flies the stage: δt = t_s / N, m ← m − r_k δt − (the drops in δt), T ← T + δt,
Q̄ ← (Q̄ T + J_sk δt)/(T + δt). At p_N = 1 the mission is complete with quality Q̄. Drops are
applied at the end of the stage: a drop's size adds to the spending whenever it comes, and since
m never rises, failing inside the stage is failing at its end; only the reaction waits for the
next epoch (so the MDP's information is coarser than the flight's, never finer).

**The chance constraint.** The excess failure of certify is "lost although the lowest plan
completes". Every plan spends at least the lowest plan's SoC per unit of progress (its rate and
its time are the smallest), and flies at least as long, so with the same drops the lowest plan's
failure implies every policy's: P(excess) = P(fail) − P(fail_0) exactly. The constrained problem

    max E[Q̄_N 1{complete}]   s.t.   P(fail) − P(fail_0) <= ε (1 − P(fail_0))

(the rate over the worlds the lowest plan completes, as certify counts it) is solved through its
Lagrangian: for a multiplier μ >= 0 the unconstrained MDP with terminal reward Q̄ + μ on
completion (0 when lost) gives V_μ = E[Q̄ 1{c}] + μ P(c). The smallest μ whose optimal policy
meets the constraint is found by bisection (:func:`SolveConstrained`); the policy is
deterministic (a randomised mix of the two policies around it could reach the constraint exactly
and do a little better: its value is bracketed by the two).

**Discretisation.** m on a uniform grid of step Δm from 0 (below it: lost), T on n_T nodes per
stage spanning the times reachable there, Q̄ on n_Q nodes over [0, 1]; continuation values are
interpolated (linear in each coordinate, separably), and a state whose m falls below 0 is lost
exactly. Drop sizes are rounded up to the grid of m (conservative), and more than
:data:`MAX_DROPS_PER_STAGE` drops in a stage count as a failure (conservative; their probability
is printed by :meth:`MissionMdp.Describe`). The error is not bounded in closed form: the report
shows the value under a refinement of (N, Δm, n_T, n_Q) shrinking
(``benchmarks/bench_mdp.py --refine``).
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.planning.risk import PoissonPmf

__all__ = [
    "MAX_DROPS_PER_STAGE",
    "MdpGrid",
    "MdpSolution",
    "MissionMdp",
    "MissionMdpFromStep",
    "MissionMdpNow",
    "Solve",
    "SEARCH_GRID",
    "SolveConstrained",
]

MAX_DROPS_PER_STAGE = 2
"""Drops per stage the MDP enumerates; more count as a failure (conservative)."""


@dc.dataclass(frozen=True)
class MdpGrid:
    """The discretisation of :class:`MissionMdp`."""

    stages: int = 20
    """N, progress stages (decision epochs) over the survey."""
    margin_step: float = 0.01
    """Δm [-], the step of the margin grid."""
    time_nodes: int = 9
    """n_T, nodes of the time flown per stage."""
    quality_nodes: int = 41
    """n_Q, nodes of the quality so far over [0, 1]."""

    def __post_init__(self):
        for name, low in (("stages", 1), ("time_nodes", 2), ("quality_nodes", 2)):
            value = getattr(self, name)
            if not isinstance(value, int) or value < low:
                raise ValueError(f"MdpGrid.{name}: must be an integer >= {low}, got {value!r}")
        if not (math.isfinite(self.margin_step) and 0.0 < self.margin_step <= 0.5):
            raise ValueError(f"MdpGrid.margin_step: must be in (0, 0.5], got {self.margin_step}")


@dc.dataclass(frozen=True)
class MissionMdp:
    """The mission under the planner's model at take-off (see the module docstring).

    Args:
        times: t_s [s] (S,), ascending: the survey time from take-off of each staircase step.
        quality: J_sk [-] (S, K): the quality of step s's best c1 with computation row k.
        rates: r_k [1/s] (K,): the margin each row spends per second (> 0).
        margin: m_0 [-]: the margin at take-off (SoC − b_res).
        flown_time: T_w [s]: the time flown before take-off (the warm-up), > 0.
        flown_quality: Q̄_w [-]: the quality of the warm-up.
        rate: λ [1/s], the drop rate.
        size_pmf: P(drop size in ((i − 1) Δm, i Δm]) for i = 0, 1, ... (rounded up to the grid).
        lowest: (s, k) of the lowest plan.
    """

    times: np.ndarray
    quality: np.ndarray
    rates: np.ndarray
    margin: float
    flown_time: float
    flown_quality: float
    rate: float
    size_pmf: np.ndarray
    lowest: tuple[int, int] = (0, 0)
    grid: MdpGrid = MdpGrid()
    path_index: tuple[int, ...] = ()
    """The index j of each step's c1 in the planner's grid (empty: not from a planner)."""

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float).reshape(-1)
        j = np.asarray(self.quality, dtype=float).reshape(t.size, -1)
        r = np.asarray(self.rates, dtype=float).reshape(-1)
        if t.size < 1 or np.any(~np.isfinite(t)) or np.any(t <= 0.0) or np.any(np.diff(t) <= 0):
            raise ValueError(f"MissionMdp.times: need ascending positive times [s], got {t}")
        if r.size != j.shape[1] or np.any(~np.isfinite(r)) or np.any(r <= 0.0):
            raise ValueError(f"MissionMdp.rates: need {j.shape[1]} positive rates, got {r}")
        if not (self.flown_time > 0.0 and 0.0 <= self.flown_quality <= 1.0):
            raise ValueError("MissionMdp: flown_time must be > 0 and flown_quality in [0, 1]")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "quality", np.clip(j, 0.0, 1.0))
        object.__setattr__(self, "rates", r)
        object.__setattr__(self, "size_pmf", np.asarray(self.size_pmf, dtype=float))

    @property
    def margin_nodes(self) -> np.ndarray:
        """The margin grid [-]: 0, Δm, ... up to the take-off margin (rounded up)."""
        step = self.grid.margin_step
        return np.arange(max(math.ceil(self.margin / step - 1e-9), 0) + 1) * step

    def TimeNodes(self, stage: int) -> np.ndarray:
        """The time-flown nodes [s] of stage n: T_w + n/N · [t_0, t_max] (one node at n = 0)."""
        n, big_n = int(stage), self.grid.stages
        lo = self.flown_time + n * self.times[0] / big_n
        hi = self.flown_time + n * self.times[-1] / big_n
        if n == 0 or hi <= lo:
            return np.array([lo])
        return np.linspace(lo, hi, self.grid.time_nodes)

    @property
    def quality_nodes(self) -> np.ndarray:
        return np.linspace(0.0, 1.0, self.grid.quality_nodes)

    def DropKernel(self, exposure: float) -> np.ndarray:
        """The probability that the drops in ``exposure`` [s] total i Δm (i = 0, 1, ...; the
        sizes rounded up), for up to :data:`MAX_DROPS_PER_STAGE` drops (the rest is missing
        mass: a failure)."""
        weights = PoissonPmf(self.rate * float(exposure), MAX_DROPS_PER_STAGE)
        kernel = np.zeros(1 + MAX_DROPS_PER_STAGE * (self.size_pmf.size - 1))
        conv = np.array([1.0])
        for weight in weights:
            kernel[: conv.size] += weight * conv
            conv = np.convolve(conv, self.size_pmf)
        return kernel

    def Regridded(self, grid: MdpGrid) -> "MissionMdp":
        """The same mission on another grid whose Δm is a whole multiple of this one's (the
        sizes rounded up to it)."""
        ratio = grid.margin_step / self.grid.margin_step
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"MdpGrid.margin_step: must be a whole multiple of {self.grid.margin_step:g}, "
                f"got {grid.margin_step:g}"
            )
        bins = np.ceil(np.arange(self.size_pmf.size) / round(ratio) - 1e-9).astype(int)
        pmf = np.bincount(bins, weights=self.size_pmf)
        return dc.replace(self, size_pmf=pmf, grid=grid)

    def Describe(self) -> str:
        """One line: the steps, the rows, the margin and the grid."""
        g = self.grid
        miss = 1.0 - float(np.sum(self.DropKernel(self.times[-1] / g.stages)))
        return (
            f"{self.times.size} steps of {self.times[0]:.0f}-{self.times[-1]:.0f} s, "
            f"{self.rates.size} computation rows, margin {self.margin:.3f}, N = {g.stages}, "
            f"Δm = {g.margin_step:g}, n_T = {g.time_nodes}, n_Q = {g.quality_nodes}; "
            f"P(> {MAX_DROPS_PER_STAGE} drops in a stage) <= {miss:.1e}"
        )


def _Positions(nodes: np.ndarray, x: np.ndarray):
    """(lower index, weight of the upper node) of ``x`` on ascending ``nodes`` (clamped)."""
    if nodes.size == 1:
        return np.zeros(np.shape(x), dtype=int), np.zeros(np.shape(x))
    x = np.clip(x, nodes[0], nodes[-1])
    i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    w = (x - nodes[i]) / (nodes[i + 1] - nodes[i])
    return i, w


def _AlongTime(table, time_nodes, times):
    """``table`` (n_m, n_T, n_Q, 2) at the times (B,) [s]: (n_m, B, n_Q, 2), linear."""
    i, w = _Positions(time_nodes, np.asarray(times, dtype=float))
    upper = np.minimum(i + 1, time_nodes.size - 1)
    w = w[None, :, None, None]
    return table[:, i] * (1.0 - w) + table[:, upper] * w


def _AlongQuality(table, quality_nodes, qualities):
    """``table`` (n_m, B, n_Q, 2) at the qualities (B, C) of each time: (n_m, B, C, 2)."""
    i, w = _Positions(quality_nodes, np.asarray(qualities, dtype=float))
    rows = np.arange(table.shape[1])[:, None]
    w = w[None, :, :, None]
    return table[:, rows, i] * (1.0 - w) + table[:, rows, i + 1] * w


def _AlongMargin(table, margin_step, margins):
    """``table`` (n_m, ...) at the margins (A,) [-]: (A, ...), linear; below 0 lost (0)."""
    x = np.asarray(margins, dtype=float) / margin_step
    lost = x < -1e-9
    top = table.shape[0] - 1
    x = np.clip(x, 0.0, top)
    i = np.minimum(np.floor(x + 1e-9).astype(int), top)
    f = np.clip(x - i, 0.0, 1.0)[(slice(None),) + (None,) * (table.ndim - 1)]
    out = table[i] * (1.0 - f) + table[np.minimum(i + 1, top)] * f
    out[lost] = 0.0
    return out


def _AfterDrops(table, kernel):
    """E over the drops of a stage: Σ_i kernel_i · table[m − i Δm] (below 0: lost)."""
    out = kernel[0] * table
    for i in range(1, min(kernel.size, table.shape[0])):
        if kernel[i] > 0.0:
            out[i:] += kernel[i] * table[:-i]
    return out


def _Flown(mdp, flown, quality, s, dt):
    """(time flown [s], quality so far [-] per row k) after flying step s for ``dt`` [s] from
    the time ``flown`` [s] (any shape) and ``quality`` (same shape): shapes (…) and (…, K)."""
    flown = np.asarray(flown, dtype=float)
    after = flown + dt
    q = np.asarray(quality, dtype=float)[..., None] * flown[..., None] + mdp.quality[s] * dt
    return after, q / after[..., None]


@dc.dataclass
class MdpSolution:
    """A solved :class:`MissionMdp` for the multiplier μ."""

    mdp: MissionMdp
    penalty: float
    """μ [-]."""
    tables: list
    """Per stage n = 0..N: (n_m, n_T, n_Q, 2) of (V_μ, P(complete)) under the policy."""
    actions: list
    """Per stage n = 0..N − 1: (n_m, n_T, n_Q) of the chosen action index s·K + k."""
    _after: dict = dc.field(default_factory=dict, repr=False)

    def AfterDrops(self, stage: int, s: int) -> np.ndarray:
        """The table of stage ``stage`` averaged over the drops of a stage flown at step s
        (kept)."""
        key = (int(stage), int(s))
        if key not in self._after:
            kernel = self.mdp.DropKernel(self.mdp.times[s] / self.mdp.grid.stages)
            self._after[key] = _AfterDrops(self.tables[key[0]], kernel)
        return self._after[key]

    def StartValues(self) -> tuple[float, float]:
        """(E[Q̄ 1{complete}], P(complete)) from take-off."""
        mdp = self.mdp
        v = _AlongTime(self.tables[0], mdp.TimeNodes(0), [mdp.flown_time])
        v = _AlongQuality(v, mdp.quality_nodes, [[mdp.flown_quality]])
        v = _AlongMargin(v, mdp.grid.margin_step, [mdp.margin])[0, 0, 0]
        return float(v[0] - self.penalty * v[1]), float(v[1])

    def StartActionValues(self, shortest: float = 0.0) -> np.ndarray:
        """(V_μ, P(complete)) (S, K, 2) of flying each action (s, k) from take-off for the first
        stage (t_s / N seconds, at least ``shortest`` [s]), then optimally. The drops on the way
        are those of a whole stage (conservative when ``shortest`` lengthens it)."""
        mdp = self.mdp
        exposures = np.maximum(mdp.times / mdp.grid.stages, float(shortest))
        flown, quality = np.array([mdp.flown_time]), np.array([mdp.flown_quality])
        out = np.zeros(mdp.quality.shape + (2,))
        for s, dt in enumerate(exposures):
            t_new, q_new = _Flown(mdp, flown, quality, s, dt)
            v = _AlongTime(self.AfterDrops(1, s), mdp.TimeNodes(1), t_new)
            v = _AlongQuality(v, mdp.quality_nodes, q_new)[:, 0]  # (n_m, K, 2)
            for k in range(mdp.rates.size):
                out[s, k] = _AlongMargin(
                    v[:, k], mdp.grid.margin_step, [mdp.margin - mdp.rates[k] * dt]
                )[0]
        return out


def Solve(mdp: MissionMdp, penalty: float, only=None) -> MdpSolution:
    """The optimal policy of ``mdp`` for the multiplier μ = ``penalty`` by backward induction
    (``only``: the one action (s, k) allowed, e.g. the lowest plan, to price a fixed policy).
    Ties go to the first action in the order (s, k) = (0, 0), (0, 1), ..."""
    g = mdp.grid
    m_nodes, q_nodes = mdp.margin_nodes, mdp.quality_nodes
    big_n, rows = g.stages, mdp.rates.size
    last = np.zeros((m_nodes.size, mdp.TimeNodes(big_n).size, q_nodes.size, 2))
    last[..., 0] = q_nodes[None, None, :] + float(penalty)
    last[..., 1] = 1.0
    solution = MdpSolution(mdp, float(penalty), [last], [])
    allowed = {(s, k) for s in range(mdp.times.size) for k in range(rows)}
    if only is not None:
        allowed = {tuple(only)}
    for n in range(big_n - 1, -1, -1):
        t_here = mdp.TimeNodes(n)
        best = np.full((m_nodes.size, t_here.size, q_nodes.size, 2), -np.inf)
        choice = np.zeros(best.shape[:3], dtype=int)
        for s in sorted({a[0] for a in allowed}):
            dt = mdp.times[s] / big_n
            kernel = mdp.DropKernel(dt)
            w = _AfterDrops(solution.tables[0], kernel)
            t_new, q_new = _Flown(mdp, t_here[:, None], q_nodes[None, :], s, dt)
            v = _AlongTime(w, mdp.TimeNodes(n + 1), t_new[:, 0])
            for k in range(rows):
                if (s, k) not in allowed:
                    continue
                value = _AlongQuality(v, q_nodes, q_new[..., k])
                value = _AlongMargin(value, g.margin_step, m_nodes - mdp.rates[k] * dt)
                better = value[..., 0] > best[..., 0] + 1e-12
                best[better] = value[better]
                choice[better] = s * rows + k
        solution.tables.insert(0, best)
        solution.actions.insert(0, choice)
    return solution


SEARCH_GRID = MdpGrid(stages=10, margin_step=0.02, time_nodes=5, quality_nodes=21)
"""The coarse grid :func:`SolveConstrained` searches the multiplier on."""


def SolveConstrained(
    mdp: MissionMdp,
    eps: float,
    *,
    iterations: int = 9,
    largest_penalty: float = 100.0,
    search: MdpGrid | None = SEARCH_GRID,
) -> tuple[MdpSolution, dict]:
    """The best policy with P(fail) − P(fail_0) <= ε (1 − P(fail_0)) (the module docstring):
    the smallest multiplier μ in [0, ``largest_penalty``] that meets it, by bisection on log μ.
    With ``search`` (a grid whose Δm is a multiple of the mdp's), the bisection runs on that
    coarser grid, and μ is then doubled on the mdp's own grid until the constraint holds there
    (the policy and figures are always the mdp's own). Returns the solution and its figures
    (quality, completion, the lowest plan's, the excess, μ)."""
    lowest = Solve(mdp, 0.0, only=tuple(mdp.lowest))
    complete_0 = lowest.StartValues()[1]
    allowed = (1.0 - complete_0) + float(eps) * complete_0

    def Meets(solution):
        return 1.0 - solution.StartValues()[1] <= allowed + 1e-12

    solution = Solve(mdp, 0.0)
    if not Meets(solution):
        coarse = mdp
        if search is not None and search.margin_step >= mdp.grid.margin_step:
            coarse = mdp.Regridded(search)
        penalty = _SmallestPenalty(coarse, float(eps), iterations, largest_penalty)
        solution = Solve(mdp, penalty)
        while not Meets(solution) and penalty < largest_penalty:
            penalty = min(2.0 * penalty, float(largest_penalty))
            solution = Solve(mdp, penalty)
    quality, complete = solution.StartValues()
    excess = max(0.0, complete_0 - complete)
    figures = {
        "penalty": solution.penalty,
        "quality": quality,
        "completion": complete,
        "lowest_completion": complete_0,
        "excess": excess,
        "excess_rate": excess / complete_0 if complete_0 > 0 else 0.0,
    }
    return solution, figures


def _SmallestPenalty(mdp, eps, iterations, largest_penalty) -> float:
    """The smallest μ (to a factor (largest/1e-3)^(2^-iterations)) whose policy meets the
    constraint on ``mdp``; ``largest_penalty`` if none below it does."""
    complete_0 = Solve(mdp, 0.0, only=tuple(mdp.lowest)).StartValues()[1]
    allowed = (1.0 - complete_0) + eps * complete_0
    lo, hi = 1e-3, float(largest_penalty)
    if 1.0 - Solve(mdp, lo).StartValues()[1] <= allowed + 1e-12:
        return lo
    for _ in range(int(iterations)):
        mid = math.sqrt(lo * hi)
        if 1.0 - Solve(mdp, mid).StartValues()[1] <= allowed + 1e-12:
            hi = mid
        else:
            lo = mid
    return hi


def MissionMdpFromStep(step, observation, grid: MdpGrid = MdpGrid()) -> MissionMdp | None:
    """The :class:`MissionMdp` of a take-off planner step (a
    :class:`~eaplan_drake.planning.mpc.MissionStep` of a problem with a risk reserve, its
    remaining times read by the staircase's steps) and its observation; None when the lowest plan
    keeps no margin or cannot be priced."""
    pb = step.problem
    t = np.asarray(step.t_rem, dtype=float)
    usable = ~step.prediction.beyond & (t > 0.0)
    if not usable[0]:
        return None
    tops = {}
    for j in np.flatnonzero(usable):  # the largest c1 of each step
        tops[round(float(t[j]), 9)] = int(j)
    times = np.array(sorted(tops))
    path_index = [tops[v] for v in sorted(tops)]
    t_low = float(t[0])
    soc0 = float(observation.soc)
    uncertainty = float(step.margin.rate)
    rates = np.array(
        [(soc0 - float(step.SocAt(float(g), t_low))) / t_low + uncertainty
         for g in pb.candidate_power]
    )  # fmt: skip
    if not np.all(np.isfinite(rates) & (rates > 0.0)):
        return None
    quality = np.array([[pb.Quality(j, u2) for u2 in pb.candidate_u2] for j in path_index])
    margin = soc0 - pb.reserve_soc
    if margin < 0.0:
        return None
    model = pb.risk_reserve.stated_model
    step_m = grid.margin_step
    edges = np.arange(0, math.ceil(model.sizes.upper / step_m - 1e-9) + 1) * step_m
    tail = model.sizes.sum_tail(1, edges)[:, 1]  # P(X > i Δm)
    pmf = np.concatenate(([1.0 - tail[0]], -np.diff(tail)))
    c1_now = float(observation.path_parameter)
    u1_now = float(np.interp(c1_now, pb.grid, pb.u1))
    u2_now = pb.RowValues(observation.computation_parameters)[1]
    w1, w2 = pb.weights
    return MissionMdp(
        times=times,
        quality=quality,
        rates=rates,
        margin=margin,
        flown_time=max(float(observation.time), 1e-9),
        flown_quality=float(w1 * u1_now + w2 * u2_now),
        rate=float(model.rate),
        size_pmf=np.clip(pmf, 0.0, None),
        lowest=(0, int(pb.lowest_candidate)),
        grid=grid,
        path_index=tuple(path_index),
    )


def MissionMdpNow(takeoff: MissionMdp, remaining, margin, flown, quality, grid: MdpGrid):
    """The mission from a state in flight, modelled afresh: the take-off MDP's rows, rates and
    faults, with the route's own remaining times ``remaining`` [s] (one per take-off step) as the
    new staircase, the ``margin`` [-], the time ``flown`` [s] and the ``quality`` so far [-], on
    ``grid`` (Δm a whole multiple of the take-off grid's). Steps with no time left are dropped;
    of steps with the same time left, the one with the larger c1 is kept. Returns (the MDP, the
    take-off index of each of its steps), or None when no margin or no step is left."""
    left = np.asarray(remaining, dtype=float)
    if not (margin > 0.0 and flown > 0.0 and left.size and left[0] > 0.0):
        return None
    kept: dict = {}
    for s in np.flatnonzero(left > 0.0):
        kept[round(float(left[s]), 6)] = int(s)  # ascending s: the largest c1 wins a tie
    times = sorted(kept)
    index = tuple(kept[t] for t in times)
    pmf = takeoff.Regridded(grid).size_pmf if grid != takeoff.grid else takeoff.size_pmf
    mdp = MissionMdp(
        times=np.array(times),
        quality=takeoff.quality[list(index)],
        rates=takeoff.rates,
        margin=float(margin),
        flown_time=float(flown),
        flown_quality=min(max(float(quality), 0.0), 1.0),
        rate=takeoff.rate,
        size_pmf=pmf,
        lowest=(0, takeoff.lowest[1]),
        grid=grid,
        path_index=tuple(takeoff.path_index[i] for i in index) if takeoff.path_index else (),
    )
    return mdp, index
