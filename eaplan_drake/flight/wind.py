"""Wind that changes in flight: Dryden gusts on a drifting mean wind (``wind.gusts``,
``wind.drift``; off by default).

The wind the aircraft flies in is w(t) = w̄(t) + R(ψ) [u, v] [m/s]: the mean wind w̄ and the gusts
u (longitudinal, along the heading ψ) and v (lateral, to its left), R(ψ) the rotation by ψ.

Gusts (the Dryden model, the low-altitude forms of MIL-HDBK-1797). With σ = σ_u = σ_v [m/s], the
length scales L_u = L, L_v = L / 2 [m] and the airspeed V [m/s], the one-sided power spectral
densities over the angular frequency ω [rad/s] (∫₀^∞ Φ dω = σ²) are

    Φ_u(ω) = σ² (2 L_u / (π V)) / (1 + (L_u ω / V)²),
    Φ_v(ω) = σ² (2 L_v / (π V)) (1 + 12 (L_v ω / V)²) / (1 + 4 (L_v ω / V)²)²,

the outputs of the shaping filters

    H_u(s) = σ sqrt(2 L_u / (π V)) / (1 + (L_u / V) s),
    H_v(s) = σ sqrt(2 L_v / (π V)) (1 + 2√3 (L_v / V) s) / (1 + 2 (L_v / V) s)²

driven by unit white noise. With λ = V / L (L_u / V = 2 L_v / V = 1/λ) they are realised as
u = σ √(2λ) x_u and v = σ √λ (√3 x_1 + λ (1 − √3) x_2) of the states

    ẋ_u = −λ x_u + η_u,   ẋ_1 = −λ x_1 + η_v,   ẋ_2 = −λ x_2 + x_1,

whose stationary covariance P∞ = diag(1/(2λ), [[1/(2λ), 1/(4λ²)], [1/(4λ²), 1/(4λ³)]]) gives u and
v the variance σ² each. Sampled every h [s] the states follow x_{k+1} = Φ x_k + G z_k exactly, with
z_k ~ N(0, I₃), Φ = e^{−λh} diag(1, [[1, 0], [h, 1]]) and G Gᵀ = Q_d = ∫₀^h e^{As} B Bᵀ e^{Aᵀs} ds
(closed form in :func:`DrydenFilter`); x₀ ~ N(0, P∞), so the gusts are stationary from t = 0 and
the samples are those of the continuous process (:func:`GustSeries`). The MIL-HDBK-1797
low-altitude scales for an altitude and a wind at 20 ft are :func:`LowAltitudeTurbulence`.

Drift. Every step h the mean wind's speed s and direction θ (where it blows towards) change by a
ramp and a random walk,

    s_{k+1} = clip(s_k + ṡ h/60 + σ_s sqrt(h/60) z, 0, s_max),   θ_{k+1} = θ_k + θ̇ h/60 + σ_θ
    sqrt(h/60) z',

with ṡ [m/s per minute], θ̇ [deg per minute] and σ_s, σ_θ the standard deviations of the change
over one minute (:class:`~eaplan_drake.params.WindDriftParams`); s_max is below the airspeed.

Draws. The standard normal draws are a pure function of (seed, step): blocks of
:data:`BLOCK_SIZE` steps, block j from ``np.random.default_rng([seed, j, WIND_STREAM])``; draw 0
sets x₀, draw k + 1 the step from t_k. The same seed gives the same wind in every run.

:class:`WindSource` is the system (a discrete state stepped every h, the plant's step).
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource

from eaplan_drake.params import SimulationParams, VehicleParams, WindParams

__all__ = [
    "AddWindSource",
    "BLOCK_SIZE",
    "BodyToEarth",
    "DriftIncrements",
    "DriftStep",
    "DrydenFilter",
    "DrydenSpectra",
    "GustFilter",
    "GustOutput",
    "GustSeries",
    "GustStart",
    "GustStep",
    "LowAltitudeTurbulence",
    "WIND_STREAM",
    "WindDraws",
    "WindSource",
]

BLOCK_SIZE = 4096
"""Steps per pre-generated block of draws."""
WIND_STREAM = 0x57494E44
"""The third word of the wind's seed sequence ("WIND"), so that its draws differ from the power
sensor's under the same seed."""
_FEET = 0.3048
"""[m] per foot."""


def DrydenSpectra(omega, sigma: float, length_scale: float, airspeed: float):
    """(Φ_u(ω), Φ_v(ω)) [(m/s)² per rad/s], the one-sided Dryden densities of the module
    docstring at the angular frequencies ω [rad/s], for σ [m/s], L = L_u = 2 L_v [m] and the
    airspeed V [m/s] (numpy-broadcasting)."""
    w = np.asarray(omega, dtype=float)
    lu, lv = float(length_scale), 0.5 * float(length_scale)
    a_u = lu * w / airspeed
    a_v = lv * w / airspeed
    phi_u = sigma**2 * (2.0 * lu / (math.pi * airspeed)) / (1.0 + a_u**2)
    phi_v = (
        sigma**2
        * (2.0 * lv / (math.pi * airspeed))
        * (1.0 + 12.0 * a_v**2)
        / (1.0 + 4.0 * a_v**2) ** 2
    )
    return phi_u, phi_v


def LowAltitudeTurbulence(altitude: float, wind_at_20ft: float) -> tuple[float, float]:
    """(σ_u [m/s], L_u [m]) of MIL-HDBK-1797's low-altitude model (altitude h below 1000 ft):
    σ_w = 0.1 W₂₀, σ_u = σ_w / (0.177 + 0.000823 h)^0.4 and L_u = h / (0.177 + 0.000823 h)^1.2
    with h in ft, for ``altitude`` [m] in (0, 304.8] and the wind ``wind_at_20ft`` W₂₀ [m/s]
    (light turbulence: 15 kn = 7.7 m/s; moderate: 30 kn; severe: 45 kn)."""
    h = float(altitude) / _FEET
    if not (0.0 < h <= 1000.0):
        raise ValueError(f"LowAltitudeTurbulence: altitude must be in (0, 304.8] m, got {altitude}")
    if not (math.isfinite(wind_at_20ft) and wind_at_20ft >= 0.0):
        raise ValueError(f"LowAltitudeTurbulence: wind_at_20ft must be >= 0, got {wind_at_20ft}")
    base = 0.177 + 0.000823 * h
    return 0.1 * float(wind_at_20ft) / base**0.4, h / base**1.2 * _FEET


@dc.dataclass(frozen=True)
class GustFilter:
    """The exact discrete Dryden filter of the module docstring for one (σ, L, V, h), as the
    entries :func:`GustStep` and :func:`GustOutput` read (Python floats: a step is a few
    multiplications, no numpy call)."""

    decay: float
    """e^{−λh} [-]: Φ = e^{−λh} diag(1, [[1, 0], [h, 1]])."""
    step: float
    """h [s]."""
    noise_gain: tuple
    """(g_u, g_11, g_21, g_22): G = diag(g_u, [[g_11, 0], [g_21, g_22]]), G Gᵀ = Q_d."""
    stationary_gain: tuple
    """The same entries of the lower-triangular factor of P∞: x₀ = it · z₀."""
    output: tuple
    """(c_u, c_1, c_2) [m/s]: u = c_u x_u, v = c_1 x_1 + c_2 x_2."""

    def Matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Φ, G, P∞ factor, C) as arrays (3×3, 3×3, 3×3, 2×3)."""
        e, h = self.decay, self.step
        phi = np.array([[e, 0.0, 0.0], [0.0, e, 0.0], [0.0, h * e, e]])
        cu, c1, c2 = self.output
        return (
            phi,
            _Lower(self.noise_gain),
            _Lower(self.stationary_gain),
            np.array([[cu, 0.0, 0.0], [0.0, c1, c2]]),
        )


def _Lower(entries) -> np.ndarray:
    a, b, c, d = entries
    return np.array([[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, c, d]])


def _Factor(diagonal: float, block: np.ndarray) -> tuple:
    """(√diagonal, the Cholesky factor's entries l_11, l_21, l_22 of the 2×2 ``block``)."""
    low = np.linalg.cholesky(block)
    return (math.sqrt(diagonal), float(low[0, 0]), float(low[1, 0]), float(low[1, 1]))


def DrydenFilter(sigma: float, length_scale: float, airspeed: float, step: float) -> GustFilter:
    """The :class:`GustFilter` for σ [m/s], L [m], V [m/s] and the step h [s]: with λ = V/L,
    e = e^{−λh} and x = 2λh,

        Φ = e · diag(1, [[1, 0], [h, 1]]),
        Q_d = diag(I₀, [[I₀, I₁], [I₁, I₂]]),
        I₀ = (1 − e²)/(2λ),  I₁ = (1 − e² (1 + x))/(4λ²),  I₂ = (2 − e² (2 + 2x + x²))/(8λ³)

    (I_n = ∫₀^h sⁿ e^{−2λs} ds), P∞ and C as in the module docstring."""
    lam, h = float(airspeed) / float(length_scale), float(step)
    x = 2.0 * lam * h
    e2, one_minus_e2 = math.exp(-x), -math.expm1(-x)
    i0 = one_minus_e2 / (2.0 * lam)
    i1 = (one_minus_e2 - x * e2) / (4.0 * lam**2)
    i2 = (2.0 * one_minus_e2 - e2 * (2.0 * x + x * x)) / (8.0 * lam**3)
    p0, p1, p2 = 1.0 / (2.0 * lam), 1.0 / (4.0 * lam**2), 1.0 / (4.0 * lam**3)
    s = float(sigma)
    return GustFilter(
        decay=math.exp(-lam * h),
        step=h,
        noise_gain=_Factor(i0, np.array([[i0, i1], [i1, i2]])),
        stationary_gain=_Factor(p0, np.array([[p0, p1], [p1, p2]])),
        output=(
            s * math.sqrt(2.0 * lam),
            s * math.sqrt(3.0 * lam),
            s * math.sqrt(lam) * lam * (1.0 - math.sqrt(3.0)),
        ),
    )


def GustStart(f: GustFilter, z) -> tuple[float, float, float]:
    """x₀ = (P∞ factor) z₀ of the draws ``z`` (3 standard normals)."""
    a, b, c, d = f.stationary_gain
    return a * z[0], b * z[1], c * z[1] + d * z[2]


def GustStep(f: GustFilter, x, z) -> tuple[float, float, float]:
    """x_{k+1} = Φ x_k + G z_k (module docstring) of the states ``x`` = (x_u, x_1, x_2) and
    the draws ``z`` (3 standard normals)."""
    e, h = f.decay, f.step
    a, b, c, d = f.noise_gain
    xu, x1, x2 = x
    return e * xu + a * z[0], e * x1 + b * z[1], e * (h * x1 + x2) + c * z[1] + d * z[2]


def GustOutput(f: GustFilter, x) -> tuple[float, float]:
    """(u, v) [m/s] = C x of the states ``x`` = (x_u, x_1, x_2)."""
    cu, c1, c2 = f.output
    return cu * x[0], c1 * x[1] + c2 * x[2]


def BodyToEarth(u: float, v: float, heading: float) -> tuple[float, float]:
    """R(ψ) [u, v] [m/s]: the gusts along (u) and to the left of (v) the heading ψ [rad], in the
    east-north frame."""
    c, s = math.cos(heading), math.sin(heading)
    return u * c - v * s, u * s + v * c


def WindDraws(seed: int, block: int) -> np.ndarray:
    """The standard normal draws of block ``block``, shape (BLOCK_SIZE, 5): per step three for
    the gusts (x_u, x_1, x_2) and two for the drift (speed, direction)."""
    rng = np.random.default_rng([int(seed), int(block), WIND_STREAM])
    return rng.standard_normal((BLOCK_SIZE, 5))


def _Draw(seed: int, index: int, memo: dict) -> list:
    """Draw ``index`` (5 floats), from the block held in ``memo`` when it is the last one used."""
    block, row = divmod(index, BLOCK_SIZE)
    if memo.get("block") != block:
        memo["block"], memo["draws"] = block, WindDraws(seed, block).tolist()
    return memo["draws"][row]


def GustSeries(
    sigma: float, length_scale: float, airspeed: float, step: float, seed: int, count: int
) -> np.ndarray:
    """(u, v) [m/s] of the gusts at t_k = k·h, k = 0 … count − 1, shape (count, 2): the values
    :class:`WindSource` rotates by the heading and adds to the mean wind, for the same seed."""
    f = DrydenFilter(sigma, length_scale, airspeed, step)
    memo: dict = {}
    x = GustStart(f, _Draw(seed, 0, memo))
    out = np.empty((count, 2))
    for k in range(count):
        out[k] = GustOutput(f, x)
        x = GustStep(f, x, _Draw(seed, k + 1, memo))
    return out


def DriftIncrements(drift, step: float) -> tuple[float, float, float, float, float]:
    """(ṡ h/60 [m/s], σ_s sqrt(h/60) [m/s], θ̇ h/60 [rad], σ_θ sqrt(h/60) [rad], s_max [m/s]) of
    ``drift`` (a :class:`~eaplan_drake.params.WindDriftParams`) over one step h [s]: the
    coefficients :func:`DriftStep` reads."""
    minutes = float(step) / 60.0
    root = math.sqrt(minutes)
    return (
        drift.speed_rate * minutes,
        drift.speed_sigma * root,
        math.radians(drift.direction_rate_deg) * minutes,
        math.radians(drift.direction_sigma_deg) * root,
        float(drift.max_speed),
    )


def DriftStep(speed: float, direction: float, z, increments) -> tuple[float, float]:
    """(s_{k+1} [m/s], θ_{k+1} [rad]) of the mean wind from (s_k, θ_k) over one step with the
    draws ``z`` = (z, z') and the ``increments`` of :func:`DriftIncrements` (module docstring:
    s + ṡ h/60 + σ_s sqrt(h/60) z clipped into [0, s_max], θ + θ̇ h/60 + σ_θ sqrt(h/60) z')."""
    ramp, sigma, turn, sigma_turn, top = increments
    s = speed + ramp + sigma * z[0]
    return min(max(s, 0.0), top), direction + turn + sigma_turn * z[1]


class WindSource(LeafSystem):
    """The wind w = w̄ + R(ψ) [u, v] [m/s] of the module docstring, stepped every ``time_step``.

    Args:
        wind: :class:`~eaplan_drake.params.WindParams` (its ``speed``, ``direction_deg``,
            ``gusts`` and ``drift``; validated).
        airspeed: V [m/s] of the gust filter.
        time_step: h [s] (the plant's step, ``simulation.max_step``).
        seed: the draws' seed (:meth:`~eaplan_drake.params.Scenario.WindSeed`).
        initial_heading: ψ(0) [rad], to rotate the gusts at t = 0.

    Discrete state: ``wind`` w(t_k) (2) and ``mean_wind`` w̄(t_k) (2), both state output ports
    (the plant reads ``wind``), and the internal (s, θ, x_u, x_1, x_2). The update at t_k steps
    them to t_{k+1} with the heading ψ(t_k) of the ``kinematics`` input (x, y, ψ, ṗ_x, ṗ_y) (read
    only with gusts on), so the plant's update at t_k flies in w(t_k).

    .. pydrake_system::

        name: WindSource
        input_ports:
        - kinematics
        output_ports:
        - wind
        - mean_wind
    """

    def __init__(
        self,
        wind: WindParams,
        *,
        airspeed: float,
        time_step: float,
        seed: int,
        initial_heading: float = 0.0,
    ):
        super().__init__()
        wind.Validate("wind")
        h = float(time_step)
        if not (math.isfinite(h) and h > 0.0):
            raise ValueError(f"WindSource: time_step must be > 0 s, got {time_step!r}")
        self._h, self._seed, self._memo = h, int(seed), {}
        self._drift = DriftIncrements(wind.drift, h) if wind.drift.on else None
        gusts = wind.gusts
        self._filter = (
            DrydenFilter(gusts.sigma, gusts.length_scale, airspeed, h) if gusts.on else None
        )
        speed, direction = float(wind.speed), math.radians(wind.direction_deg)
        x = (0.0, 0.0, 0.0)
        if self._filter is not None:
            x = GustStart(self._filter, _Draw(self._seed, 0, self._memo))
        internal = np.array([speed, direction, *x])
        mean, total = self._Wind(internal.tolist(), float(initial_heading))
        self._wind_index = self.DeclareDiscreteState(total)
        self._mean_index = self.DeclareDiscreteState(mean)
        self._internal_index = self.DeclareDiscreteState(internal)
        self._kinematics_port = self.DeclareVectorInputPort("kinematics", 5)
        self.DeclarePeriodicDiscreteUpdateEvent(h, 0.0, self._Update)
        self.DeclareStateOutputPort("wind", self._wind_index)
        self.DeclareStateOutputPort("mean_wind", self._mean_index)

    def _Wind(self, internal: list, heading: float) -> tuple[list, list]:
        """(w̄, w) [m/s] of the internal state (s, θ, x_u, x_1, x_2) at the heading ψ [rad]."""
        speed, direction = internal[0], internal[1]
        mean = [speed * math.cos(direction), speed * math.sin(direction)]
        if self._filter is None:
            return mean, mean
        gx, gy = BodyToEarth(*GustOutput(self._filter, internal[2:]), heading)
        return mean, [mean[0] + gx, mean[1] + gy]

    def _Update(self, context, discrete_state):
        # Drake fills discrete_state with the context's values before this handler: the groups
        # are read and written in place (Python floats in between: no numpy call per element).
        state = discrete_state.get_mutable_value(self._internal_index)
        speed, direction, xu, x1, x2 = state.tolist()
        z = _Draw(self._seed, round(context.get_time() / self._h) + 1, self._memo)
        if self._drift is not None:
            speed, direction = DriftStep(speed, direction, (z[3], z[4]), self._drift)
        mx, my = speed * math.cos(direction), speed * math.sin(direction)
        wx, wy = mx, my
        if self._filter is not None:
            xu, x1, x2 = GustStep(self._filter, (xu, x1, x2), z)
            heading = self._kinematics_port.Eval(context).item(2)
            gx, gy = BodyToEarth(*GustOutput(self._filter, (xu, x1, x2)), heading)
            wx, wy = mx + gx, my + gy
        state[:] = (speed, direction, xu, x1, x2)
        mean = discrete_state.get_mutable_value(self._mean_index)
        mean[0], mean[1] = mx, my
        wind = discrete_state.get_mutable_value(self._wind_index)
        wind[0], wind[1] = wx, wy


def AddWindSource(
    builder: DiagramBuilder,
    wind: np.ndarray,
    wind_params: WindParams | None,
    vehicle: VehicleParams,
    simulation: SimulationParams,
    seed: int,
) -> ConstantVectorSource | WindSource:
    """Adds the world's wind, named ``wind``: a ``ConstantVectorSource`` of ``wind`` w [m/s]
    (east, north), or, when ``wind_params`` has gusts or drift on, a
    :class:`~eaplan_drake.flight.wind.WindSource` of them stepped every ``simulation.max_step``
    with the draws of ``seed`` (its ``kinematics`` input left for the caller)."""
    if wind_params is None or not wind_params.changes:
        return builder.AddNamedSystem("wind", ConstantVectorSource(wind))
    return builder.AddNamedSystem(
        "wind",
        WindSource(
            wind_params,
            airspeed=vehicle.airspeed,
            time_step=simulation.max_step,
            seed=seed,
            initial_heading=math.radians(vehicle.initial_heading_deg),
        ),
    )
