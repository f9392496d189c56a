"""Tests of eaplan_drake.planning.belief: closed forms, the point-rate limit, seeded Monte Carlo."""

import math
from fractions import Fraction

import numpy as np
import pytest

from eaplan_drake.planning.belief import (
    PRIOR_DROPS,
    PRIOR_RATE,
    SIZE_RESOLUTION,
    BeliefDropTail,
    BeliefExcessRisk,
    BeliefExcessRiskBounds,
    ExponentialSizeBelief,
    FaultBelief,
    LearningSizes,
    NegativeBinomialCutoff,
    NegativeBinomialPmf,
    RateBelief,
    SaturatedSumTail,
    UpdateSizes,
)
from eaplan_drake.planning.learnt_sizes import DirichletDrops
from eaplan_drake.planning.risk import (
    EmpiricalDrops,
    ExcessRiskBounds,
    ExponentialDrops,
    FaultModel,
    PoissonPmf,
    TotalDropTail,
    UniformDrops,
)

SIZES = {
    "uniform": UniformDrops(0.02, 0.1),
    "exponential": ExponentialDrops(0.05),
    "empirical": EmpiricalDrops([0.06, 0.09, 0.06, 0.03]),
    "belief": ExponentialSizeBelief(4.0, 0.2),  # ϑ ~ Gamma(4, 0.2): Lomax sizes, mean 0.067
}


def StandardError(p, n):
    return math.sqrt(max(p * (1.0 - p), 1.0 / n) / n)


def SampleSizes(sizes, rng, shape):
    """Sizes of ``shape`` (worlds, drops); an ExponentialSizeBelief draws one ϑ per world."""
    if isinstance(sizes, UniformDrops):
        return rng.uniform(sizes.a, sizes.b, shape)
    if isinstance(sizes, ExponentialDrops):
        return rng.exponential(sizes.mean, shape)
    if isinstance(sizes, ExponentialSizeBelief):
        theta = rng.gamma(sizes.shape, 1.0 / sizes.scale, shape[0])
        return rng.exponential(1.0, shape) / theta[:, None]
    return rng.choice(np.asarray(sizes.values), shape)


def SampleWorlds(belief, horizon, worlds, rng):
    """One λ from the belief per world, then drop times (sorted, inf where none) and sizes."""
    lam = rng.gamma(belief.rate.shape, 1.0 / belief.rate.rate, worlds)
    counts = rng.poisson(lam * horizon)
    width = max(int(counts.max()), 1)
    times = rng.uniform(0.0, horizon, (worlds, width))
    times[np.arange(width) >= counts[:, None]] = np.inf
    return np.sort(times, axis=1), SampleSizes(belief.sizes, rng, (worlds, width))


# Bad inputs.


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: RateBelief(0.0, 100.0), "RateBelief.shape"),
        (lambda: RateBelief(1.0, -1.0), "RateBelief.rate"),
        (lambda: RateBelief(math.nan, 1.0), "RateBelief.shape"),
        (lambda: RateBelief.FromRecords(-1, 100.0), "drops"),
        (lambda: RateBelief.FromRecords(1.5, 100.0), "drops"),
        (lambda: RateBelief.FromRecords(1, -5.0), "flight_time"),
        (lambda: RateBelief.FromRecords(prior_rate=0.0), "prior_rate"),
        (lambda: RateBelief(1.0, 1.0).Quantile(1.0), "probability"),
        (lambda: ExponentialSizeBelief(0.0, 0.1), "ExponentialSizeBelief.shape"),
        (lambda: ExponentialSizeBelief.FromMean(1.5), "mean"),
        (lambda: ExponentialSizeBelief(2.0, 0.1).Update([0.1, math.nan]), "sizes"),
        (lambda: FaultBelief(0.003, SIZES["uniform"]), "FaultBelief.rate"),
        (lambda: FaultBelief(RateBelief(1.0, 1.0), "uniform"), "FaultBelief.sizes"),
        (lambda: UpdateSizes(EmpiricalDrops([0.1]), [0.2, math.nan]), "observed"),
        (
            lambda: FaultBelief(RateBelief(1.0, 1.0), SIZES["uniform"]).Update(60.0, [-0.1]),
            "observed",
        ),
        (lambda: NegativeBinomialPmf(0.0, 1.0, 5), "shape"),
        (lambda: NegativeBinomialPmf(1.0, [1.0, math.nan], 5), "odds"),
        (lambda: NegativeBinomialPmf(1.0, 1.0, -1), "n_max"),
        (lambda: NegativeBinomialCutoff(1.0, math.inf), "odds"),
        (lambda: NegativeBinomialCutoff(1e-6, 1e11), "odds.*too heavy"),
    ],
)
def test_bad_input_names_the_field(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_bad_arguments_of_the_tails_name_the_field():
    belief = FaultBelief(RateBelief(2.0, 500.0), SIZES["uniform"])
    with pytest.raises(ValueError, match="exposure"):
        BeliefDropTail(belief, -1.0, 0.1)
    with pytest.raises(ValueError, match="margin"):
        BeliefDropTail(belief, 10.0, math.nan)
    with pytest.raises(ValueError, match="exposure.*expected drops"):
        BeliefDropTail(belief, 1e6, 0.1)
    with pytest.raises(ValueError, match="lowest_margin"):
        BeliefExcessRisk(belief, 300.0, 0.1, 300.0, math.inf)
    with pytest.raises(ValueError, match="cells"):
        BeliefExcessRisk(belief, 300.0, 0.1, 300.0, 0.2, cells=0)


# The rate's belief.


@pytest.mark.parametrize("y", [1e-6, 0.1, 0.7, 2.0, 5.5, 30.0])
def test_gamma_cdf_closed_forms(y):
    beta = 200.0
    rate = y / beta
    assert RateBelief(1.0, beta).Cdf(rate) == pytest.approx(-math.expm1(-y), rel=1e-13, abs=1e-15)
    erlang = 1.0 - math.exp(-y) * (1.0 + y + y * y / 2.0)
    assert RateBelief(3.0, beta).Cdf(rate) == pytest.approx(erlang, rel=1e-11, abs=1e-15)
    assert RateBelief(0.5, beta).Cdf(rate) == pytest.approx(math.erf(math.sqrt(y)), rel=1e-13)
    assert RateBelief(1.0, beta).Quantile(0.3) == pytest.approx(-math.log(0.7) / beta, rel=1e-12)


@pytest.mark.parametrize("shape", [29.9, 30.0, 1e4, 1e8])
def test_gamma_cdf_keeps_its_digits_for_a_sharp_belief(shape):
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 30
    belief = RateBelief(shape, shape / 0.003)
    for k in [-4.0, -1.0, 0.0, 0.5, 2.0, 6.0]:
        rate = 0.003 * (1.0 + k / math.sqrt(shape))
        exact = float(1 - mpmath.gammainc(shape, belief.rate * rate, mpmath.inf, regularized=True))
        assert belief.Cdf(rate) == pytest.approx(exact, abs=1e-12)


def test_records_give_the_posterior_of_the_stated_prior():
    prior = RateBelief.FromRecords()
    assert prior.shape == PRIOR_DROPS == 0.5
    assert prior.mean == pytest.approx(PRIOR_RATE) and PRIOR_RATE == 0.003
    fleet = RateBelief.FromRecords(3, 36000.0)
    assert fleet == RateBelief(3.5, 0.5 / 0.003 + 36000.0)
    # the same evidence in any order and any split gives the same belief
    split = prior.Update(20000.0, 1).Update(6000.0).Update(10000.0, 2)
    assert split.shape == fleet.shape and split.rate == pytest.approx(fleet.rate, rel=1e-15)
    # quiet flight lowers the mean, a drop raises it
    assert fleet.Update(600.0).mean < fleet.mean < fleet.Update(0.0, 1).mean
    point = RateBelief.PointMass(0.004)
    assert point.mean == pytest.approx(0.004) and math.sqrt(point.variance) / point.mean < 1e-3


def test_update_is_the_conjugate_posterior():
    """Bayes' rule on a grid of λ (prior density × Poisson likelihood, normalised) has the mean and
    variance of Gamma(α + n, β + τ)."""
    prior = RateBelief(0.5, 300.0)
    tau, n = 1200.0, 4
    lam = np.linspace(1e-9, 0.05, 400_001)
    log_post = (prior.shape - 1.0) * np.log(lam) - prior.rate * lam + n * np.log(lam * tau)
    weight = np.exp(log_post - lam * tau - np.max(log_post - lam * tau))
    mean = np.sum(weight * lam) / np.sum(weight)
    variance = np.sum(weight * (lam - mean) ** 2) / np.sum(weight)
    post = prior.Update(tau, n)
    assert mean == pytest.approx(post.mean, rel=1e-6)
    assert variance == pytest.approx(post.variance, rel=1e-5)


def test_update_against_sampling():
    """λ drawn from the prior, a count drawn given λ: the λ of the draws that saw n drops have the
    posterior's mean and quantiles."""
    rng = np.random.default_rng(41)
    prior = RateBelief(0.5, 167.0)
    tau, n = 900.0, 2
    lam = rng.gamma(prior.shape, 1.0 / prior.rate, 2_000_000)
    kept = lam[rng.poisson(lam * tau) == n]
    post = prior.Update(tau, n)
    assert kept.size > 50_000
    se = math.sqrt(post.variance / kept.size)
    assert abs(np.mean(kept) - post.mean) <= 4.0 * se
    for q in [0.05, 0.5, 0.95]:
        assert abs(np.mean(kept <= post.Quantile(q)) - q) <= 4.0 * StandardError(q, kept.size)


@pytest.mark.parametrize("shape, rate", [(0.5, 166.7), (3.5, 36166.7), (40.0, 9000.0)])
def test_moments_and_quantiles_against_sampling(shape, rate):
    belief = RateBelief(shape, rate)
    rng = np.random.default_rng(7)
    lam = rng.gamma(shape, 1.0 / rate, 400_000)
    sd = math.sqrt(belief.variance)
    assert abs(np.mean(lam) - belief.mean) <= 4.0 * sd / math.sqrt(lam.size)
    assert np.var(lam) == pytest.approx(belief.variance, rel=0.05)
    for q in [0.01, 0.25, 0.5, 0.9, 0.999]:
        assert abs(np.mean(lam <= belief.Quantile(q)) - q) <= 4.0 * StandardError(q, lam.size)
        assert belief.Cdf(belief.Quantile(q)) == pytest.approx(q, rel=1e-10)


# The predictive count.


def test_negative_binomial_closed_forms():
    theta = np.array([0.0, 0.3, 2.0, 15.0])
    p = 1.0 / (1.0 + theta)
    geometric = NegativeBinomialPmf(1.0, theta, 40)
    np.testing.assert_allclose(geometric, p[:, None] * (1.0 - p[:, None]) ** np.arange(41), 1e-13)
    pmf = NegativeBinomialPmf(3.0, 0.75, 30)
    q = Fraction(3, 7)  # odds 3/4: p = 4/7
    exact = [math.comb(n + 2, n) * (1 - q) ** 3 * q**n for n in range(31)]
    np.testing.assert_allclose(pmf, [float(e) for e in exact], rtol=1e-13)
    # the Poisson limit: α → ∞ with ατ/β = Λ fixed
    Lam = 4.2
    np.testing.assert_allclose(NegativeBinomialPmf(1e11, Lam / 1e11, 40), PoissonPmf(Lam, 40), 1e-7)
    heavy = NegativeBinomialPmf(0.5, 9.0, NegativeBinomialCutoff(0.5, 9.0))
    assert 1.0 - 1e-12 <= np.sum(heavy) <= 1.0 + 1e-12


def test_predictive_count_against_sampling():
    belief = RateBelief(0.5, 167.0)
    tau = 500.0
    rng = np.random.default_rng(3)
    counts = rng.poisson(rng.gamma(belief.shape, 1.0 / belief.rate, 1_000_000) * tau)
    pmf = belief.CountPmf(tau, 12)
    for n in range(13):
        assert abs(np.mean(counts == n) - pmf[n]) <= 4.0 * StandardError(pmf[n], counts.size)
    # over-dispersed: the variance is the mean times 1 + τ/β
    assert np.sum(pmf * np.arange(13)) < belief.mean * tau


@pytest.mark.parametrize(
    "shape, odds",
    [(0.5, 0.01), (0.5, 3.0), (0.5, 30.0), (1.0, 1.0), (3.5, 0.04), (60.0, 0.05), (1e8, 3e-6)],
)
def test_cutoff_leaves_at_most_1e_12_and_is_not_wasteful(shape, odds):
    n_max = NegativeBinomialCutoff(shape, odds)
    pmf = NegativeBinomialPmf(shape, odds, 20 * n_max + 200)
    beyond = np.cumsum(pmf[::-1])[::-1]  # beyond[n] = P(N >= n), summed from the far end
    assert beyond[n_max + 1] <= 1e-12
    assert beyond[max(n_max - 3, 0)] > 1e-13
    assert NegativeBinomialCutoff(shape, 0.0) == 0


# The sizes.


def test_size_belief_closed_forms_and_point_limit():
    sizes = ExponentialSizeBelief(3.0, 0.12)
    m = np.array([-0.1, 0.0, 0.05, 0.3])
    q = sizes.sum_tail(6, m)
    np.testing.assert_allclose(q[:, 1], np.where(m < 0, 1.0, (0.12 / (0.12 + m)) ** 3), 1e-13)
    np.testing.assert_array_equal(q[:, 0], m < 0.0)
    assert sizes.mean == pytest.approx(0.06)
    assert np.all(np.diff(q, axis=1) >= 0.0)  # more sizes, more total
    # a sharp belief is the known-scale exponential
    sharp = ExponentialSizeBelief.FromMean(0.05, prior_sizes=1e8)
    np.testing.assert_allclose(
        sharp.sum_tail(8, m), ExponentialDrops(0.05).sum_tail(8, m), atol=1e-6
    )


def test_size_belief_against_sampling():
    sizes = ExponentialSizeBelief(2.5, 0.1)
    rng = np.random.default_rng(11)
    totals = np.cumsum(SampleSizes(sizes, rng, (400_000, 5)), axis=1)
    q = sizes.sum_tail(5, 0.2)
    for n in range(1, 6):
        estimate = np.mean(totals[:, n - 1] > 0.2)
        assert abs(estimate - q[n]) <= 4.0 * StandardError(q[n], totals.shape[0])


def test_size_updates():
    prior = ExponentialSizeBelief.FromMean(0.05)
    assert prior == ExponentialSizeBelief(2.0, 0.1)
    assert UpdateSizes(prior, [0.2, 0.25]) == ExponentialSizeBelief(4.0, 0.55)
    grown = UpdateSizes(EmpiricalDrops([0.05]), [0.2134, 0.0001])
    assert grown.values == (0.05, 0.213, 0.001)
    assert UpdateSizes(SIZES["uniform"], [0.2]) is SIZES["uniform"]
    assert UpdateSizes(SIZES["exponential"], [0.2]) is SIZES["exponential"]
    belief = FaultBelief(RateBelief(0.5, 167.0), prior).Update(600.0, [0.2])
    assert belief.rate == RateBelief(1.5, 767.0)
    assert belief.sizes.shape == 3.0 and belief.sizes.scale == pytest.approx(0.3, rel=1e-15)
    assert FaultBelief(RateBelief(2.0, 500.0), SIZES["uniform"]).PointModel() == FaultModel(
        0.004, SIZES["uniform"]
    )


def test_learning_sizes_are_never_lighter_than_the_point_model():
    uniform = UniformDrops(0.0, 0.15)
    listed = LearningSizes(uniform)
    assert listed.values == (0.025, 0.05, 0.075, 0.1, 0.125, 0.15)
    m = np.linspace(0.0, 0.6, 61)
    assert np.all(listed.sum_tail(10, m) >= uniform.sum_tail(10, m) - 1e-12)
    odd = LearningSizes(UniformDrops(0.013, 0.1), prior_sizes=7)
    assert len(odd.values) == 7 and odd.values[-1] == 0.1
    assert np.all(odd.sum_tail(8, m) >= UniformDrops(0.013, 0.1).sum_tail(8, m) - 1e-12)
    scale = LearningSizes(ExponentialDrops(0.05), 3)
    assert scale.shape == 3.0 and scale.scale == pytest.approx(0.15, rel=1e-15)
    assert LearningSizes(listed) is listed
    # heavier drops than believed: the list learns them, and the total drop's tail rises
    belief = FaultBelief(RateBelief.FromRecords(), listed)
    learned = belief.Update(300.0, [0.2, 0.22])
    assert learned.sizes.values[-2:] == (0.2, 0.22)
    assert BeliefDropTail(learned, 600.0, 0.3) > BeliefDropTail(
        belief.Update(300.0, [0.1, 0.1]), 600.0, 0.3
    )


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_saturated_size_tails_are_the_tails_from_below(kind):
    m = np.linspace(-0.05, 0.5, 23)
    full = SIZES[kind].sum_tail(120, m)
    saturated = SaturatedSumTail(SIZES[kind], 120, m)
    assert saturated.shape == full.shape == (23, 121)
    assert np.all(saturated <= full + 1e-15) and np.all(saturated >= full - 1e-13)
    with pytest.raises(ValueError, match="margin"):
        SaturatedSumTail(SIZES[kind], 10, [0.1, math.nan])


# The total drop under the belief.


@pytest.mark.parametrize("tau, mu", [(100.0, 0.05), (800.0, 0.1), (5000.0, 0.02)])
def test_drop_tail_geometric_closed_form(tau, mu):
    """α = 1: the count is geometric, and a geometric sum of exponentials is exponential:
    P(S > m) = (1 − p) e^(−p m/μ), p = β/(β + τ)."""
    beta = 400.0
    belief = FaultBelief(RateBelief(1.0, beta), ExponentialDrops(mu))
    p = beta / (beta + tau)
    m = np.array([0.0, 0.01, 0.1, 0.4])
    tail = BeliefDropTail(belief, tau, m)
    exact = (1 - p) * np.exp(-p * m / mu)
    assert np.all(tail <= exact + 1e-15) and np.all(tail >= exact - 1e-12)  # from below


@pytest.mark.parametrize("kind", ["uniform", "exponential", "empirical"])
def test_drop_tail_of_a_point_belief_is_the_poisson_one(kind):
    belief = FaultBelief(RateBelief.PointMass(1 / 200), SIZES[kind])
    tau, m = np.array([0.0, 50.0, 400.0, 900.0]), np.array([0.1, -0.01, 0.12, 0.3])
    np.testing.assert_allclose(
        BeliefDropTail(belief, tau, m),
        TotalDropTail(FaultModel(1 / 200, SIZES[kind]), tau, m),
        atol=1e-6,
    )


@pytest.mark.parametrize(
    "kind, tau, m",
    [
        ("uniform", 600.0, 0.1),
        ("exponential", 400.0, 0.2),
        ("empirical", 900.0, 0.15),
        ("belief", 700.0, 0.25),
    ],
)
def test_drop_tail_against_monte_carlo(kind, tau, m):
    belief = FaultBelief(RateBelief(0.5, 167.0), SIZES[kind])
    rng = np.random.default_rng(20261205)
    worlds = 200_000
    times, sizes = SampleWorlds(belief, tau, worlds, rng)
    totals = np.round(np.sum(np.where(times <= tau, sizes, 0.0), axis=1), 12)
    exact = BeliefDropTail(belief, tau, m)
    assert abs(np.mean(totals > m) - exact) <= 4.0 * StandardError(exact, worlds)


def test_drop_tail_of_a_heavy_count_saturates_the_sizes():
    """α = 1/2 over a long exposure sums counts far beyond where the uniform's tails reach 1."""
    belief = FaultBelief(RateBelief(0.5, 30.0), UniformDrops(0.0, 0.15))
    n_max = NegativeBinomialCutoff(0.5, 1500.0 / 30.0)
    assert n_max > 1000
    pmf = belief.rate.CountPmf(1500.0, n_max)
    direct = np.sum(pmf[:200] * UniformDrops(0.0, 0.15).sum_tail(199, 0.3)) + np.sum(pmf[200:])
    assert BeliefDropTail(belief, 1500.0, 0.3) == pytest.approx(direct, abs=1e-13)


# The excess risk under the belief.


def SimulateExcess(belief, tau_p, m_p, tau_0, m_0, worlds, rng):
    """Fraction of worlds (λ from the belief) where p, falling back to the lowest plan at its first
    drop, fails while the lowest plan flown from the start completes (risk.py's A1 to A4)."""
    times, sizes = SampleWorlds(belief, max(tau_p, tau_0), worlds, rng)
    lowest_fails = np.sum(np.where(times <= tau_0, sizes, 0.0), axis=1) > m_0
    first = times[:, 0]
    dropped = first <= tau_p
    u = np.where(dropped, first / tau_p, 1.0)
    end = first + tau_0 * (1.0 - u)
    total = np.sum(np.where(times <= end[:, None], sizes, 0.0), axis=1)
    plan_fails = np.where(dropped, total > u * m_p + (1.0 - u) * m_0, m_p < 0.0)
    return np.mean(plan_fails & ~lowest_fails)


@pytest.mark.parametrize(
    "kind, shape, rate, tau_p, m_p, tau_0, m_0",
    [
        ("uniform", 0.5, 167.0, 400.0, 0.05, 300.0, 0.12),  # no records, longer and spends more
        ("uniform", 3.5, 1000.0, 300.0, 0.02, 300.0, 0.12),  # same path, more SoC per second
        ("exponential", 1.5, 400.0, 500.0, 0.1, 300.0, 0.2),
        ("empirical", 0.5, 167.0, 350.0, -0.01, 300.0, 0.06),  # fails without faults
        ("belief", 2.0, 600.0, 450.0, 0.1, 300.0, 0.25),  # learning sizes
        ("empirical", 2.0, 600.0, 250.0, 0.15, 300.0, 0.1),  # out of order: the bound only
    ],
)
def test_excess_risk_against_monte_carlo(kind, shape, rate, tau_p, m_p, tau_0, m_0):
    belief = FaultBelief(RateBelief(shape, rate), SIZES[kind])
    rng = np.random.default_rng(1205)
    worlds = 200_000
    estimate = SimulateExcess(belief, tau_p, m_p, tau_0, m_0, worlds, rng)
    lower, upper = BeliefExcessRiskBounds(belief, tau_p, m_p, tau_0, m_0)
    se = StandardError(estimate, worlds)
    assert lower - 4.0 * se <= estimate <= upper + 4.0 * se
    assert BeliefExcessRisk(belief, tau_p, m_p, tau_0, m_0) == upper
    if tau_p >= tau_0 and m_p <= m_0:
        assert upper - lower <= 0.01


@pytest.mark.parametrize("kind", ["uniform", "exponential", "empirical"])
def test_excess_risk_of_a_point_belief_is_the_poisson_one(kind):
    belief = FaultBelief(RateBelief.PointMass(1 / 250), SIZES[kind])
    model = FaultModel(1 / 250, SIZES[kind])
    args = ([400.0, 300.0, 500.0, 250.0], [0.05, 0.02, -0.01, 0.15], 300.0, [0.12, 0.12, 0.06, 0.1])
    for mine, theirs in zip(
        BeliefExcessRiskBounds(belief, *args), ExcessRiskBounds(model, *args), strict=True
    ):
        np.testing.assert_allclose(mine, theirs, atol=1e-6)


def GeneralisedLaguerre(a, nodes):
    """Nodes x and normalised weights of ∫ x^a e^(−x) f(x) dx / Γ(a + 1) (Golub–Welsch)."""
    k = np.arange(nodes)
    jacobi = np.diag(2.0 * k + a + 1.0)
    off = np.sqrt(k[1:] * (k[1:] + a))
    jacobi += np.diag(off, 1) + np.diag(off, -1)
    x, vectors = np.linalg.eigh(jacobi)
    return x, vectors[0] ** 2


@pytest.mark.parametrize("shape", [0.5, 2.0, 7.0])
def test_excess_risk_is_the_mixture_of_the_poisson_excess_over_the_rate(shape):
    """E_λ R(p | λ) by Gauss–Laguerre over λ ~ Gamma(α, β) of risk.ExcessRiskBounds brackets the
    same value as the exact negative binomial form."""
    rate = 3000.0
    sizes = SIZES["uniform"]
    belief = FaultBelief(RateBelief(shape, rate), sizes)
    x, w = GeneralisedLaguerre(shape - 1.0, 24)
    tau_p, m_p, tau_0, m_0 = [400.0, 300.0, 600.0], [0.05, 0.03, 0.1], 300.0, 0.13
    bounds = [
        ExcessRiskBounds(FaultModel(xi / rate, sizes), tau_p, m_p, tau_0, m_0, cells=256)
        for xi in x
    ]
    mixed_low = sum(wi * b[0] for wi, b in zip(w, bounds, strict=True))
    mixed_high = sum(wi * b[1] for wi, b in zip(w, bounds, strict=True))
    low, high = BeliefExcessRiskBounds(belief, tau_p, m_p, tau_0, m_0, cells=256)
    assert np.all(low <= mixed_high + 1e-6) and np.all(mixed_low <= high + 1e-6)
    assert np.all(high - low <= 2e-3)


def test_excess_risk_of_the_lowest_plan_is_zero_and_the_bracket_tightens():
    belief = FaultBelief(RateBelief(0.5, 167.0), SIZES["uniform"])
    tau, m = np.array([0.0, 50.0, 300.0, 800.0]), np.array([-0.05, 0.0, 0.1, 0.3])
    lower, upper = BeliefExcessRiskBounds(belief, tau, m, tau, m)
    np.testing.assert_array_equal(lower, 0.0)
    np.testing.assert_array_equal(upper, 0.0)
    assert BeliefExcessRisk(belief, 300.0, 0.1 - 1e-12, 300.0, 0.1) <= 1e-10
    m_p = np.linspace(0.15, 0.0, 12)
    coarse = np.array(BeliefExcessRiskBounds(belief, 400.0, m_p, 300.0, 0.15, cells=16))
    fine = np.array(BeliefExcessRiskBounds(belief, 400.0, m_p, 300.0, 0.15, cells=128))
    assert np.all(coarse[0] <= fine[0] + 1e-12) and np.all(fine[1] <= coarse[1] + 1e-12)
    assert np.max(fine[1] - fine[0]) <= 0.25 * np.max(coarse[1] - coarse[0])
    assert np.all(np.diff(fine[1]) >= -1e-12) and fine[1][-1] > fine[1][1] > 0.0


def test_quiet_flight_lowers_the_excess_risk_and_a_drop_raises_it():
    belief = FaultBelief(RateBelief.FromRecords(), ExponentialSizeBelief.FromMean(0.05))
    args = (500.0, 0.08, 400.0, 0.2)
    now = BeliefExcessRisk(belief, *args)
    quiet = BeliefExcessRisk(belief.Update(300.0), *args)
    heavy = BeliefExcessRisk(belief.Update(300.0, [0.2]), *args)
    assert quiet < now and heavy > quiet
    assert 0.0 < quiet < heavy < 1.0


def test_excess_risk_vectorised_over_candidates_and_deterministic():
    belief = FaultBelief(RateBelief(1.5, 400.0), SIZES["belief"])
    tau_p = np.linspace(300.0, 600.0, 40)
    m_p = np.linspace(0.2, -0.02, 40)
    batch = BeliefExcessRisk(belief, tau_p, m_p, 300.0, 0.2)
    assert batch.shape == (40,)
    np.testing.assert_array_equal(batch, BeliefExcessRisk(belief, tau_p, m_p, 300.0, 0.2))
    for i in [0, 7, 23, 39]:
        single = BeliefExcessRisk(belief, tau_p[i], m_p[i], 300.0, 0.2)
        assert batch[i] == pytest.approx(single, abs=1e-12)


# -- the learnt sizes the mpc's risk reserve flies with ---------------------------------------


def test_dirichlet_sizes_on_the_grid_are_the_empirical_list():
    """K = 2 around two equally likely sizes, one more observed: three equally likely sizes,
    exactly (sizes on the grid are not rounded)."""
    learnt = DirichletDrops(EmpiricalDrops((0.05, 0.1)), (0.2,), 2.0)
    m = np.array([-0.1, 0.0123, 0.1235, 0.2771, 0.4567, 0.8123])
    np.testing.assert_allclose(
        learnt.sum_tail(6, m), EmpiricalDrops((0.05, 0.1, 0.2)).sum_tail(6, m), atol=1e-12
    )
    assert learnt.upper == 0.2


def test_dirichlet_sizes_bracket_the_base_tails_by_the_grid():
    """With nothing observed the grid tails Q̂_n of U[0, 0.15] lie between Q_n(m) and
    Q_n(m − n h): conservative by at most n grid steps."""
    base = UniformDrops(0.0, 0.15)
    m = np.arange(1001) * SIZE_RESOLUTION
    grid = DirichletDrops(base, (), 6.0).sum_tail(20, m)
    exact = base.sum_tail(20, m)
    shifted = np.stack(
        [base.sum_tail(20, m - n * SIZE_RESOLUTION)[:, n] for n in range(21)], axis=1
    )
    assert np.all(grid >= exact - 1e-12)
    assert np.all(grid <= shifted + 1e-12)


def test_dirichlet_sizes_against_sampling():
    """P(S(τ) > m) with the learnt sizes against 400 000 sampled worlds (binomial 4σ)."""
    base, observed, k = UniformDrops(0.0, 0.15), (0.2, 0.05), 6.0
    model = FaultModel(0.003, DirichletDrops(base, observed, k))
    rng = np.random.default_rng(7)
    worlds = 400_000
    counts = rng.poisson(0.003 * 300.0, worlds)
    total = np.zeros(worlds)
    for i in range(counts.max()):
        pick = rng.random(worlds) * (k + len(observed))
        size = np.where(pick < k, rng.uniform(0.0, 0.15, worlds), np.where(pick < k + 1, 0.2, 0.05))
        total += np.where(counts > i, size, 0.0)
    for m in (0.05, 0.1, 0.2, 0.3):
        p = float(TotalDropTail(model, 300.0, m))
        sampled = float(np.mean(total > m))
        assert abs(p - sampled) <= 4.0 * math.sqrt(p * (1.0 - p) / worlds) + 1e-4


def test_dirichlet_sizes_learn_a_heavier_world():
    """An observed size above the declared bounds raises every tail at once; below them lowers
    the tail beyond the bounds' mean."""
    base = UniformDrops(0.0, 0.15)
    m = np.array([0.1, 0.2])
    prior = DirichletDrops(base, (), 6.0).sum_tail(3, m)
    heavy = DirichletDrops(base, (0.22,), 6.0).sum_tail(3, m)
    assert np.all(heavy[:, 1:] >= prior[:, 1:])
    assert heavy[1, 1] == pytest.approx(1.0 / 7.0, abs=1e-12)  # only the 0.22 exceeds 0.2


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(base=0.1, observed=(), prior_sizes=1.0), "DirichletDrops.base"),
        (dict(base=UniformDrops(0, 0.1), observed=(0.0,), prior_sizes=1.0), "observed[0]"),
        (dict(base=UniformDrops(0, 0.1), observed=(), prior_sizes=0.0), "prior_sizes"),
    ],
)
def test_dirichlet_sizes_bad_input_names_the_field(kwargs, key):
    with pytest.raises(ValueError, match=key.replace("[", r"\[").replace("]", r"\]")):
        DirichletDrops(**kwargs)
