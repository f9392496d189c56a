"""Stratified and importance-sampled worlds (eaplan_drake.studies.sampling) and their
anytime-valid bounds and power (eaplan_drake.studies.bounds), on the synthetic stand-in whose
excess-failure rate is known in closed form (eaplan_drake.studies.standin)."""

import dataclasses as dc
import math

import numpy as np
import pytest

from eaplan_drake.params import FaultModelParams
from eaplan_drake.studies.bounds import (
    CertifyThreshold,
    LowerBound,
    PlainPower,
    SequentialDecision,
    SequentialPower,
    UpperBound,
    WorldsForPower,
)
from eaplan_drake.studies.sampling import (
    CountProbabilities,
    CrossEntropyTilt,
    DrawProposedFaults,
    DrawWindows,
    FaultProposal,
    StratifiedProposal,
    TiltedMeanSize,
    TiltedProposal,
)
from eaplan_drake.studies.standin import StandIn, StandInRate, StandInWorlds
from eaplan_drake.studies.statistics import ClopperPearsonUpper

MODEL = FaultModelParams()
STAND_IN = StandIn()
PROPOSALS = {
    "plain": None,
    "stratified": StratifiedProposal(MODEL, STAND_IN.window),
    "importance": TiltedProposal(MODEL, STAND_IN.window, rate=0.009, size_tilt=10.0),
}


def _Runs(proposal, runs, worlds, stand_in=STAND_IN, seed=1):
    rng = np.random.default_rng(seed)
    out = [StandInWorlds(rng, stand_in, proposal, worlds) for _ in range(runs)]
    return tuple(np.array([o[i] for o in out]) for i in range(3))


def test_the_stand_in_rate_is_its_closed_form():
    rho = StandInRate(STAND_IN)
    assert rho == pytest.approx(0.030, abs=5e-4)  # calibrated like the default planner
    w, e, f, n = StandInWorlds(np.random.default_rng(0), STAND_IN, None, 400_000)
    assert np.all(w == 1.0)
    sd = math.sqrt(rho * (1 - rho) / f.sum())
    assert e.sum() / f.sum() == pytest.approx(rho, abs=4 * sd)
    p = CountProbabilities(MODEL, STAND_IN.window)
    assert p.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.bincount(n, minlength=p.size)[:4] / n.size == pytest.approx(p[:4], abs=3e-3)


@pytest.mark.parametrize("name", ["stratified", "importance"])
def test_weights_are_exact_likelihood_ratios(name):
    proposal = PROPOSALS[name]
    rng = np.random.default_rng(2)
    n, sizes, w = DrawWindows(rng, MODEL, proposal, 400_000)
    assert w.max() <= proposal.weight_bound
    assert w.mean() == pytest.approx(1.0, abs=4 * w.std() / math.sqrt(w.size))  # E_q[W] = 1
    # E_q[W g] = E_p[g] for the stand-in's events, whose p-probabilities are exact
    s = dc.replace(STAND_IN, other_loss=0.0)
    total = np.nansum(sizes, axis=1)
    for margin in (0.15, 0.25, 0.3):
        exact = 1.0 - StandInRate(dc.replace(s, policy_margin=margin, lowest_margin=1.0))
        g = w * (total <= margin)
        assert g.mean() == pytest.approx(exact, abs=4 * g.std() / math.sqrt(g.size))
    assert np.mean(n >= 2) > 1.2 * (1.0 - CountProbabilities(MODEL, STAND_IN.window)[:2].sum())


@pytest.mark.parametrize("name", ["plain", "stratified", "importance"])
def test_the_upper_bound_covers_the_true_rate_in_95_percent_of_1000_runs(name):
    w, e, f = _Runs(PROPOSALS[name], 1000, 300)
    bound = 1.0 if name == "plain" else PROPOSALS[name].weight_bound
    upper = UpperBound(w, e, f, bound, eps=0.05)
    rho = StandInRate(STAND_IN)
    assert np.mean(upper >= rho) >= 0.95
    assert np.median(upper) < 0.1  # and it is informative
    lower = LowerBound(w, e, f, bound, eps=0.05)
    assert np.mean(lower <= rho) >= 0.95 and np.all(lower <= upper)


@pytest.mark.parametrize("name", ["plain", "importance"])
def test_the_sequential_verdict_keeps_its_level_under_optional_stopping(name):
    # a rate just above ε: a user who stops at the first world where the bound is under ε
    # wrongly certifies at most 5 % of the time, over 1500 worlds
    s = dc.replace(STAND_IN, policy_margin=0.2261)
    rho = StandInRate(s)
    assert 0.05 < rho < 0.052
    w, e, f = _Runs(PROPOSALS[name], 1000, 1500, s, seed=3)
    bound = 1.0 if name == "plain" else PROPOSALS[name].weight_bound
    certified, refuted = SequentialDecision(w, e, f, bound, eps=0.05)
    assert np.mean(certified > 0) <= 0.05
    # counting with Clopper–Pearson at every 50 worlds and stopping when it first passes is not
    peeks = [
        any(
            ClopperPearsonUpper(int(ek[:t].sum()), int(fk[:t].sum())) <= 0.05
            for t in range(50, 1501, 50)
        )
        for ek, fk in zip(e[:200], f[:200], strict=True)
    ]
    assert name != "plain" or np.mean(peeks) > 0.05


def test_plain_power_is_the_chance_that_counting_certifies():
    assert CertifyThreshold(59, 0.05) == 0 and CertifyThreshold(58, 0.05) == -1
    k = CertifyThreshold(300, 0.05)
    assert ClopperPearsonUpper(k, 300) <= 0.05 < ClopperPearsonUpper(k + 1, 300)
    rng = np.random.default_rng(4)
    feasible = rng.binomial(300, 0.96, size=20_000)
    lost = rng.binomial(feasible, 0.03)
    thresholds = {n: CertifyThreshold(int(n), 0.05) for n in np.unique(feasible)}
    for n in list(thresholds)[::10]:  # the threshold is Clopper–Pearson's
        k = thresholds[n]
        assert ClopperPearsonUpper(k, int(n)) <= 0.05 < ClopperPearsonUpper(k + 1, int(n))
    passed = [a <= thresholds[b] for a, b in zip(lost, feasible, strict=True)]
    power = PlainPower(0.03, 0.96, 300, 0.05)
    assert power == pytest.approx(np.mean(passed), abs=0.015)
    assert PlainPower(0.0, 1.0, 59, 0.05) == pytest.approx(1.0)
    n = WorldsForPower(lambda n: PlainPower(0.03, 1.0, n, 0.05), 0.9)
    assert PlainPower(0.03, 1.0, n, 0.05) >= 0.9 > PlainPower(0.03, 1.0, n - 1, 0.05)
    assert WorldsForPower(lambda n: 0.0, 0.9, largest=1000) is None


def test_sequential_power_matches_repeated_runs():
    w, e, f = _Runs(PROPOSALS["importance"], 400, 300, seed=5)
    certified, _ = SequentialDecision(w, e, f, 2.0, eps=0.05)
    pilot = _Runs(PROPOSALS["importance"], 1, 2000, seed=6)
    power = SequentialPower(*(a[0] for a in pilot), 2.0, 0.05, 300, runs=400)
    assert np.all(np.diff(power) >= 0)
    assert power[-1] == pytest.approx(np.mean(certified > 0), abs=0.1)


def test_cross_entropy_tilt_follows_the_elite_worlds():
    rng = np.random.default_rng(7)
    n, sizes, w = DrawWindows(rng, MODEL, FaultProposal(window=330.0, mix=1.0), 5000)
    total = np.nansum(sizes, axis=1)
    elite = total > np.quantile(total, 0.9)
    mean = np.where(n > 0, total / np.maximum(n, 1), np.nan)
    rate, theta = CrossEntropyTilt(MODEL, 330.0, n, mean, w, elite)
    assert rate * 330.0 == pytest.approx(n[elite].mean(), rel=1e-9)
    per_drop = np.sum(total[elite]) / np.sum(n[elite])
    assert TiltedMeanSize(MODEL, theta) == pytest.approx(per_drop, rel=1e-6)
    assert theta > 0.0 and MODEL.rate <= rate <= 5 * MODEL.rate
    assert CrossEntropyTilt(MODEL, 330.0, n, mean, w, np.zeros(n.size, bool)) == (MODEL.rate, 0.0)
    small = total < np.quantile(total, 0.2)  # elite worlds with fewer, smaller drops: no tilt
    assert CrossEntropyTilt(MODEL, 330.0, n, mean, w, small & (n > 0)) == (MODEL.rate, 0.0)
    exp = FaultModelParams(sizes="exponential", size_mean=0.05)
    xs = DrawWindows(rng, exp, FaultProposal(330.0, 0.0, (0.0, 1.0), 8.0), 20_000)[1]
    assert np.nanmean(xs) == pytest.approx(TiltedMeanSize(exp, 8.0), rel=0.03)
    emp = FaultModelParams(sizes="empirical", size_values=[0.05, 0.1])
    xs = DrawWindows(rng, emp, FaultProposal(330.0, 0.0, (0.0, 1.0), 20.0), 20_000)[1]
    assert np.nanmean(xs) == pytest.approx(TiltedMeanSize(emp, 20.0), abs=0.002)


def test_a_proposed_world_has_its_window_drops_first_and_the_declared_ones_after():
    proposal = TiltedProposal(MODEL, 300.0, rate=0.009, size_tilt=10.0)
    faults, weight, stratum = DrawProposedFaults(np.random.default_rng(8), MODEL, 1500.0, proposal)
    assert sum(f.time <= 300.0 for f in faults) == stratum
    assert 0.0 < weight <= proposal.weight_bound
    with pytest.raises(ValueError, match="window"):
        proposal.Validate(MODEL, 200.0)
    with pytest.raises(ValueError, match="mix"):
        dc.replace(proposal, mix=0.0).Validate(MODEL, 1500.0)
