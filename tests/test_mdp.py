"""The mission MDP (eaplan_drake/planning/mdp.py) against exhaustive enumeration on a tiny
instance whose every transition lands on the grids, and the ``mdp`` policy in a flight."""

import itertools
import math

import numpy as np
import pytest

from eaplan_drake.planning import mdp as opt

# Two stages; steps of 10 and 20 s (δt = 5, 10 s); rows spending 0.01 and 0.02 per second, so
# every spend is a multiple of Δm = 0.05; the warm-up of 5 s at quality 0 and the qualities
# chosen so that the quality after one stage is a multiple of 1/6 (the 7 quality nodes).
TINY = dict(
    times=np.array([10.0, 20.0]),
    quality=np.array([[1 / 3, 2 / 3], [1 / 2, 3 / 4]]),
    rates=np.array([0.01, 0.02]),
    margin=0.3,
    flown_time=5.0,
    flown_quality=0.0,
    rate=0.03,
    size_pmf=np.array([0.0, 0.5, 0.5]),  # sizes 0.05 or 0.10
    lowest=(0, 0),
    grid=opt.MdpGrid(stages=2, margin_step=0.05, time_nodes=3, quality_nodes=7),
)
ACTIONS = [(s, k) for s in range(2) for k in range(2)]


def Drops(mdp, exposure):
    """[(probability, total size)] of the drops in ``exposure`` (at most two, as the MDP)."""
    mean = mdp.rate * exposure
    sizes = [(p, 0.05 * i) for i, p in enumerate(mdp.size_pmf) if p > 0.0]
    out = [(math.exp(-mean), 0.0)]
    for count in (1, 2):
        weight = math.exp(-mean) * mean**count / math.factorial(count)
        for combo in itertools.product(sizes, repeat=count):
            out.append((weight * math.prod(p for p, _ in combo), sum(x for _, x in combo)))
    return out


def Outcomes(mdp, policy):
    """[(probability, quality, complete)] of a policy: a function (stage, history) -> action,
    enumerated exactly (the histories are the drop totals of the stages flown)."""
    results = []

    def Fly(stage, margin, flown, area, history, prob):
        if margin < -1e-12:
            results.append((prob, 0.0, False))
            return
        if stage == mdp.grid.stages:
            results.append((prob, area / flown, True))
            return
        s, k = policy(stage, history)
        dt = mdp.times[s] / mdp.grid.stages
        spent = margin - mdp.rates[k] * dt
        for p, drop in Drops(mdp, dt):
            Fly(
                stage + 1,
                spent - drop,
                flown + dt,
                area + mdp.quality[s, k] * dt,
                history + (round(drop, 9),),
                prob * p,
            )

    Fly(0, mdp.margin, mdp.flown_time, mdp.flown_quality * mdp.flown_time, (), 1.0)
    return results


def Figures(outcomes):
    """(E[Q 1{complete}], P(complete), the probability not enumerated: > 2 drops a stage)."""
    return (
        sum(p * q for p, q, _ in outcomes),
        sum(p for p, _, c in outcomes if c),
        1.0 - sum(p for p, _, _ in outcomes),
    )


def AllPolicies(mdp):
    """Every deterministic policy of the tiny instance: a first action and an action for each
    drop total of the first stage."""
    totals = sorted({round(x, 9) for s in range(2) for _, x in Drops(mdp, mdp.times[s] / 2)})
    for first in ACTIONS:
        for later in itertools.product(ACTIONS, repeat=len(totals)):
            table = dict(zip(totals, later, strict=True))
            yield lambda stage, history, f=first, t=table: f if stage == 0 else t[history[0]]


@pytest.fixture(scope="module")
def tiny():
    return opt.MissionMdp(**TINY)


@pytest.fixture(scope="module")
def enumerated(tiny):
    return [Figures(Outcomes(tiny, policy)) for policy in AllPolicies(tiny)]


@pytest.mark.parametrize("penalty", [0.0, 0.5, 5.0])
def test_the_dynamic_programme_equals_the_best_of_every_policy_enumerated(
    tiny, enumerated, penalty
):
    best = max(q + penalty * c for q, c, _ in enumerated)
    quality, complete = opt.Solve(tiny, penalty).StartValues()
    assert quality + penalty * complete == pytest.approx(best, abs=1e-12)
    # and it is the value of a policy that exists
    assert any(
        q == pytest.approx(quality, abs=1e-12) and c == pytest.approx(complete, abs=1e-12)
        for q, c, _ in enumerated
    )


def test_a_fixed_plan_is_priced_as_enumerated(tiny):
    for action in ACTIONS:
        expected = Figures(Outcomes(tiny, lambda stage, history, a=action: a))
        quality, complete = opt.Solve(tiny, 0.0, only=action).StartValues()
        assert (quality, complete) == pytest.approx(expected[:2], abs=1e-12)


@pytest.mark.parametrize("eps", [0.0, 0.01, 0.05, 0.5])
def test_the_constrained_policy_keeps_the_excess_and_no_policy_within_it_is_much_better(
    tiny, enumerated, eps
):
    _, figures = opt.SolveConstrained(tiny, eps, iterations=30, search=None)
    complete_0 = figures["lowest_completion"]
    lowest = Figures(Outcomes(tiny, lambda stage, history: (0, 0)))
    assert complete_0 == pytest.approx(lowest[1], abs=1e-12)
    allowed = (1.0 - complete_0) + eps * complete_0
    assert 1.0 - figures["completion"] <= allowed + 1e-12
    within = [q for q, c, _ in enumerated if 1.0 - c <= allowed + 1e-12]
    assert figures["quality"] <= max(within) + 1e-12
    # a deterministic Lagrangian policy: at most the gap to the next policy it passed over
    assert figures["quality"] >= max(within) - 0.05


def test_no_policy_completes_more_often_than_the_lowest_plan(tiny, enumerated):
    """P(excess) = P(fail) − P(fail_0) needs the lowest plan's failures to be every policy's:
    then no policy completes more often than it."""
    lowest = Figures(Outcomes(tiny, lambda stage, history: (0, 0)))
    assert max(c for _, c, _ in enumerated) == pytest.approx(lowest[1], abs=1e-12)


def test_a_finer_grid_changes_the_value_less():
    """The discretisation's error shrinks: on an instance whose spends fall off the grids (the
    drop sizes 0.04, 0.08 and 0.12 on every grid), halving Δm and the node spacing moves the
    value less each time (measured: 0.0077, 0.0034, 0.0014)."""
    smooth = dict(TINY, margin=0.37, rates=np.array([0.0113, 0.0171]), rate=0.02)
    values = []
    for step, nodes in ((0.04, 5), (0.02, 9), (0.01, 17), (0.005, 33)):
        pmf = np.zeros(int(round(0.12 / step)) + 1)
        for size in (0.04, 0.08, 0.12):
            pmf[int(round(size / step))] += 1.0 / 3.0
        grid = opt.MdpGrid(stages=4, margin_step=step, time_nodes=nodes, quality_nodes=2 * nodes)
        mdp = opt.MissionMdp(**dict(smooth, size_pmf=pmf, grid=grid))
        values.append(opt.Solve(mdp, 1.0).StartValues()[0])
    moves = np.abs(np.diff(values))
    assert moves[1] < moves[0] and moves[2] < moves[1] and moves[2] < 0.002


def test_bad_grids_and_models_are_one_line_naming_the_field():
    with pytest.raises(ValueError, match=r"MdpGrid.stages: must be an integer >= 1"):
        opt.MdpGrid(stages=0)
    with pytest.raises(ValueError, match=r"MdpGrid.margin_step: must be in \(0, 0.5\]"):
        opt.MdpGrid(margin_step=float("nan"))
    with pytest.raises(ValueError, match=r"MissionMdp.times: need ascending positive"):
        opt.MissionMdp(**dict(TINY, times=np.array([20.0, 10.0])))
    with pytest.raises(ValueError, match=r"MissionMdp.rates: need 2 positive rates"):
        opt.MissionMdp(**dict(TINY, rates=np.array([0.01, -1.0])))


def test_the_mdp_policy_flies_the_survey_within_its_model(monkeypatch):
    """``planner.policy: mdp`` solves at take-off (a coarse grid here), then re-plans: it
    completes the fault-free survey above the reserve, its take-off solve keeps the excess within
    ε, it flies only the steps' largest c1 after the warm-up, and it does better than the pilot's
    static plan on the same world (0.474)."""
    from eaplan_drake import registry
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.planning import policies
    from eaplan_drake.simulation import Simulate

    made = []

    def Coarse(planner, table, order, battery, *, path_parameter_grid, integer, **_):
        problem = policies.MissionProblem(
            planner, table, order, battery, path_parameter_grid, integer
        )
        made.append(policies.MdpPolicy(problem, opt.MdpGrid(10, 0.02, 5, 21)))
        return made[-1]

    monkeypatch.setitem(registry.POLICIES._entries, "mdp", Coarse)
    scenario = LoadNamedScenario("survey")
    scenario.planner.policy = "mdp"
    log = Simulate(scenario)
    assert log.summary["completed"]
    assert log.summary["final_soc"] > scenario.battery.reserve_soc
    assert len(made) == 1
    figures = made[0].figures
    assert figures["excess_rate"] <= scenario.planner.risk + 1e-9
    assert 0.0 < figures["quality"] <= 1.0
    ((takeoff, solution),) = made[0]._solutions.items()
    tops = {float(made[0].problem.grid[j]) for j in solution.mdp.path_index}
    after = log.times > takeoff
    assert set(np.unique(log["path_parameters"][after, 0]).tolist()) <= tops
    assert log.summary["quality"] > 0.474


def test_a_coarser_grid_rounds_the_sizes_up_and_keeps_their_mass(tiny):
    coarse = tiny.Regridded(opt.MdpGrid(stages=2, margin_step=0.1, time_nodes=3, quality_nodes=7))
    # sizes 0.05 and 0.10 both round up to one step of 0.1
    assert coarse.size_pmf.tolist() == pytest.approx([0.0, 1.0])
    with pytest.raises(ValueError, match=r"MdpGrid.margin_step: must be a whole multiple of 0.05"):
        tiny.Regridded(opt.MdpGrid(margin_step=0.07))
