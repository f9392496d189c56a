"""Kalman filter on the energy-model state q (paper 003 Alg. 2 l. 28–29).

Model (the :ref:`scaled form <design-energy-model>`, see :mod:`eaplan_drake.energy.fourier`),
sampled every h [s]:

    q_{k+1} = A_d(T) q_k + B Δg_{k+1} + w_k,   w_k ~ N(0, Q),
    z_k     = C q_k + v_k,                     v_k ~ N(0, R),

with z the measured power [W], Δg the known change of the computation power [W] and
Q = q_n I (+ q_0 on α0: ``mean_process_noise``), R the process and measurement noise
variances [W²] (per step).

With the aperiodic load state (``EstimatorParams.aperiodic_time_constant`` τ > 0) the state is
q = [α0, α1, β1, …, αr, βr, d], A_d gets φ = exp(−h/τ) for d, C a trailing 1, and
Q = diag(q_n, …, q_n, Q_dd) with Q_dd = (q_d τ/2)(1 − φ²) (see
:mod:`eaplan_drake.energy.fourier`); the filter equations below are the same.

One filter step at t_k (a priori estimate q̂⁻, P⁻ for t_k, without the jump Δg_k yet)::

    input:    q̂⁻ ← q̂⁻ + B Δg_k                          (known input; P unchanged)
    update:   u = P⁻ Cᵀ,  s = C u + R,  k = u / s,
              q̂ = q̂⁻ + k (z_k − C q̂⁻),
              P = (I − k C) P⁻ (I − k C)ᵀ + k R kᵀ = P⁻ − (k uᵀ + u kᵀ) + s k kᵀ
                = P⁻ − (k vᵀ + v kᵀ),  v = u − (s/2) k       (Joseph form as rank-1 terms)
              — skipped (prediction only) when z_k is not finite;
    predict:  q̂⁻ ← A_d q̂,  P⁻ ← A_d P A_dᵀ + Q,  symmetrised.

For a scalar measurement the Joseph form needs no m×m product: with u = P⁻Cᵀ it is the
rank-1 expression above, symmetric to the last bit when P⁻ is (k vᵀ + v kᵀ is computed
symmetric). The authors' filter has the covariance sign flipped ((I + KC)) and never
carries P over; this one does neither. The Joseph form with a symmetrised P keeps P symmetric
positive definite.
"""

import copy
import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from eaplan_drake.energy.fourier import (
    InputMemory,
    KnownInputStep,
    ModelOrder,
    OutputMatrix,
    ProcessNoiseMatrix,
    StateSize,
    TransitionMatrices,
)
from eaplan_drake.params import EstimatorParams
from eaplan_drake.ticks import DeclareTickedDiscreteUpdateEvent

__all__ = [
    "EnergyEstimator",
    "KalmanGain",
    "KalmanPredict",
    "KalmanStep",
    "KalmanUpdate",
]


def KalmanPredict(q, P, Ad, Q, out=None, half_Ad=None):
    """Time update: (A_d q, A_d P A_dᵀ + Q) with P symmetrised; q [W], P and Q [W²] (m×m).

    A known input B Δg enters in :func:`KalmanStep`, before the measurement update. ``out``:
    optional (q_out (m,), P_out (m×m)) arrays the result is written into and returned (the same
    values bit for bit; they may be the storage of ``q`` and ``P``, e.g. a system's state).
    ``half_Ad``: ½ A_d precomputed
    (:meth:`~eaplan_drake.energy.fourier.TransitionMatrices.WithHalf`;
    computed here when None). The symmetrised ½ (X + Xᵀ), X = A_d P A_dᵀ, is formed as
    Y + Yᵀ with Y = (½ A_d) P A_dᵀ: scaling by 2⁻¹ commutes with every rounding, so Y = ½ X to
    the bit (no subnormal products at the magnitudes of P [W²]).
    """
    if half_Ad is None:
        half_Ad = 0.5 * Ad
    X = half_Ad.dot(P).dot(Ad.T)  # ndarray.dot: the cheapest call for small matrices
    X += X.T.copy()  # Y + Yᵀ (a contiguous copy of Yᵀ adds faster than the strided view)
    if out is None:
        X += Q
        return Ad.dot(q), X
    q_out, P_out = out
    np.dot(Ad, q, out=q_out)  # numpy buffers the product when q is q_out's own storage
    np.add(X, Q, out=P_out)
    return q_out, P_out


def KalmanGain(P, c, R: float):
    """(k, u, s) for a scalar measurement: u = P cᵀ [W²], s = c u + R [W²], gain k = u / s [-].

    ``c`` is the output row C, shape (m,) [-]; P [W²] (m×m); R [W²]. ``s`` is a numpy float64
    (an array divided by it takes numpy's fast path, not the Python-float one).
    """
    u = P.dot(c)
    s = c.dot(u) + R
    return u / s, u, s


def KalmanUpdate(q, P, c, R: float, z: float):
    """Measurement update with a scalar sample z [W]: Joseph form as rank-1 terms.

    u = P cᵀ, s = c u + R, k = u / s; q̂ = q + k (z − c q),
    P̂ = (I − k c) P (I − k c)ᵀ + k R kᵀ = P − (k uᵀ + u kᵀ) + s k kᵀ = P − (k vᵀ + v kᵀ) with
    v = u − (s/2) k (exactly symmetric for a symmetric P; no m×m product: k vᵀ and v kᵀ are
    outer products, each entry one rounded multiplication, so v kᵀ is (k vᵀ)ᵀ to the bit).
    ``c`` is the output row C, (m,) or (1×m) [-]; R [W²]. A non-finite z (a dropped sample)
    returns (q, P) unchanged (the same objects).
    """
    if not math.isfinite(z):
        return q, P
    c = c.ravel()
    k, u, s = KalmanGain(P, c, R)
    q = q + k * (z - c.dot(q))
    v = u - (0.5 * s) * k
    k_col = k[:, None]
    v_col = v[:, None]
    return q, P - (k_col.dot(v_col.T) + v_col.dot(k_col.T))


def KalmanStep(q_prior, P_prior, z: float, dg: float, Ad, c, Q, R: float, out=None, half_Ad=None):
    """One filter step at t_k: add B Δg_k to α0, update with z_k, predict to t_{k+1}.

    (q_prior [W], P_prior [W²]) is the a priori estimate at t_k, z_k [W] the sample (non-finite:
    prediction only), Δg_k [W] the known change of the computation power, A_d = A_d(T) and
    Q [W²] (m×m) precomputed (:func:`~eaplan_drake.energy.fourier.DiscreteEnergyMatrices`,
    :func:`~eaplan_drake.energy.fourier.ProcessNoiseMatrix`), ``c`` the output row C, R [W²].
    Returns the a priori (q̂⁻, P⁻) for t_{k+1} as new arrays, or written into ``out`` = (q_out,
    P_out) (:func:`KalmanPredict`, as ``half_Ad``; they may be the prior's own storage).
    B = e_0 (Δg enters α0 only).
    """
    q = np.asarray(q_prior, dtype=float)
    if dg != 0.0:
        q = q.copy()
        q[0] += dg
    q, P = KalmanUpdate(q, P_prior, c, R, z)
    return KalmanPredict(q, P, Ad, Q, out, half_Ad)


class EnergyEstimator(LeafSystem):
    """Kalman filter estimating the energy-model state q̂ [W] from the power sensor.

    Runs at ``estimator.rate`` (h = 1/rate; with ``time_step``, the loop's base tick, dividing h
    n ≥ 2 times the event is declared at the tick and acts every n-th, so its times coincide bit
    for bit with the loop's: :func:`~eaplan_drake.ticks.DeclareTickedDiscreteUpdateEvent`) with
    Drake's discrete convention: the state at t_k
    holds the a priori estimate q̂⁻(t_k), P⁻(t_k) (all samples before t_k), and the update at
    t_k applies one :func:`KalmanStep` with z_k = ``measured_power`` [W] (non-finite: prediction
    only), Δg_k = change of ``computation_power`` [W] since the previous step (known input through
    B, so a commanded change is followed without a transient) and A_d for the ``period`` input T
    [s] (re-discretised when T changes, kept per T; non-finite or non-positive T is ignored).
    Q = q_n I (+ q_0 on α0, Q_dd on d) and R from :class:`~eaplan_drake.params.EstimatorParams`;
    P(0) = p0 I.

    Outputs (from the state only): ``energy_coefficients`` q̂ (m = 2r + 1, or 2r + 2 with the
    aperiodic load d last) [W],
    ``estimated_power`` ŷ = C q̂ [W], ``covariance_trace`` tr P [W²], ``mean_power_variance``
    P_00 = Var(α̂0) [W²].
    Discrete state, one group (one read per update): q̂⁻ (m) [W], then P⁻ row-major (m²) [W²],
    then :data:`~eaplan_drake.energy.fourier.InputMemory` (g at the previous step [W], T in use
    [s]); :meth:`Estimate`, :meth:`Covariance` and :meth:`Memory` read its parts.

    .. pydrake_system::

        name: EnergyEstimator
        input_ports:
        - measured_power
        - computation_power
        - period
        output_ports:
        - energy_coefficients
        - estimated_power
        - covariance_trace
        - mean_power_variance
    """

    def __init__(
        self,
        order: int,
        initial_period: float,
        estimator: EstimatorParams | None = None,
        initial_q=None,
        *,
        time_step: float | None = None,
    ):
        super().__init__()
        estimator = EstimatorParams() if estimator is None else estimator
        if not isinstance(estimator, EstimatorParams):
            raise ValueError(
                f"estimator: must be an EstimatorParams, got {type(estimator).__name__}"
            )
        estimator.Validate("estimator")
        estimator = copy.deepcopy(estimator)
        StateSize(order)  # checks the Fourier order r
        model = ModelOrder(order, estimator.aperiodic_time_constant)
        m = StateSize(model)
        T0 = float(initial_period)
        if not (math.isfinite(T0) and T0 > 0.0):
            raise ValueError(f"initial_period: must be finite and > 0, got {initial_period!r}")
        if initial_q is None:
            q0 = np.zeros(m)
        else:
            q0 = np.asarray(initial_q, dtype=float).reshape(-1)
            if q0.size == m - 1 and m % 2 == 0:  # Fourier part only: the aperiodic load d = 0
                q0 = np.append(q0, 0.0)
            if q0.size != m or not np.all(np.isfinite(q0)):
                raise ValueError(
                    f"initial_q: must be {m} finite values (m = 2r + 1 for order {order}, "
                    f"+ 1 with the aperiodic state), got {q0}"
                )
        self._order = int(order)
        self._model = model
        self._m = m
        self._h = 1.0 / estimator.rate
        self._params = estimator
        self._c = OutputMatrix(model)[0]
        self._Q = ProcessNoiseMatrix(
            model,
            estimator.process_noise,
            estimator.mean_process_noise,
            estimator.aperiodic_noise,
            self._h,
        )
        self._R = float(estimator.measurement_noise)
        self._transition = TransitionMatrices(model, self._h)
        # One state group [q̂⁻ | P⁻ row-major | g_prev, T], sliced by these (views, no copy).
        self._q_part = slice(0, m)
        self._P_part = slice(m, m + m * m)
        self._memory_part = slice(m + m * m, m + m * m + 2)
        initial_P = (estimator.initial_covariance * np.eye(m)).reshape(-1)
        self._state_index = self.DeclareDiscreteState(np.concatenate([q0, initial_P, [np.nan, T0]]))
        self._measured_port = self.DeclareVectorInputPort("measured_power", 1)
        self._computation_power_port = self.DeclareVectorInputPort("computation_power", 1)
        self._period_port = self.DeclareVectorInputPort("period", 1)
        self.DeclareInitializationDiscreteUpdateEvent(self._Initialize)
        DeclareTickedDiscreteUpdateEvent(self, self._h, time_step, self._Update)
        state = {self.discrete_state_ticket(self._state_index)}
        self._energy_coefficients_port = self.DeclareVectorOutputPort(
            "energy_coefficients", m, self._CalcCoefficients, prerequisites_of_calc=state
        )
        self._estimated_power_port = self.DeclareVectorOutputPort(
            "estimated_power", 1, self._CalcPower, prerequisites_of_calc=state
        )
        self._covariance_trace_port = self.DeclareVectorOutputPort(
            "covariance_trace", 1, self._CalcTrace, prerequisites_of_calc=state
        )
        self._mean_power_variance_port = self.DeclareVectorOutputPort(
            "mean_power_variance", 1, self._CalcMeanVariance, prerequisites_of_calc=state
        )

    @property
    def order(self) -> int:
        return self._order

    @property
    def model(self):
        """The model structure: r, or ``AugmentedOrder(r, τ)`` with the aperiodic state."""
        return self._model

    @property
    def time_step(self) -> float:
        return self._h

    def EstimatedPower(self, q) -> float:
        """ŷ = C q [W] for energy coefficients q (m,) [W]: the ``estimated_power`` output of
        q = q̂⁻ (also used on logged coefficients, :data:`~eaplan_drake.diagram.LOG_DERIVED`)."""
        return float(self._c.dot(q))

    @property
    def params(self) -> EstimatorParams:
        return self._params

    def _State(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state_index).get_value()

    def Estimate(self, context: Context) -> np.ndarray:
        """A copy of q̂⁻ (m) [W] held in the context's state."""
        return self._State(context)[self._q_part].copy()

    def Covariance(self, context: Context) -> np.ndarray:
        """A copy of P⁻ (m×m) [W²] held in the context's state."""
        m = self._m
        return self._State(context)[self._P_part].reshape(m, m).copy()

    def Memory(self, context: Context) -> InputMemory:
        """A copy of the memory (g at the previous step [W], T in use [s])."""
        return InputMemory(self._State(context)[self._memory_part].copy())

    def _Initialize(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = discrete_state.get_mutable_value(self._state_index)
        memory = InputMemory(x[self._memory_part])
        g = self._computation_power_port.Eval(context)[0]
        T = self._period_port.Eval(context)[0]
        memory.previous_computation_power = g if math.isfinite(g) else np.nan
        if math.isfinite(T) and T > 0.0:
            memory.period = T

    def _Update(self, context: Context, discrete_state: DiscreteValues):
        # Drake fills discrete_state with the context's current values before this handler
        # (LeafSystem::DispatchDiscreteVariableUpdateHandler): read and write it in place.
        x = discrete_state.get_mutable_value(self._state_index)
        q = x[self._q_part]  # views of the state: the step writes its result in place
        P = x[self._P_part].reshape(self._m, self._m)
        memory = x[self._memory_part]
        z = self._measured_port.Eval(context)[0]
        g = self._computation_power_port.Eval(context)[0]
        T = self._period_port.Eval(context)[0]
        dg = KnownInputStep(memory, g, T)
        Ad, half_Ad = self._transition.WithHalf(memory[1])
        KalmanStep(q, P, z, dg, Ad, self._c, self._Q, self._R, out=(q, P), half_Ad=half_Ad)
        return None

    def _CalcCoefficients(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._State(context)[self._q_part])

    def _CalcPower(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self.EstimatedPower(self._State(context)[self._q_part]))

    def _CalcTrace(self, context: Context, output: BasicVector) -> None:
        P = self._State(context)[self._P_part]
        output.SetAtIndex(0, float(P[:: self._m + 1].sum()))

    def _CalcMeanVariance(self, context: Context, output: BasicVector) -> None:
        P = self._State(context)[self._P_part]
        output.SetAtIndex(0, float(P[0]))  # P_00: Var(α̂0) [W²]
