"""Tests of the PowerSensor system and its seeded noise / dropout draws."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, Sine

from eaplan_drake.energy.sensor import (
    BLOCK_SIZE,
    AveragedNoiseStd,
    AveragedSample,
    AveragedVariance,
    BaseStepsPerSample,
    NoiseBlock,
    NoiseSamples,
    PowerSample,
    PowerSensor,
    ReadingsPerSample,
)
from eaplan_drake.params import SensorParams

AMPLITUDE, OMEGA, PHASE, OFFSET = 4.0, 0.7, 0.3, 6.0  # computation power 6 W + 4 sin(0.7 t + 0.3)
MOTION = 25.0


def TruePower(t):
    return MOTION + OFFSET + AMPLITUDE * np.sin(OMEGA * np.asarray(t) + PHASE)


def MakeDiagram(params: SensorParams, time_step: float | None = None):
    """Sensor fed by the sum of a constant motion power and a sinusoidal computation power (that
    sum y is also the diagram's output port ``true_power``)."""
    builder = DiagramBuilder()
    sensor = builder.AddSystem(PowerSensor(params, time_step=time_step))
    motion = builder.AddSystem(ConstantVectorSource([MOTION]))
    sine = builder.AddSystem(Sine(AMPLITUDE, OMEGA, PHASE, 1))
    offset = builder.AddSystem(ConstantVectorSource([OFFSET]))
    adder = builder.AddSystem(Adder(2, 1))
    builder.Connect(sine.get_output_port(0), adder.get_input_port(0))
    builder.Connect(offset.get_output_port(), adder.get_input_port(1))
    total = builder.AddSystem(Adder(2, 1))
    builder.Connect(motion.get_output_port(), total.get_input_port(0))
    builder.Connect(adder.get_output_port(), total.get_input_port(1))
    builder.Connect(total.get_output_port(), sensor.GetInputPort("power"))
    builder.ExportOutput(total.get_output_port(), "true_power")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    return sensor, simulator


def Samples(sensor, simulator, count: int) -> np.ndarray:
    """measured_power held after each of the first ``count`` samples (t_k + h/2, k = 0 …)."""
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    h = sensor.period
    out = np.empty(count)
    for k in range(count):
        simulator.AdvanceTo((k + 0.5) * h)
        out[k] = sensor.GetOutputPort("measured_power").Eval(context)[0]
    return out


def test_ports_and_sizes():
    sensor = PowerSensor(SensorParams())
    assert sensor.num_input_ports() == 1 and sensor.num_output_ports() == 1
    assert sensor.GetInputPort("power").size() == 1
    assert sensor.GetOutputPort("measured_power").size() == 1
    assert not sensor.HasDirectFeedthrough(0, 0)
    assert sensor.period == pytest.approx(0.01)


def test_zero_noise_gives_the_exact_sum_sampled_and_held():
    sensor, simulator = MakeDiagram(SensorParams(noise_std=0.0))
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    true_power = simulator.get_system().GetOutputPort("true_power")
    root = simulator.get_context()
    # Before the first sample the output is NaN ("no sample yet"); the input y is always there.
    assert math.isnan(sensor.GetOutputPort("measured_power").Eval(context)[0])
    assert true_power.Eval(root)[0] == TruePower(0.0)
    samples = Samples(sensor, simulator, 300)
    t_k = np.arange(300) * sensor.period
    np.testing.assert_allclose(samples, TruePower(t_k), rtol=0, atol=1e-12)
    # Held between samples: at t_k + h/2 the true power has moved on, the sample has not.
    assert true_power.Eval(root)[0] == pytest.approx(TruePower(299.5 * sensor.period), abs=1e-12)
    assert abs(samples[-1] - TruePower(299.5 * sensor.period)) > 1e-4


def test_noise_statistics_over_many_samples():
    n = 200_000
    params = SensorParams(noise_std=0.5, seed=7)
    noise, dropped = NoiseSamples(params, 0, n)
    assert not dropped.any()
    # 5-sigma tolerances: mean ± 5·σ/√n = 0.0056 W, std ± 5·σ/√(2n) = 0.0040 W.
    assert abs(noise.mean()) < 5 * 0.5 / math.sqrt(n)
    assert abs(noise.std() - 0.5) < 5 * 0.5 / math.sqrt(2 * n)
    # Gaussian shape: 68.27 % within one σ (± 5·√(p(1−p)/n) = 0.0052).
    inside = np.mean(np.abs(noise) < 0.5)
    assert abs(inside - 0.682689) < 5 * math.sqrt(0.682689 * 0.317311 / n)
    # White: lag-1 autocorrelation ≈ 0 (± 5/√n), also across block boundaries.
    rho = np.corrcoef(noise[:-1], noise[1:])[0, 1]
    assert abs(rho) < 5 / math.sqrt(n)


def test_dropout_fraction():
    n = 200_000
    _, dropped = NoiseSamples(SensorParams(dropout_probability=0.3, seed=3), 0, n)
    assert abs(dropped.mean() - 0.3) < 5 * math.sqrt(0.3 * 0.7 / n)


def test_draws_are_a_function_of_the_sample_index_only():
    params = SensorParams(seed=11, dropout_probability=0.2)
    noise, dropped = NoiseSamples(params, 0, 3 * BLOCK_SIZE)
    first = BLOCK_SIZE - 50  # straddles a block boundary
    part_noise, part_dropped = NoiseSamples(params, first, 100)
    np.testing.assert_array_equal(part_noise, noise[first : first + 100])
    np.testing.assert_array_equal(part_dropped, dropped[first : first + 100])
    other, _ = NoiseSamples(SensorParams(seed=12), 0, 100)
    assert not np.allclose(other, noise[:100])


def test_measurement_equation():
    assert PowerSample(30.0, 0.25, False) == 30.25
    assert PowerSample(30.0, -1.5, False) == 28.5
    assert math.isnan(PowerSample(30.0, 0.25, True))


def test_system_samples_equal_the_measurement_equation_exactly():
    params = SensorParams(noise_std=0.5, dropout_probability=0.1, seed=3)
    count = 300
    noise, dropped = NoiseSamples(params, 0, count)
    t_k = np.arange(count) * 0.01
    samples = zip(TruePower(t_k), noise, dropped, strict=True)
    expected = [PowerSample(float(y), float(n), bool(d)) for y, n, d in samples]
    sensor, simulator = MakeDiagram(params)
    np.testing.assert_allclose(Samples(sensor, simulator, count), expected, rtol=0, atol=1e-13)


def test_system_keeps_a_copy_of_its_params():
    params = SensorParams(noise_std=0.0, seed=2)
    sensor, simulator = MakeDiagram(params)
    params.noise_std = 10.0
    params.rate = 1.0
    assert sensor.params.noise_std == 0.0 and sensor.period == pytest.approx(0.01)
    np.testing.assert_allclose(
        Samples(sensor, simulator, 20), TruePower(np.arange(20) * 0.01), rtol=0, atol=1e-12
    )


def test_system_samples_are_sum_plus_the_seeded_draws_and_reproducible():
    params = SensorParams(noise_std=0.5, dropout_probability=0.25, seed=5)
    count = 1500
    noise, dropped = NoiseSamples(params, 0, count)
    expected = np.where(dropped, np.nan, TruePower(np.arange(count) * 0.01) + noise)

    sensor, simulator = MakeDiagram(params)
    first = Samples(sensor, simulator, count)
    np.testing.assert_allclose(first, expected, rtol=0, atol=1e-12)  # NaNs must match too
    assert abs(np.isnan(first).mean() - 0.25) < 5 * math.sqrt(0.25 * 0.75 / count)

    # A fresh diagram with the same seed, and the same simulator re-initialised, agree exactly.
    sensor2, simulator2 = MakeDiagram(params)
    np.testing.assert_array_equal(Samples(sensor2, simulator2, count), first)
    simulator.get_mutable_context().SetTime(0.0)
    simulator.get_mutable_context().SetDiscreteState(np.array([math.nan]))
    simulator.Initialize()
    np.testing.assert_array_equal(Samples(sensor, simulator, count), first)

    # Another seed differs.
    sensor3, simulator3 = MakeDiagram(SensorParams(noise_std=0.5, seed=6))
    assert not np.allclose(Samples(sensor3, simulator3, 50), first[:50], equal_nan=True)


def test_long_run_stays_finite_when_no_dropout():
    params = SensorParams(noise_std=0.5, seed=1)
    sensor, simulator = MakeDiagram(params)
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    values = []
    for t in np.arange(1.0, 100.0, 0.37):
        simulator.AdvanceTo(t)
        values.append(sensor.GetOutputPort("measured_power").Eval(context)[0])
    values = np.array(values)
    assert np.all(np.isfinite(values))
    # Within 6σ of the true power range [27, 35] W.
    assert np.all((values > 27.0 - 3.0) & (values < 35.0 + 3.0))


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("rate", 0.0, "sensor.rate"),
        ("rate", math.inf, "sensor.rate"),
        ("noise_std", -0.1, "sensor.noise_std"),
        ("dropout_probability", 1.0, "sensor.dropout_probability"),
        ("dropout_probability", -0.1, "sensor.dropout_probability"),
        ("seed", -1, "sensor.seed"),
        ("seed", 1.5, "sensor.seed"),
    ],
)
def test_bad_params_name_the_field(field, value, message):
    params = SensorParams()
    setattr(params, field, value)
    with pytest.raises(ValueError, match=message):
        PowerSensor(params)


# -- averaging sensor ----------------------------------------------------------------------------

H = 0.01  # base step [s]


def AveragedSamples(sensor, simulator, count: int, h: float = H) -> np.ndarray:
    """measured_power after each of the first ``count`` averaged samples (sample k is emitted at
    the last base tick of its interval, ((k + 1) n − 1) h; read half a base step later)."""
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    n = sensor.base_steps_per_sample
    out = np.empty(count)
    for k in range(count):
        simulator.AdvanceTo(((k + 1) * n - 0.5) * h)
        out[k] = sensor.GetOutputPort("measured_power").Eval(context)[0]
    return out


def IntervalMeans(n: int, count: int, h: float = H) -> np.ndarray:
    """(1/n) Σ y(t_j), j = kn … kn + n − 1, of the test's true power, k = 0 … count − 1."""
    ticks = np.arange(count * n) * h
    return TruePower(ticks).reshape(count, n).mean(axis=1)


def test_averaging_functions():
    assert BaseStepsPerSample(10.0, 0.01) == 10
    assert BaseStepsPerSample(20.0, 0.05) == 1
    assert BaseStepsPerSample(1.0 / 0.3, 0.1) == 3
    for rate, h in ((30.0, 0.01), (200.0, 0.01), (15.0, 0.05)):
        with pytest.raises(ValueError, match="sensor.rate"):
            BaseStepsPerSample(rate, h)
    assert AveragedNoiseStd(0.5, 4) == 0.25
    assert AveragedVariance(0.25, 10) == pytest.approx(0.025, rel=1e-15)
    assert ReadingsPerSample(100.0, 10.0) == 10 and ReadingsPerSample(100.0, 20.0) == 5
    for native, rate in ((100.0, 30.0), (10.0, 20.0)):
        with pytest.raises(ValueError, match="sensor.native_rate"):
            ReadingsPerSample(native, rate)
    expected = 30.0 + 2.0 * 0.5 / 5**0.5  # mean of 10 base ticks, noise of 5 readings
    assert AveragedSample(300.0, 10, 2.0, 0.5, 5, False) == pytest.approx(expected)
    assert math.isnan(AveragedSample(300.0, 10, 2.0, 0.5, 5, True))


def test_averaging_needs_the_base_step_and_a_whole_number_of_them():
    with pytest.raises(ValueError, match="time_step"):
        PowerSensor(SensorParams(rate=10.0, averaging=True))
    with pytest.raises(ValueError, match="sensor.rate"):
        PowerSensor(SensorParams(rate=30.0, averaging=True), time_step=H)


def test_averaging_over_one_base_step_is_the_point_sampler_bit_for_bit():
    params = SensorParams(noise_std=0.5, dropout_probability=0.2, seed=4)
    point = Samples(*MakeDiagram(params), 500)
    averaged = dc.replace(params, averaging=True)
    sensor, simulator = MakeDiagram(averaged, time_step=H)
    assert sensor.base_steps_per_sample == 1
    np.testing.assert_array_equal(Samples(sensor, simulator, 500), point)


def test_averaged_samples_are_the_interval_mean_plus_the_seeded_draws():
    params = SensorParams(rate=10.0, noise_std=0.5, dropout_probability=0.1, seed=9, averaging=True)
    sensor, simulator = MakeDiagram(params, time_step=H)
    n = sensor.base_steps_per_sample
    assert n == 10 and sensor.readings_per_sample == 10
    count = 200
    z, u = NoiseBlock(params.seed, 0)
    expected = [
        AveragedSample(m * n, n, float(z[k]), 0.5, 10, bool(u[k] < 0.1))
        for k, m in enumerate(IntervalMeans(n, count))
    ]
    np.testing.assert_allclose(
        AveragedSamples(sensor, simulator, count), expected, rtol=0, atol=1e-12
    )


@pytest.mark.parametrize(
    "rate, h, readings",
    [(10.0, H, 10), (20.0, 0.05, 5)],
    ids=["10 base steps", "one coarse base step"],
)
def test_averaged_noise_has_the_stated_mean_and_variance(rate, h, readings):
    """Υ_k − mean power over the interval ~ N(0, σ²/n), n = native_rate / rate readings (also
    when the interval is one coarse base step): over N = 3000 samples, σ = 0.5 W, fixed seed;
    5-sigma tolerances on the mean (5 √(σ²/(nN))) and on the variance (5 (σ²/n) √(2/N))."""
    sigma, count = 0.5, 3000
    params = SensorParams(rate=rate, noise_std=sigma, seed=21, averaging=True, native_rate=100.0)
    sensor, simulator = MakeDiagram(params, time_step=h)
    assert sensor.readings_per_sample == readings
    m = sensor.base_steps_per_sample
    residual = AveragedSamples(sensor, simulator, count, h) - IntervalMeans(m, count, h)
    variance = sigma**2 / readings
    assert abs(residual.mean()) < 5 * math.sqrt(variance / count)
    assert abs(residual.var() - variance) < 5 * variance * math.sqrt(2.0 / count)
    # Well below the point sampler's σ² = 0.25 W², far outside the tolerance.
    assert residual.var() < 0.5 * sigma**2
