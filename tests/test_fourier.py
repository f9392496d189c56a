"""Tests of the scaled periodic energy model (paper 003 Eqs. 3–12, Lemma III.1)."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.energy.fourier import (
    DiscreteFourierMatrices,
    EstimatePeriod,
    FitFourierSeries,
    FourierEnergyModel,
    FourierMatrices,
    FourierStateFromCoefficients,
)
from eaplan_drake.logfit.powerlog import ReferenceDirectory

REFERENCE = REFERENCE_DIR = ReferenceDirectory()


def _series(t, a0, a, b, T):
    """h(t) = a0/T + (2/T) Σ (a_j cos ωjt + b_j sin ωjt), written out independently."""
    w = 2.0 * math.pi / T
    y = np.full_like(np.asarray(t, dtype=float), a0 / T)
    for j, (aj, bj) in enumerate(zip(a, b, strict=True), start=1):
        y += (2.0 / T) * (aj * np.cos(w * j * t) + bj * np.sin(w * j * t))
    return y


def _expm(M, terms=60):
    """Matrix exponential by scaling and squaring of a Taylor series (test-only reference)."""
    s = max(0, int(math.ceil(math.log2(max(np.abs(M).sum(axis=1).max(), 1e-300)))) + 1)
    X = M / 2.0**s
    E = np.eye(M.shape[0])
    term = np.eye(M.shape[0])
    for k in range(1, terms):
        term = term @ X / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


@pytest.mark.parametrize("order", [0, 1, 3, 5])
def test_matrices_shapes_and_structure(order):
    T = 46.0
    A, B, C = FourierMatrices(order, T)
    m = 2 * order + 1
    assert A.shape == (m, m) and B.shape == (m, 1) and C.shape == (1, m)
    np.testing.assert_array_equal(A, -A.T)  # skew: a pure oscillator
    np.testing.assert_array_equal(B[:, 0], np.eye(m)[0])
    expected_C = np.zeros(m)
    expected_C[0] = 1.0
    expected_C[1::2] = 1.0
    np.testing.assert_array_equal(C[0], expected_C)
    w = 2 * math.pi / T
    for j in range(1, order + 1):
        assert A[2 * j - 1, 2 * j] == pytest.approx(w * j)
        assert A[2 * j, 2 * j - 1] == pytest.approx(-w * j)
    # eigenvalues 0, ±iωj
    eig = np.sort(np.abs(np.linalg.eigvals(A).imag))
    np.testing.assert_allclose(eig, np.sort([0.0] + [w * j for j in range(1, order + 1)] * 2))


@pytest.mark.parametrize("h", [0.01, 0.37, 5.0, 46.0])
def test_discretisation_is_the_matrix_exponential(h):
    A, B, _ = FourierMatrices(3, 46.0)
    Ad, Bd = DiscreteFourierMatrices(3, 46.0, h)
    np.testing.assert_allclose(Ad, _expm(A * h), atol=1e-12)
    np.testing.assert_array_equal(Bd, B)
    np.testing.assert_allclose(Ad @ Ad.T, np.eye(7), atol=1e-14)  # orthogonal


def test_lemma_III_1_random_coefficients_over_20_periods():
    rng = np.random.default_rng(11)
    for _ in range(5):
        r = int(rng.integers(1, 6))
        T = float(rng.uniform(10.0, 80.0))
        a0 = float(rng.uniform(500.0, 2000.0))
        a = rng.normal(0.0, 50.0, r)
        b = rng.normal(0.0, 50.0, r)
        h = 0.01 * float(rng.uniform(0.5, 2.0))
        q = FourierStateFromCoefficients(a0, a, b, T)
        np.testing.assert_allclose(q[0], a0 / T)
        Ad, _ = DiscreteFourierMatrices(r, T, h)
        _, _, C = FourierMatrices(r, T)
        n = int(math.ceil(20 * T / h)) + 1
        ys = np.empty(n)
        for k in range(n):
            ys[k] = (C @ q)[0]
            q = Ad @ q
        t = h * np.arange(n)
        truth = _series(t, a0, a, b, T)
        err = np.max(np.abs(ys - truth) / np.abs(truth))
        assert err < 1e-9, f"r={r}, T={T}: relative error {err:g}"


def test_amplitude_preserved_over_1e5_steps():
    rng = np.random.default_rng(5)
    q0 = rng.normal(0.0, 3.0, 7)
    Ad, _ = DiscreteFourierMatrices(3, 46.0, 0.01)
    q = q0.copy()
    for _ in range(100_000):
        q = Ad @ q
    for j in range(1, 4):
        amp0 = math.hypot(q0[2 * j - 1], q0[2 * j])
        amp = math.hypot(q[2 * j - 1], q[2 * j])
        assert amp == pytest.approx(amp0, rel=1e-10)
    assert q[0] == q0[0]
    # after exactly 1e5 steps of 0.01 s = 1000 s the phase is that of the analytic solution
    np.testing.assert_allclose(q, _expm(FourierMatrices(3, 46.0)[0] * 1000.0) @ q0, atol=1e-8)


def test_input_raises_output_by_exactly_delta_g():
    rng = np.random.default_rng(2)
    Ad, Bd = DiscreteFourierMatrices(3, 46.0, 0.01)
    _, _, C = FourierMatrices(3, 46.0)
    q = rng.normal(30.0, 2.0, 7)
    dg = 1.73
    y_free = (C @ (Ad @ q))[0]
    y_step = (C @ (Ad @ q + Bd[:, 0] * dg))[0]
    assert y_step - y_free == pytest.approx(dg, abs=1e-12)


def test_bad_arguments_name_the_field():
    with pytest.raises(ValueError, match="order"):
        FourierMatrices(-1, 46.0)
    with pytest.raises(ValueError, match="order"):
        FourierMatrices(1.5, 46.0)
    with pytest.raises(ValueError, match="period"):
        FourierMatrices(3, 0.0)
    with pytest.raises(ValueError, match="period"):
        DiscreteFourierMatrices(3, float("nan"), 0.01)
    with pytest.raises(ValueError, match="time step"):
        DiscreteFourierMatrices(3, 46.0, -0.01)


def test_fourier_fit_recovers_state_from_noisy_signal():
    rng = np.random.default_rng(7)
    T, r = 46.0, 3
    a0, a, b = 31.0 * T, rng.normal(0, 40, r), rng.normal(0, 40, r)
    t = np.arange(0.0, 3 * T, 0.1)
    y = _series(t, a0, a, b, T) + rng.normal(0.0, 0.5, t.size)
    y[rng.uniform(size=t.size) < 0.1] = np.nan  # dropped samples are ignored
    q = FitFourierSeries(t, y, r, T)
    np.testing.assert_allclose(q, FourierStateFromCoefficients(a0, a, b, T), atol=0.05)
    # the state at another time is the propagated one
    q_late = FitFourierSeries(t, y, r, T, at_time=10.0)
    Ad, _ = DiscreteFourierMatrices(r, T, 10.0)
    np.testing.assert_allclose(q_late, Ad @ q, atol=1e-9)
    with pytest.raises(ValueError, match="at least"):
        FitFourierSeries(t[:5], y[:5], r, T)


def test_period_estimate_on_synthetic_signal():
    rng = np.random.default_rng(9)
    for T in (46.0, 31.7, 60.0):
        a = np.array([60.0, 25.0, 10.0])
        b = np.array([-20.0, 30.0, 5.0])
        t = np.sort(rng.uniform(0.0, 5 * T, 2000))  # irregular sampling
        y = _series(t, 31.0 * T, a, b, T) + rng.normal(0.0, 0.5, t.size)
        assert EstimatePeriod(t, y) == pytest.approx(T, rel=0.005)
        t = np.arange(0.0, 2.5 * T, 0.1)  # clean, regular, only 2.5 periods
        assert EstimatePeriod(t, _series(t, 31.0 * T, a, b, T)) == pytest.approx(T, rel=5e-4)


def test_period_estimate_errors():
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(ValueError, match="empty lag range"):
        EstimatePeriod(t, np.sin(t), min_period=8.0, max_period=5.0)
    with pytest.raises(ValueError, match="samples"):
        EstimatePeriod(t[:3], t[:3])


@pytest.mark.authors_data
def test_period_estimate_on_authors_plan_I_log():
    data = np.loadtxt(REFERENCE / "plan_I" / "energy_resized.csv", delimiter=",")
    t, y = data[:, 0], data[:, 1]
    first = t <= 200.0  # about four periods, as available early in flight
    assert EstimatePeriod(t[first], y[first]) == pytest.approx(46.0, abs=1.0)
    assert EstimatePeriod(t, y) == pytest.approx(46.0, abs=1.0)


# -- FourierEnergyModel ---------------------------------------------------------------------------


def _standalone(model, g, T):
    """A Simulator on the model alone with fixed inputs (change them between AdvanceTo calls)."""
    simulator = Simulator(model)
    context = simulator.get_mutable_context()
    model.GetInputPort("computation_power").FixValue(context, [g])
    model.GetInputPort("period").FixValue(context, [T])
    simulator.Initialize()
    return simulator, context


def _power(model, context):
    return model.GetOutputPort("power").Eval(context)[0]


def test_model_ports_and_outputs_match_pure_functions():
    q0 = np.arange(1.0, 8.0)
    model = FourierEnergyModel(3, 46.0, q0, 0.01)
    assert [model.get_input_port(i).get_name() for i in range(2)] == [
        "computation_power",
        "period",
    ]
    assert model.GetInputPort("computation_power").size() == 1
    assert model.GetInputPort("period").size() == 1
    assert model.GetOutputPort("energy_coefficients").size() == 7
    assert model.GetOutputPort("power").size() == 1
    # outputs depend on the state only (no algebraic loop through the inputs)
    assert not model.HasDirectFeedthrough(0, 0) and not model.HasDirectFeedthrough(1, 1)
    context = model.CreateDefaultContext()
    np.testing.assert_array_equal(model.GetOutputPort("energy_coefficients").Eval(context), q0)
    _, _, C = FourierMatrices(3, 46.0)
    assert _power(model, context) == pytest.approx((C @ q0)[0], abs=1e-12)
    # 250 steps of the system equal 250 steps of the pure matrices
    simulator, context = _standalone(model, 4.0, 46.0)
    simulator.AdvanceTo(2.5)
    Ad, _ = DiscreteFourierMatrices(3, 46.0, 0.01)
    np.testing.assert_allclose(
        model.GetOutputPort("energy_coefficients").Eval(context),
        np.linalg.matrix_power(Ad, 250) @ q0,
        atol=1e-12,
    )


def test_model_lemma_III_1_in_a_diagram_over_20_periods():
    rng = np.random.default_rng(21)
    r, T, h = 3, 20.0, 0.01
    a0, a, b = 31.0 * T, rng.normal(0.0, 40.0, r), rng.normal(0.0, 40.0, r)
    builder = DiagramBuilder()
    model = builder.AddSystem(
        FourierEnergyModel(r, T, FourierStateFromCoefficients(a0, a, b, T), h)
    )
    g = builder.AddSystem(ConstantVectorSource([6.0]))
    period = builder.AddSystem(ConstantVectorSource([T]))
    builder.Connect(g.get_output_port(), model.GetInputPort("computation_power"))
    builder.Connect(period.get_output_port(), model.GetInputPort("period"))
    logger = LogVectorOutput(model.GetOutputPort("power"), builder, h)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(20 * T)
    log = logger.FindLog(simulator.get_context())
    t, y = log.sample_times(), log.data()[0]
    assert t[-1] == pytest.approx(20 * T) and t.size > 20 * T / h
    truth = _series(t, a0, a, b, T)
    assert np.all(np.isfinite(y))
    assert np.max(np.abs(y - truth) / np.abs(truth)) < 1e-9


def test_model_amplitude_preserved_over_1e5_steps():
    rng = np.random.default_rng(4)
    q0 = rng.normal(0.0, 3.0, 7)
    q0[0] = 30.0
    model = FourierEnergyModel(3, 46.0, q0, 0.01)
    simulator, context = _standalone(model, 5.0, 46.0)
    simulator.AdvanceTo(1000.0)  # 1e5 updates
    q = model.GetOutputPort("energy_coefficients").Eval(context)
    for j in range(1, 4):
        assert math.hypot(q[2 * j - 1], q[2 * j]) == pytest.approx(
            math.hypot(q0[2 * j - 1], q0[2 * j]), rel=1e-10
        )
    assert q[0] == q0[0]  # constant computation power: no Δg
    np.testing.assert_allclose(q, _expm(FourierMatrices(3, 46.0)[0] * 1000.0) @ q0, atol=1e-8)


def test_model_computation_step_raises_output_by_exactly_delta_g():
    rng = np.random.default_rng(8)
    q0 = rng.normal(0.0, 2.0, 7)
    q0[0] = 25.0
    runs = []
    for g_after in (5.0, 7.5):
        model = FourierEnergyModel(3, 46.0, q0, 0.01)
        simulator, context = _standalone(model, 5.0, 46.0)
        simulator.AdvanceTo(3.0)
        model.GetInputPort("computation_power").FixValue(context, [g_after])
        ys = []
        for k in range(1, 200):
            simulator.AdvanceTo(3.0 + 0.01 * k)
            ys.append(_power(model, context))
        runs.append(np.array(ys))
    np.testing.assert_allclose(runs[1] - runs[0], 2.5, atol=1e-12)


def test_model_new_period_takes_effect_without_jump():
    rng = np.random.default_rng(12)
    q0 = rng.normal(0.0, 3.0, 7)
    q0[0] = 30.0
    h, T1, T2 = 0.01, 46.0, 23.0
    model = FourierEnergyModel(3, T1, q0, h)
    simulator, context = _standalone(model, 5.0, T1)
    ys = []
    for k in range(1, 1001):
        simulator.AdvanceTo(k * h)
        ys.append(_power(model, context))
    q_switch = model.GetOutputPort("energy_coefficients").Eval(context).copy()
    model.GetInputPort("period").FixValue(context, [T2])
    for k in range(1001, 2001):
        simulator.AdvanceTo(k * h)
        ys.append(_power(model, context))
    dy = np.abs(np.diff(ys))
    # no jump: the step across the switch is a normal one-step increment of the faster model
    w2 = 2 * math.pi / T2
    bound = h * sum(w2 * j * math.hypot(q0[2 * j - 1], q0[2 * j]) for j in range(1, 4))
    assert dy[999] <= bound
    assert np.max(dy) <= bound
    # after the switch the state follows the new period exactly
    q_now = model.GetOutputPort("energy_coefficients").Eval(context)
    Ad2, _ = DiscreteFourierMatrices(3, T2, h)
    np.testing.assert_allclose(q_now, np.linalg.matrix_power(Ad2, 1000) @ q_switch, atol=1e-10)
    assert model.Memory(context).period == T2


def test_model_ignores_non_finite_inputs():
    q0 = np.array([30.0, 1.0, 0.0, 0.5, 0.5, 0.0, 0.2])
    model = FourierEnergyModel(3, 46.0, q0, 0.01)
    simulator, context = _standalone(model, 5.0, 46.0)
    simulator.AdvanceTo(1.0)
    model.GetInputPort("computation_power").FixValue(context, [np.nan])
    model.GetInputPort("period").FixValue(context, [np.inf])
    simulator.AdvanceTo(2.0)
    model.GetInputPort("period").FixValue(context, [-3.0])
    simulator.AdvanceTo(3.0)
    q = model.GetOutputPort("energy_coefficients").Eval(context)
    Ad, _ = DiscreteFourierMatrices(3, 46.0, 0.01)
    np.testing.assert_allclose(q, np.linalg.matrix_power(Ad, 300) @ q0, atol=1e-10)
    # computation power comes back: Δg relative to the last finite value
    model.GetInputPort("computation_power").FixValue(context, [6.0])
    simulator.AdvanceTo(3.01)
    assert model.GetOutputPort("energy_coefficients").Eval(context)[0] == pytest.approx(31.0)


def test_model_bad_constructor_arguments():
    with pytest.raises(ValueError, match="order"):
        FourierEnergyModel(-1, 46.0)
    with pytest.raises(ValueError, match="initial_period"):
        FourierEnergyModel(3, 0.0)
    with pytest.raises(ValueError, match="time_step"):
        FourierEnergyModel(3, 46.0, time_step=0.0)
    with pytest.raises(ValueError, match="initial_q"):
        FourierEnergyModel(3, 46.0, np.zeros(5))


# -- augmented model (aperiodic AR(1) load) -------------------------------------------------------


def test_augmented_order_sizes_and_matrices():
    from eaplan_drake.energy.fourier import (
        AperiodicDecay,
        AperiodicProcessNoise,
        AugmentedOrder,
        DiscreteEnergyMatrices,
        OutputMatrix,
        StateSize,
    )

    model = AugmentedOrder(3, 20.0)
    assert StateSize(3) == 7 and StateSize(model) == 8 and int(model) == 3
    np.testing.assert_array_equal(OutputMatrix(model), [[1, 1, 0, 1, 0, 1, 0, 1]])
    Ad, Bd = DiscreteEnergyMatrices(model, 46.0, 0.5)
    Ad3, Bd3 = DiscreteFourierMatrices(3, 46.0, 0.5)
    np.testing.assert_array_equal(Ad[:7, :7], Ad3)
    assert Ad[7, 7] == pytest.approx(math.exp(-0.5 / 20.0), rel=1e-15)
    assert not Ad[7, :7].any() and not Ad[:7, 7].any()
    np.testing.assert_array_equal(Bd[:7], Bd3)
    assert Bd[7, 0] == 0.0
    # integer order: exactly the paper's matrices
    A_int, B_int = DiscreteEnergyMatrices(3, 46.0, 0.5)
    np.testing.assert_array_equal(A_int, Ad3)
    np.testing.assert_array_equal(B_int, Bd3)
    # random walk
    assert AperiodicDecay(math.inf, 0.5) == 1.0
    assert AperiodicProcessNoise(AugmentedOrder(1, math.inf), 0.2, 0.5) == pytest.approx(0.1)
    # the stationary variance of the discrete AR(1) is q_d τ / 2 for any step
    for h in (0.01, 0.5, 30.0):
        phi = AperiodicDecay(20.0, h)
        Qdd = AperiodicProcessNoise(model, 0.3, h)
        assert Qdd / (1.0 - phi * phi) == pytest.approx(0.3 * 20.0 / 2.0, rel=1e-12)
    assert AperiodicProcessNoise(3, 0.3, 0.5) == 0.0
    with pytest.raises(ValueError, match="aperiodic_time_constant"):
        AugmentedOrder(3, 0.0)
    with pytest.raises(ValueError, match="order"):
        AugmentedOrder(-1, 5.0)


def test_known_input_step_and_transition_cache():
    from eaplan_drake.energy.fourier import InputMemory, KnownInputStep, TransitionMatrices

    memory = InputMemory(np.array([np.nan, 46.0]))
    assert KnownInputStep(memory, 5.0, 46.0) == 0.0  # first finite g: no jump
    assert memory.previous_computation_power == 5.0
    assert KnownInputStep(memory, 7.5, 30.0) == 2.5 and memory.period == 30.0
    assert KnownInputStep(memory, np.nan, np.inf) == 0.0  # ignored: kept
    assert memory.previous_computation_power == 7.5 and memory.period == 30.0
    assert KnownInputStep(memory, 6.0, -1.0) == -1.5 and memory.period == 30.0
    cache = TransitionMatrices(3, 0.01, max_periods=2)
    for T in (46.0, 30.0, 46.0, 23.0):
        np.testing.assert_array_equal(cache(T), DiscreteFourierMatrices(3, T, 0.01)[0])
        Ad, half = cache.WithHalf(T)
        assert Ad is cache(T) and half is cache.WithHalf(T)[1]  # cached, not recomputed
        np.testing.assert_array_equal(half, 0.5 * Ad)


def test_process_noise_matrix_is_the_models_q():
    from eaplan_drake.energy.fourier import AugmentedOrder, ProcessNoiseMatrix

    np.testing.assert_array_equal(
        ProcessNoiseMatrix(2, 1e-6, 3e-6, 0.5, 0.01), np.diag([4e-6, 1e-6, 1e-6, 1e-6, 1e-6])
    )
    tau, q_d, h = 20.0, 0.3, 0.5
    phi = math.exp(-h / tau)
    Q = ProcessNoiseMatrix(AugmentedOrder(1, tau), 1e-5, 0.0, q_d, h)
    np.testing.assert_allclose(
        Q, np.diag([1e-5, 1e-5, 1e-5, 0.5 * q_d * tau * (1.0 - phi * phi)]), rtol=1e-14, atol=0
    )
    assert ProcessNoiseMatrix(AugmentedOrder(0, math.inf), 0.0, 0.0, 0.2, 0.5)[1, 1] == (
        pytest.approx(0.1)
    )


def test_free_response_decays_the_aperiodic_load_as_its_model_says():
    from eaplan_drake.energy.fourier import AugmentedOrder, FourierOutputMatrix, FreeResponseMatrix

    T, step, n = 46.0, 0.5, 300
    q = np.array([30.0, 2.0, -1.0, 0.5, 0.3, 0.0, 0.0])
    periodic = FreeResponseMatrix(3, T, step, n) @ q
    k = np.arange(n)
    tau_d = 12.0
    rows = FreeResponseMatrix(AugmentedOrder(3, tau_d), T, step, n)
    np.testing.assert_allclose(
        rows @ np.append(q, 4.0), periodic + 4.0 * np.exp(-k * step / tau_d), atol=1e-11
    )
    held = FreeResponseMatrix(AugmentedOrder(3, math.inf), T, step, n) @ np.append(q, 4.0)
    np.testing.assert_allclose(held, periodic + 4.0, atol=1e-11)
    # the integer order gives exactly the stacked powers of the rotation
    Ad = DiscreteFourierMatrices(3, T, step)[0]
    C = FourierOutputMatrix(3)
    expected = np.vstack([C @ np.linalg.matrix_power(Ad, i) for i in range(8)])
    np.testing.assert_allclose(FreeResponseMatrix(3, T, step, 8), expected, atol=1e-13)


def test_period_with_confidence_accepts_a_periodic_signal_and_refuses_noise():
    from eaplan_drake.energy.fourier import EstimatePeriodWithConfidence

    rng = np.random.default_rng(2)
    t = np.arange(0.0, 400.0, 0.2)
    y = 30.0 + 3.0 * np.cos(2 * np.pi * t / 46.0) + np.sin(4 * np.pi * t / 46.0)
    found = EstimatePeriodWithConfidence(t, y + rng.normal(0.0, 0.3, t.size))
    assert found.period == pytest.approx(46.0, rel=0.01)
    assert found.confidence > 0.9
    noise = EstimatePeriodWithConfidence(t, rng.normal(30.0, 1.0, t.size))
    assert noise.period is None
    assert noise.message.startswith("no clear period")
    assert noise.confidence < 0.5
