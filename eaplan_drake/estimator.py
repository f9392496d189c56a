"""Kalman filter on the energy-model state q (paper 003 Alg. 2 l. 28–29).

Model (scaled form of DESIGN.md, see :mod:`eaplan_drake.energy_model`), sampled every h [s]:

    q_{k+1} = A_d(T) q_k + B Δg_{k+1} + w_k,   w_k ~ N(0, Q),
    z_k     = C q_k + v_k,                     v_k ~ N(0, R),

with z the measured power [W], Δg the known change of the computation power [W] and
Q = q_n I (+ q_0 on α0: ``mean_process_noise``), R the process and measurement noise
variances [W²] (per step).

With the aperiodic load state (``EstimatorParams.aperiodic_time_constant`` τ > 0) the state is
q = [α0, α1, β1, …, αr, βr, d], A_d gets φ = exp(−h/τ) for d, C a trailing 1, and
Q = diag(q_n, …, q_n, Q_dd) with Q_dd = (q_d τ/2)(1 − φ²) (see
:mod:`eaplan_drake.energy_model`); the filter equations below are the same.

One filter step at t_k (a priori estimate q̂⁻, P⁻ for t_k, without the jump Δg_k yet):

    input:    q̂⁻ ← q̂⁻ + B Δg_k                          (known input; P unchanged)
    update:   s = C P⁻ Cᵀ + R,  K = P⁻ Cᵀ / s,
              q̂ = q̂⁻ + K (z_k − C q̂⁻),
              P = (I − K C) P⁻ (I − K C)ᵀ + K R Kᵀ       (Joseph form), symmetrised
              — skipped (prediction only) when z_k is not finite;
    predict:  q̂⁻ ← A_d q̂,  P⁻ ← A_d P A_dᵀ + Q,  symmetrised.

The authors' filter has the covariance sign flipped ((I + KC)) and never carries P over; this
one does neither. The Joseph form with a symmetrised P keeps P symmetric positive definite.
"""

import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from eaplan_drake.energy_model import (
    AperiodicProcessNoise,
    DiscreteEnergyMatrices,
    OutputMatrix,
    StateSize,
)
from eaplan_drake.params import EstimatorParams

__all__ = [
    "EnergyEstimator",
    "KalmanPredict",
    "KalmanStep",
    "KalmanUpdate",
]


def KalmanPredict(q, P, Ad, Q, B=None, dg: float = 0.0):
    """Time update: (A_d q + B Δg, A_d P A_dᵀ + Q), P symmetrised."""
    q = Ad @ q
    if B is not None and dg != 0.0:
        q = q + np.reshape(B, -1) * dg
    P = Ad @ P @ Ad.T + Q
    return q, 0.5 * (P + P.T)


def KalmanUpdate(q, P, C, R: float, z: float):
    """Measurement update with a scalar sample z [W], Joseph form, P symmetrised.

    A non-finite z (a dropped sample) returns (q, P) unchanged.
    """
    if not math.isfinite(z):
        return q, P
    c = np.reshape(C, -1)
    u = P @ c
    s = float(c @ u) + R
    K = u / s
    q = q + K * (z - float(c @ q))
    L = np.eye(c.size) - K[:, None] * c
    P = L @ P @ L.T + (R * K)[:, None] * K
    return q, 0.5 * (P + P.T)


def KalmanStep(q_prior, P_prior, z: float, dg: float, Ad, C, Q, R: float):
    """One filter step at t_k: add B Δg_k to α0, update with z_k, predict to t_{k+1}.

    Returns the a priori (q̂⁻, P⁻) for t_{k+1}. B = e_0 (Δg enters α0 only).
    """
    q = np.array(q_prior, dtype=float)
    q[0] += dg
    q, P = KalmanUpdate(q, P_prior, C, R, z)
    return KalmanPredict(q, P, Ad, Q)


class EnergyEstimator(LeafSystem):
    """Kalman filter estimating the energy-model state q̂ [W] from the power sensor.

    Runs at ``estimator.rate`` (h = 1/rate) with Drake's discrete convention: the state at t_k
    holds the a priori estimate q̂⁻(t_k), P⁻(t_k) (all samples before t_k), and the update at
    t_k applies one :func:`KalmanStep` with z_k = ``measured_power`` [W] (non-finite: prediction
    only), Δg_k = change of ``computation_power`` [W] since the previous step (known input through
    B, so a commanded change is followed without a transient) and A_d for the ``period`` input T
    [s] (re-discretised when T changes; non-finite or non-positive T is ignored). Q = q_n I and R
    from :class:`EstimatorParams`; P(0) = p0 I.

    Outputs (from the state only): ``energy_coefficients`` q̂ (m = 2r + 1, or 2r + 2 with the
    aperiodic load d last) [W],
    ``estimated_power`` ŷ = C q̂ [W], ``covariance_trace`` tr P [W²], ``mean_power_variance``
    P_00 = Var(α̂0) [W²].
    Discrete state (one vector): [q̂ (m), P row-major (m²), g at the previous step, T in use].

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
    ):
        super().__init__()
        estimator = EstimatorParams() if estimator is None else estimator
        if not isinstance(estimator, EstimatorParams):
            raise ValueError(
                f"estimator: must be an EstimatorParams, got {type(estimator).__name__}"
            )
        estimator.Validate("estimator")
        StateSize(order)  # checks the Fourier order r
        model = estimator.ModelOrder(order)
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
        self._q_diag = np.full(m, float(estimator.process_noise))
        self._q_diag[0] += float(estimator.mean_process_noise)
        if m % 2 == 0:
            self._q_diag[-1] = AperiodicProcessNoise(model, estimator.aperiodic_noise, self._h)
        self._R = float(estimator.measurement_noise)
        self._eye = np.eye(m)
        self._Ad_period = T0
        self._Ad = DiscreteEnergyMatrices(model, T0, self._h)[0]
        self._AdT = self._Ad.T.copy()
        self._diag = np.arange(m) * (m + 1)  # flat indices of diag(P)
        state = np.concatenate(
            [q0, (estimator.initial_covariance * np.eye(m)).reshape(-1), [np.nan, T0]]
        )
        self._state_index = self.DeclareDiscreteState(state)
        self._measured_port = self.DeclareVectorInputPort("measured_power", 1)
        self._computation_power_port = self.DeclareVectorInputPort("computation_power", 1)
        self._period_port = self.DeclareVectorInputPort("period", 1)
        self.DeclareInitializationDiscreteUpdateEvent(self._Initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(self._h, 0.0, self._Update)
        xd = {self.xd_ticket()}
        self._energy_coefficients_port = self.DeclareVectorOutputPort(
            "energy_coefficients", m, self._CalcCoefficients, prerequisites_of_calc=xd
        )
        self._estimated_power_port = self.DeclareVectorOutputPort(
            "estimated_power", 1, self._CalcPower, prerequisites_of_calc=xd
        )
        self._covariance_trace_port = self.DeclareVectorOutputPort(
            "covariance_trace", 1, self._CalcTrace, prerequisites_of_calc=xd
        )
        self._mean_power_variance_port = self.DeclareVectorOutputPort(
            "mean_power_variance", 1, self._CalcMeanVariance, prerequisites_of_calc=xd
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

    @property
    def params(self) -> EstimatorParams:
        return self._params

    def Covariance(self, context: Context) -> np.ndarray:
        """P⁻ (m×m) [W²] held in the context's state."""
        m = self._m
        x = context.get_discrete_state(self._state_index).get_value()
        return x[m : m + m * m].reshape(m, m).copy()

    def _Initialize(self, context: Context, discrete_state: DiscreteValues) -> None:
        m = self._m
        x = context.get_discrete_state(self._state_index).get_value().copy()
        g = self._computation_power_port.Eval(context)[0]
        T = self._period_port.Eval(context)[0]
        x[m + m * m] = g if math.isfinite(g) else np.nan
        if math.isfinite(T) and T > 0.0:
            x[m + m * m + 1] = T
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(x)

    def _Update(self, context: Context, discrete_state: DiscreteValues) -> None:
        m = self._m
        mm = m * m
        x = context.get_discrete_state(self._state_index).get_value()
        z = self._measured_port.Eval(context)[0]
        g = self._computation_power_port.Eval(context)[0]
        T = self._period_port.Eval(context)[0]
        if not (T > 0.0 and math.isfinite(T)):
            T = x[m + mm + 1]
        if T != self._Ad_period:  # cache of a pure function of T
            self._Ad = DiscreteEnergyMatrices(self._model, T, self._h)[0]
            self._AdT = self._Ad.T.copy()
            self._Ad_period = T
        Ad, c, R = self._Ad, self._c, self._R
        q = x[:m].copy()
        P = x[m : m + mm].reshape(m, m)
        g_prev = x[m + mm]
        if math.isfinite(g):
            if math.isfinite(g_prev):
                q[0] += g - g_prev
            g_prev = g
        # Same arithmetic as KalmanStep (KalmanUpdate then KalmanPredict), inlined for speed.
        if math.isfinite(z):
            u = P @ c
            K = u / (c @ u + R)
            q += K * (z - c @ q)
            L = self._eye - K[:, None] * c
            P = L @ P @ L.T + (R * K)[:, None] * K
            P = 0.5 * (P + P.T)
        q = Ad @ q
        P = Ad @ P @ self._AdT
        P = 0.5 * (P + P.T)
        new = np.empty(m + mm + 2)
        new[:m] = q
        flat = new[m : m + mm]
        flat[:] = P.reshape(-1)
        flat[self._diag] += self._q_diag
        new[m + mm] = g_prev
        new[m + mm + 1] = T
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(new)

    def _CalcCoefficients(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state_index).get_value()[: self._m])

    def _CalcPower(self, context: Context, output: BasicVector) -> None:
        x = context.get_discrete_state(self._state_index).get_value()
        output.SetAtIndex(0, float(self._c @ x[: self._m]))

    def _CalcTrace(self, context: Context, output: BasicVector) -> None:
        m = self._m
        x = context.get_discrete_state(self._state_index).get_value()
        output.SetAtIndex(0, float(x[m : m + m * m][self._diag].sum()))

    def _CalcMeanVariance(self, context: Context, output: BasicVector) -> None:
        x = context.get_discrete_state(self._state_index).get_value()
        output.SetAtIndex(0, float(x[self._m]))  # P_00: Var(α̂0) [W²]
