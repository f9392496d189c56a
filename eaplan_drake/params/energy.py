"""The energy loop's parameters: computation load, energy model, battery (and its scripted
faults), power sensor and estimator."""

import dataclasses as dc

from eaplan_drake.params.bounds import (
    MAX_COMPUTATION_PARAMETERS,
    MAX_FAULTS,
    MAX_POWER_OFFSET,
    MAX_RATE,
    MAX_VARIANCE,
    MIN_BATTERY_HEALTH,
)
from eaplan_drake.params.checks import (
    _at_most,
    _check,
    _in_range,
    _is_int,
    _nonnegative,
    _positive,
    _vector,
)
from eaplan_drake.params.walk import _Params
from eaplan_drake.registry import BATTERY_MODELS


@dc.dataclass
class ComputationParams(_Params):
    """Computation power g(c2) from a measured powprofiler table (paper 003 Sec. III-B)."""

    table: str = "pednet_jetson_nano"
    """A packaged table name (``pednet_jetson_nano``, ``two_parameters``) or a CSV path."""
    initial_parameters: list[float] = dc.field(default_factory=lambda: [10.0])
    """c2(0), one entry per computation parameter (σ of them) [table units, e.g. fps]."""
    integer: bool = True
    """Parameters take only the table's grid values (fps); the planner maps relaxed values back."""
    power_offset: float = 0.0
    """ΔP, how far the payload's true power is off the table [W], in [-100, 100]: the aircraft
    draws g(c2) + ΔP, while the estimator and the planner know g(c2) only. 0 (default): the
    table is exact."""

    def Validate(self, key: str = "computation") -> None:
        _check(bool(self.table), f"{key}.table", "must name a table")
        _check(len(self.initial_parameters) >= 1, f"{key}.initial_parameters", "needs >= 1 entry")
        _check(
            len(self.initial_parameters) <= MAX_COMPUTATION_PARAMETERS,
            f"{key}.initial_parameters",
            f"at most {MAX_COMPUTATION_PARAMETERS} entries, got {len(self.initial_parameters)}",
        )
        _vector(self.initial_parameters, f"{key}.initial_parameters")
        _in_range(self.power_offset, f"{key}.power_offset", -MAX_POWER_OFFSET, MAX_POWER_OFFSET)


@dc.dataclass
class EnergyModelParams(_Params):
    """Periodic energy model (paper 003 Eqs. 3–12), scaled form y = C q with q in W."""

    order: int = 3
    """r, Fourier order (state size m = 2r + 1), in [0, 20]."""
    initial_period: float = 46.0
    """T, first guess of the period [s] until one is measured in flight."""
    initial_coefficients: list[float] = dc.field(default_factory=list)
    """q(0) [W] (m entries) or empty: α0 = initial_mean_power, harmonics zero."""
    initial_mean_power: float = 30.0
    """α0(0) [W] used when initial_coefficients is empty."""

    def Validate(self, key: str = "energy_model") -> None:
        _check(
            _is_int(self.order) and 0 <= self.order <= 20,
            f"{key}.order",
            f"must be an integer in [0, 20], got {self.order!r}",
        )
        _positive(self.initial_period, f"{key}.initial_period")
        if self.initial_coefficients:
            _vector(self.initial_coefficients, f"{key}.initial_coefficients", 2 * self.order + 1)
        _nonnegative(self.initial_mean_power, f"{key}.initial_mean_power")


@dc.dataclass
class BatteryFault(_Params):
    """A sudden loss of state of charge at a given time."""

    time: float = 0.0
    """When [s]."""
    soc_drop: float = 0.0
    """How much SoC is lost [-], in (0, 1] (0.06 is −6 %)."""


PHYSICAL_K_B = 1.0 / 3600.0
"""k_b of a real battery [h/s]: one ampere drains one ampere-hour in 3600 s."""

AUTHORS_K_B = 0.00183
"""The authors' scaling: the k_b of the papers' reference numbers [h/s], 6.59 × the physical
1/3600 (a 3.2 Ah, 14.8 V pack then holds 7.19 Wh, not 47.4 Wh). The four reference scenarios
(``plan_I``, ``plan_II``, ``plan_i``, ``plan_ii``) set it so that they reproduce the papers."""

NOMINAL_CELL_VOLTAGE = 3.7
"""Nominal voltage of one lithium-polymer cell [V]: an nS pack is n × 3.7 V."""

_DEFAULT_CAPACITY = 3.2
_DEFAULT_VOLTAGE = 14.8


@dc.dataclass
class BatteryParams(_Params):
    """Rint equivalent circuit (paper 003 Lemma III.3): ḃ = −k_b I(y) / Q_c.

    A pack is entered as on its label: a capacity (``capacity`` [Ah] or ``capacity_mah`` [mAh])
    or an energy (``energy_wh`` [Wh]), and a voltage (``cells``, nS at
    :data:`NOMINAL_CELL_VOLTAGE`, or ``voltage`` [V]). :meth:`Capacity` and :meth:`Voltage` are
    the Q_c and V the model uses; the energy a full pack delivers is Q_c V / k_b [J]
    (:meth:`Energy`)."""

    voltage: float = _DEFAULT_VOLTAGE
    """V, internal (open-circuit) voltage [V], unless ``cells`` gives it."""
    internal_resistance: float = 0.0012
    """R_r [Ω]."""
    capacity: float = _DEFAULT_CAPACITY
    """Q_c, nominal capacity [Ah], unless ``capacity_mah`` or ``energy_wh`` gives it."""
    capacity_mah: float = 0.0
    """Q_c as on the label [mAh]; 0 (default): not given."""
    energy_wh: float = 0.0
    """The pack's energy as on the label [Wh] (Q_c = energy_wh / V); 0 (default): not given."""
    cells: int = 0
    """Cells in series, nS (V = n × 3.7 V); 0 (default): not given, ``voltage`` holds."""
    k_b: float = PHYSICAL_K_B
    """Ah-to-seconds conversion [h/s]: the physical 1/3600 (default); the papers' reference numbers
    use the authors' scaling :data:`AUTHORS_K_B` = 0.00183."""
    initial_soc: float = 1.0
    """b(0) [-], in (0, 1]."""
    reserve_soc: float = 0.30
    """Reserve: the flight fails if b reaches it before the survey ends [-], in [0, 1)."""
    faults: list[BatteryFault] = dc.field(default_factory=list)
    """Sudden SoC drops (plan i: −6 % at 93 s, −9 % at 270 s)."""
    model: str = "rint"
    """Battery model, one of :data:`~eaplan_drake.registry.BATTERY_MODELS` (``rint``: the Rint
    circuit above); the battery system and the planner's prediction both use it."""
    health: float = 1.0
    """The pack's usable fraction of its nominal capacity [-], in [0.1, 1] (a pack's is
    0.8–1.0 with age and temperature): the battery system discharges a capacity of
    health · Q_c, and its SoC is the fraction of that; the planner keeps the nominal Q_c.
    1 (default): the pack is as labelled."""

    def ForgetLabel(self, given) -> None:
        """Before a layer that gives the keys ``given`` (a mapping or key names) is loaded over
        these parameters: a size it gives (``capacity``, ``capacity_mah``, ``energy_wh``)
        replaces the size held here, a voltage (``cells``, ``voltage``) the voltage, so that
        ``--set battery.capacity_mah=3300`` over a scenario that states ``capacity`` is the new
        pack, not two sizes."""
        given = set(given)
        if given & {"capacity", "capacity_mah", "energy_wh"}:
            self.capacity, self.capacity_mah, self.energy_wh = _DEFAULT_CAPACITY, 0.0, 0.0
        if given & {"cells", "voltage"}:
            self.cells, self.voltage = 0, _DEFAULT_VOLTAGE

    def Voltage(self) -> float:
        """V [V]: ``cells`` × :data:`NOMINAL_CELL_VOLTAGE` when ``cells`` is given, else
        ``voltage``."""
        return self.cells * NOMINAL_CELL_VOLTAGE if self.cells > 0 else float(self.voltage)

    def Capacity(self) -> float:
        """Q_c [Ah]: from ``capacity_mah``, ``energy_wh`` / V or ``capacity``, whichever is
        given."""
        if self.capacity_mah > 0.0:
            return self.capacity_mah / 1000.0
        if self.energy_wh > 0.0:
            return self.energy_wh / self.Voltage()
        return float(self.capacity)

    def Energy(self) -> float:
        """Energy of a full pack at the internal voltage, Q_c V / k_b [J] (3600 Q_c V with the
        physical k_b)."""
        return self.Capacity() * self.Voltage() / self.k_b

    def Validate(self, key: str = "battery") -> None:
        BATTERY_MODELS.Check(self.model, f"{key}.model")
        _positive(self.voltage, f"{key}.voltage")
        _positive(self.internal_resistance, f"{key}.internal_resistance")
        _positive(self.capacity, f"{key}.capacity")
        _nonnegative(self.capacity_mah, f"{key}.capacity_mah")
        _nonnegative(self.energy_wh, f"{key}.energy_wh")
        _check(
            _is_int(self.cells) and 0 <= self.cells <= 100,
            f"{key}.cells",
            f"must be an integer in [0, 100] (0: not given), got {self.cells!r}",
        )
        given = [name for name in ("capacity_mah", "energy_wh") if getattr(self, name) > 0.0]
        if self.capacity != _DEFAULT_CAPACITY:
            given.insert(0, "capacity")
        _check(
            len(given) <= 1,
            f"{key}.{given[-1] if given else 'capacity'}",
            f"give the pack's size once (capacity, capacity_mah or energy_wh), got "
            f"{' and '.join(given)}",
        )
        _check(
            self.cells == 0
            or self.voltage in (_DEFAULT_VOLTAGE, self.cells * NOMINAL_CELL_VOLTAGE),
            f"{key}.cells",
            f"{self.cells}S is {self.cells * NOMINAL_CELL_VOLTAGE:g} V nominal but {key}.voltage "
            f"is {self.voltage:g}; give one of the two",
        )
        _positive(self.k_b, f"{key}.k_b")
        _in_range(self.health, f"{key}.health", MIN_BATTERY_HEALTH, 1.0)
        _in_range(self.initial_soc, f"{key}.initial_soc", 1e-9, 1.0)
        _in_range(self.reserve_soc, f"{key}.reserve_soc", 0.0, 1.0 - 1e-9)
        _check(
            len(self.faults) <= MAX_FAULTS,
            f"{key}.faults",
            f"at most {MAX_FAULTS} faults, got {len(self.faults)}",
        )
        for i, f in enumerate(self.faults):
            _nonnegative(f.time, f"{key}.faults[{i}].time")
            _in_range(f.soc_drop, f"{key}.faults[{i}].soc_drop", 1e-12, 1.0)


@dc.dataclass
class SensorParams(_Params):
    """Power sensor Υ = P_motion + P_computation + noise, sampled periodically."""

    rate: float = 100.0
    """Sampling rate [Hz]."""
    noise_std: float = 0.5
    """Standard deviation of the additive Gaussian noise [W]."""
    dropout_probability: float = 0.0
    """Probability that a sample is lost (output NaN) [-], in [0, 1)."""
    seed: int = 0
    """Seed of the noise and dropout generator, an integer >= 0."""
    averaging: bool = False
    """False (default): each sample is the power at the sample time plus noise of σ =
    ``noise_std``. True: each sample is the mean of the n = native_rate / rate readings of its
    interval, the mean power over it plus noise of σ/√n, and the estimator's R becomes
    ``estimator.measurement_noise`` / n (:mod:`eaplan_drake.energy.sensor`): a sensor reporting
    below
    its native rate, or a simulation on a coarser ``simulation.max_step``, then loses no
    information. Needs rate <= 1 / max_step and estimator.rate <= rate."""
    native_rate: float = 100.0
    """f_r, rate of the readings whose noise is σ = ``noise_std`` [Hz] (the paper's 100 Hz);
    used with ``averaging`` (an integer multiple of ``rate``)."""

    def Validate(self, key: str = "sensor") -> None:
        _positive(self.rate, f"{key}.rate")
        _at_most(self.rate, f"{key}.rate", MAX_RATE, "Hz", "bounds the events per second")
        _nonnegative(self.noise_std, f"{key}.noise_std")
        _positive(self.native_rate, f"{key}.native_rate")
        _at_most(self.native_rate, f"{key}.native_rate", MAX_RATE, "Hz", "bounds the readings")
        _in_range(self.dropout_probability, f"{key}.dropout_probability", 0.0, 1.0 - 1e-9)
        _check(
            _is_int(self.seed) and self.seed >= 0,
            f"{key}.seed",
            f"must be an integer >= 0, got {self.seed!r}",
        )


@dc.dataclass
class EstimatorParams(_Params):
    """Discrete Kalman filter on q (paper 003 Alg. 2 l. 28–29), Joseph-form update."""

    rate: float = 100.0
    """Update rate [Hz] (the sensor's)."""
    initial_covariance: float = 100.0
    """P(0) = p0 · I [W²]."""
    process_noise: float = 1e-6
    """Q = q · I per step [W²]. 1e-6 at 100 Hz keeps \\|ŷ − y\\| < 0.3 W on a σ = 0.5 W sensor
    (1e-4 lets ŷ wander by ≈ ±0.3 W) and still follows an unannounced 1 W step of the mean
    to 1/e in ≈ 1.2 s."""
    measurement_noise: float = 0.25
    """R, variance of the power sensor [W²] (σ = 0.5 W → 0.25)."""
    mean_process_noise: float = 0.0
    """Extra random-walk variance per step on the mean power α0 [W²]: Q_00 = process_noise +
    mean_process_noise (a slowly drifting level, e.g. battery sag or wind change)."""
    aperiodic_time_constant: float = 0.0
    """τ of the aperiodic (AR(1), first-order Gauss–Markov) load state d [s]; 0 = no such state
    (the paper's model, the default), ``.inf`` = random walk. Opt-in: see
    :mod:`eaplan_drake.energy.fourier`; the planner's prediction uses the same model."""
    aperiodic_noise: float = 0.0
    """q_d, intensity of the aperiodic load's driving noise [W²/s] (stationary variance
    q_d τ / 2); used only when aperiodic_time_constant > 0."""

    def Validate(self, key: str = "estimator") -> None:
        _positive(self.rate, f"{key}.rate")
        _at_most(self.rate, f"{key}.rate", MAX_RATE, "Hz", "bounds the events per second")
        _positive(self.initial_covariance, f"{key}.initial_covariance")
        _at_most(
            self.initial_covariance, f"{key}.initial_covariance", MAX_VARIANCE, "W²", "numerics"
        )
        _nonnegative(self.process_noise, f"{key}.process_noise")
        _at_most(self.process_noise, f"{key}.process_noise", MAX_VARIANCE, "W²", "numerics")
        _positive(self.measurement_noise, f"{key}.measurement_noise")
        _at_most(self.measurement_noise, f"{key}.measurement_noise", MAX_VARIANCE, "W²", "numerics")
        tau = self.aperiodic_time_constant
        _check(
            isinstance(tau, (int, float)) and not isinstance(tau, bool) and tau >= 0.0,
            f"{key}.aperiodic_time_constant",
            f"must be >= 0 [s] (0: none, .inf: random walk), got {tau!r}",
        )
        _nonnegative(self.aperiodic_noise, f"{key}.aperiodic_noise")
        _at_most(self.aperiodic_noise, f"{key}.aperiodic_noise", MAX_VARIANCE, "W²/s", "numerics")
        _nonnegative(self.mean_process_noise, f"{key}.mean_process_noise")
        _at_most(
            self.mean_process_noise, f"{key}.mean_process_noise", MAX_VARIANCE, "W²/s", "numerics"
        )
