"""The reference loop: the closed loop of a static flight as one plain Python/numpy loop, no Drake.

The yardstick of ``bench_flights.py``: a flight's speed is reported as × real time and as the ratio
to this loop measured in the same run, which carries from one machine to the next (an absolute
speed does not). It is written once, here, and is not meant to change with the package: the same
math as the diagram at the paper's rates (plant integrated by Heun's RK2 at h = 0.01 s, the
guiding-vector-field law evaluated at both stages, the sequencer at 20 Hz, the sensor and the
Kalman filter at 100 Hz, the Rint battery at 100 Hz), with the plan's geometry, the sensor's noise
draws and the filter's discrete matrices taken from the package once, outside the loop. No planner:
c1 and c2 stay at their initial values.

    python3 benchmarks/reference_loop.py [SCENARIO]   # flies it and compares with Simulate
"""

import math
import sys
import time

import numpy as np

from eaplan_drake.energy.fourier import DiscreteEnergyMatrices, ModelOrder, OutputMatrix
from eaplan_drake.energy.sensor import BLOCK_SIZE, NoiseSamples
from eaplan_drake.flight.plant import MaxHeadingRate
from eaplan_drake.resolve import ResolveScenario, StartParameters

GRAVITY = 9.81
_FIELD_EPS = 1e-9
_FIELD_FLOOR_SQ = 1e-6
_SPEED_EPS = 1e-6
_ALONG_FLOOR = 0.05


def _Command(x, y, vx, vy, psi, a, bx, by, c, s, ke, va, kd, rmax):
    nx = 2.0 * a * x + bx
    ny = 2.0 * a * y + by
    kp = ke * (a * (x * x + y * y) + bx * x + by * y + c)
    dx = s * ny - kp * nx
    dy = -s * nx - kp * ny
    dn2 = dx * dx + dy * dy
    cpsi = math.cos(psi)
    spsi = math.sin(psi)
    v2 = vx * vx + vy * vy
    if v2 > _SPEED_EPS * _SPEED_EPS:
        v = math.sqrt(v2)
        ux, uy = vx / v, vy / v
    else:
        ux, uy = cpsi, spsi
    if dn2 > _FIELD_EPS * _FIELD_EPS:
        dn = math.sqrt(dn2)
        mx, my = dx / dn, dy / dn
        ta = 2.0 * a
        ndot = nx * vx + ny * vy
        ddx = ta * (s * vy - kp * vx) - ke * ndot * nx
        ddy = ta * (-s * vx - kp * vy) - ke * ndot * ny
        chid = (dx * ddy - dy * ddx) / (dn2 if dn2 > _FIELD_FLOOR_SQ else _FIELD_FLOOR_SQ)
    else:
        mx, my = ux, uy
        chid = 0.0
    e = ux * my - uy * mx
    if ux * mx + uy * my < 0.0:
        e = -1.0 if e < 0.0 else 1.0
    along = cpsi * vx + spsi * vy
    floor = _ALONG_FLOOR * va
    u = v2 / (va * (along if along > floor else floor)) * (chid + kd * e)
    return rmax if u > rmax else (-rmax if u < -rmax else u)


class _Stage:
    def __init__(self, stage):
        self.stage = stage
        self.descriptor = [float(v) for v in stage.path.descriptor()]
        self.trigger = [float(v) for v in stage.trigger]
        self.tangent = [float(v) for v in stage.TriggerTangent()]
        self.is_circle = bool(stage.is_circle)
        self.center = [float(v) for v in stage.path.center] if self.is_circle else None


def FlyReferenceLoop(scenario, log_period: float = 0.1) -> dict:
    """Flies ``scenario`` (its initial c1 and c2, no planner) until the survey completes, the
    reserve or a brown-out; returns times, positions, SoC, ŷ at ``log_period`` [s], the status,
    and the CPU time [s] of the loop alone."""
    resolved = ResolveScenario(scenario)
    s, table, plan = resolved.scenario, resolved.table, resolved.plan
    c1, c2 = StartParameters(s, table)
    h = 1.0 / s.estimator.rate
    if abs(s.sensor.rate - s.estimator.rate) > 0 or abs(h - s.simulation.max_step) > 1e-15:
        raise ValueError("the reference loop needs sensor rate = estimator rate = 1 / max_step")
    va = float(s.vehicle.airspeed)
    rmax = MaxHeadingRate(s.vehicle)
    kd = float(s.guidance.k_d)
    w = s.wind.speed * np.array(
        [math.cos(math.radians(s.wind.direction_deg)), math.sin(math.radians(s.wind.direction_deg))]
    )
    wx, wy = float(w[0]), float(w[1])
    mp = s.vehicle.motion_power
    p0 = float(mp.level_power)
    p2 = float(mp.level_power * mp.induced_fraction * (va / GRAVITY) ** 2)
    g_power = float(table.power(c2))
    eps2 = float(s.coverage.trigger_radius) ** 2
    # battery
    bat = s.battery
    V, R = bat.Voltage(), float(bat.internal_resistance)
    p_max = V * V / (4.0 * R)
    i_max = V / (2.0 * R)
    rate_per_amp_step = bat.k_b / bat.Capacity() * h
    faults = sorted((f.time - 1e-9, f.soc_drop) for f in bat.faults)
    reserve = float(bat.reserve_soc)
    # sensor
    sensor = s.sensor
    sensor_params = type(sensor)(**{**sensor.__dict__, "seed": s.SensorSeed()})
    # estimator
    order = ModelOrder(s.energy_model.order, s.estimator.aperiodic_time_constant)
    cvec = OutputMatrix(order)[0]
    m = cvec.size
    q = np.zeros(m)
    if s.energy_model.initial_coefficients:
        q[:] = s.energy_model.initial_coefficients
    else:
        q[0] = s.energy_model.initial_mean_power
    P = s.estimator.initial_covariance * np.eye(m)
    q_diag = np.full(m, float(s.estimator.process_noise))
    q_diag[0] += float(s.estimator.mean_process_noise)
    Rm = float(s.estimator.measurement_noise)
    eye = np.eye(m)
    T = float(s.energy_model.initial_period)
    Ad = DiscreteEnergyMatrices(order, T, h)[0]
    Ad_T = T
    # sequencer
    stage = _Stage(plan.Stages(c1)[0])
    entries = {}
    complete = False

    x, y = (float(v) for v in s.vehicle.initial_position)
    psi = math.radians(s.vehicle.initial_heading_deg)
    b, y_held, k_fault = float(bat.initial_soc), 0.0, 0
    z_held = math.nan
    noise, dropped, block = None, None, -1
    log_every = max(1, int(round(log_period / h)))
    log_t, log_xy, log_b, log_yhat = [], [], [], []
    status = "time_limit"
    end = 0.0
    steps = int(round(s.simulation.time_limit / h))
    cpu0 = time.process_time()
    for k in range(steps + 1):
        t = k * h
        # -- outputs at t_k (from the state before this step's updates) --
        u0 = _Command(
            x, y, va * math.cos(psi) + wx, va * math.sin(psi) + wy, psi, *stage.descriptor,
            va, kd, rmax,
        )  # fmt: skip
        true_power = p0 + p2 * u0 * u0 + g_power
        if k % log_every == 0:
            log_t.append(t)
            log_xy.append((x, y))
            log_b.append(b)
            log_yhat.append(float(cvec @ q))
        end = t
        if complete:
            status = "complete"
            break
        if true_power > p_max:
            status = "brownout"
            break
        if b <= reserve:
            status = "reserve_reached"
            break
        if k == steps:
            break
        # -- discrete updates at t_k (all read the state before the step) --
        # sensor
        blk, local = divmod(int(round(t / h)), BLOCK_SIZE)
        if blk != block:
            noise, dropped = NoiseSamples(sensor_params, blk * BLOCK_SIZE, BLOCK_SIZE)
            block = blk
        z_new = math.nan if dropped[local] else true_power + noise[local]
        # estimator (reads z held from the previous sample)
        if T != Ad_T:
            Ad = DiscreteEnergyMatrices(order, T, h)[0]
            Ad_T = T
        if math.isfinite(z_held):
            pc = P @ cvec
            K = pc / (cvec @ pc + Rm)
            q = q + K * (z_held - cvec @ q)
            L = eye - K[:, None] * cvec
            P = L @ P @ L.T + (Rm * K)[:, None] * K
            P = 0.5 * (P + P.T)
        q = Ad @ q
        P = Ad @ P @ Ad.T
        P = 0.5 * (P + P.T)
        P[np.diag_indices(m)] += q_diag
        z_held = z_new
        # battery (current of the power held from the previous step)
        i = i_max if y_held >= p_max else 2.0 * y_held / (V + math.sqrt(V * V - 4.0 * R * y_held))
        b = min(1.0, max(0.0, b - i * rate_per_amp_step))
        while k_fault < len(faults) and faults[k_fault][0] <= t:
            b = max(b - faults[k_fault][1], 0.0)
            k_fault += 1
        y_held = true_power
        # sequencer at 20 Hz
        if k % 5 == 0:
            for _ in range(8):
                tx, ty = stage.trigger
                dx, dy = x - tx, y - ty
                if dx * dx + dy * dy >= eps2:
                    ux, uy = stage.tangent
                    if dx * ux + dy * uy < 0.0:
                        break
                    if stage.is_circle:
                        ox, oy = stage.center
                        if (x - ox) * (tx - ox) + (y - oy) * (ty - oy) <= 0.0:
                            break
                st = stage.stage
                rest = plan.StagesAfter(st.index, tuple(st.anchor), c1)
                if not rest:
                    complete = True
                    break
                stage = _Stage(rest[0])
                prim = rest[0].primitive
                if prim >= 0:
                    last = entries.get(prim)
                    if last is not None and t > last:
                        T = t - last
                    entries[prim] = t
        # -- plant: Heun's RK2 over [t_k, t_k + h], guidance at both stages --
        d = stage.descriptor
        c0, s0 = math.cos(psi), math.sin(psi)
        vx0, vy0 = va * c0 + wx, va * s0 + wy
        r0 = _Command(x, y, vx0, vy0, psi, *d, va, kd, rmax)
        x1, y1, psi1 = x + h * vx0, y + h * vy0, psi + h * r0
        c1_, s1_ = math.cos(psi1), math.sin(psi1)
        vx1, vy1 = va * c1_ + wx, va * s1_ + wy
        r1 = _Command(x1, y1, vx1, vy1, psi1, *d, va, kd, rmax)
        x += 0.5 * h * (vx0 + vx1)
        y += 0.5 * h * (vy0 + vy1)
        psi += 0.5 * h * (r0 + r1)
    cpu = time.process_time() - cpu0
    return {
        "times": np.array(log_t),
        "position": np.array(log_xy),
        "soc": np.array(log_b),
        "estimated_power": np.array(log_yhat),
        "status": status,
        "duration": end,
        "cpu_s": cpu,
    }


def main(name: str) -> None:
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.simulation import Simulate

    scenario = LoadNamedScenario(name)
    ref = FlyReferenceLoop(scenario)
    log = Simulate(scenario)
    n = min(len(ref["times"]), len(log.times))
    print(
        f"{name}: reference loop {ref['status']} at {ref['duration']:.2f} s, "
        f"{ref['duration'] / ref['cpu_s']:.0f}x real time per CPU second; "
        f"Simulate {log.summary['status']} at {log.summary['duration']:.2f} s"
    )
    for key in ("position", "soc", "estimated_power"):
        a, b = ref[key][:n], log[key][:n].reshape(ref[key][:n].shape)
        print(f"  max |{key} difference| over the first {n} samples: {np.max(np.abs(a - b)):.3e}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "plan_I")
