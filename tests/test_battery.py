"""Tests of the Rint battery functions (paper 003 Lemma III.3) and the Battery system."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator, SimulatorStatus
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from eaplan_drake.energy.battery import (
    STATUS_BROWNOUT,
    STATUS_RESERVE,
    Battery,
    BatteryState,
    IsBrownout,
    MaxDeliverablePower,
    PowerBudget,
    RintCurrent,
    SocAfter,
    SocDerivative,
    TimeToSoc,
)
from eaplan_drake.logfit.powerlog import ReferenceDirectory
from eaplan_drake.params import BatteryFault, BatteryParams

V, R, Q, KB = 14.8, 0.0012, 3.2, 0.00183


def Reference(reserve_soc: float = 0.0) -> BatteryParams:
    """The reference battery; reserve 0 by default so that a test can discharge it to empty
    (the Battery ends a simulation when b reaches the reserve)."""
    return BatteryParams(
        voltage=V, internal_resistance=R, capacity=Q, k_b=KB, reserve_soc=reserve_soc
    )


# -- pure functions -----------------------------------------------------------------------------


def test_current_solves_the_rint_quadratic():
    # I must satisfy R I² − V I + y = 0 (App. C) and be the root that is 0 at y = 0.
    y = np.array([0.0, 1e-9, 5.0, 33.0, 1000.0, 0.99 * MaxDeliverablePower(V, R)])
    current = RintCurrent(y, V, R)
    np.testing.assert_allclose(R * current**2 - V * current + y, 0.0, atol=1e-9 * V**2 / R)
    assert current[0] == 0.0
    # Naive textbook form agrees where it has no cancellation problem.
    naive = (V - np.sqrt(V**2 - 4 * R * y[2:])) / (2 * R)
    np.testing.assert_allclose(current[2:], naive, rtol=1e-9)
    # Small loads: I ≈ y / V (the resistance hardly matters), exact to first order.
    assert RintCurrent(1e-9, V, R) == pytest.approx(1e-9 / V, rel=1e-12)
    assert isinstance(RintCurrent(33.0, V, R), float)


def test_scalar_and_array_evaluations_agree_bit_for_bit():
    # One expression, evaluated with math for a scalar and numpy for an array.
    p = Reference()
    y = np.array([-5.0, 0.0, 1e-9, 12.5, 33.0, 0.5 * MaxDeliverablePower(V, R), 1e12])
    b0 = np.array([0.9, 0.5, 1.0, 0.3, 0.05, 0.7, 0.2])
    current = RintCurrent(y, V, R)
    soc = SocAfter(b0, y, 0.01, p)
    brown = IsBrownout(y, V, R)
    for k in range(y.size):
        assert RintCurrent(float(y[k]), V, R) == current[k]
        assert RintCurrent(np.float64(y[k]), V, R) == current[k]
        assert SocAfter(float(b0[k]), float(y[k]), 0.01, p) == soc[k]
        assert IsBrownout(float(y[k]), V, R) == brown[k]
    assert isinstance(SocAfter(0.9, 33.0, 1.0, p), float)
    assert isinstance(IsBrownout(33.0, V, R), bool)
    assert RintCurrent([33.0, 1.0], V, R).shape == (2,)
    assert math.isnan(RintCurrent(math.nan, V, R))
    assert np.isnan(RintCurrent(np.array([math.nan]), V, R)[0])
    assert math.isnan(SocAfter(0.5, math.nan, 1.0, p))


def test_negative_power_gives_negative_current():
    current = RintCurrent(-5.0, V, R)
    assert current < 0.0
    assert R * current**2 - V * current - 5.0 == pytest.approx(0.0, abs=1e-9)


def test_max_power_and_brownout_never_nan():
    p_max = MaxDeliverablePower(V, R)
    assert p_max == pytest.approx(V**2 / (4 * R), rel=1e-15)
    assert RintCurrent(p_max, V, R) == pytest.approx(V / (2 * R), rel=1e-12)
    over = np.array([p_max * (1 + 1e-9), 2 * p_max, 1e12])
    current = RintCurrent(over, V, R)
    assert np.all(np.isfinite(current))
    np.testing.assert_allclose(current, V / (2 * R), rtol=1e-12)
    assert np.all(IsBrownout(over, V, R))
    assert not IsBrownout(p_max, V, R) and not IsBrownout(33.0, V, R)
    assert math.isfinite(SocDerivative(1e12, Reference()))
    assert math.isfinite(TimeToSoc(1.0, 0.0, 1e12, Reference()))


def test_soc_derivative_matches_lemma():
    p = Reference()
    y = 33.0
    lemma = -KB * (V - math.sqrt(V**2 - 4 * R * y)) / (2 * R * Q)
    assert SocDerivative(y, p) == pytest.approx(lemma, rel=1e-9)
    assert SocDerivative(0.0, p) == 0.0


def test_33_watts_empty_the_reference_battery_in_about_784_s():
    # Issue 2 / DESIGN.md: ≈ 784 s. Closed form: Q_c / (k_b I(33 W)) = 784.09 s.
    t = TimeToSoc(1.0, 0.0, 33.0, Reference())
    assert t == pytest.approx(784.0, abs=0.5)
    # Without the resistance (I = y / V) it would be 784.23 s: R_r matters by ~0.14 s only.
    assert Q * V / (KB * 33.0) - t == pytest.approx(0.14, abs=0.02)


def test_time_to_soc_closed_form_and_edge_cases():
    p = Reference()
    y = np.array([10.0, 33.0, 500.0])
    t = TimeToSoc(0.9, 0.3, y, p)
    # Integrating ḃ over t must land exactly on the target.
    np.testing.assert_allclose(0.9 + SocDerivative(y, p) * t, 0.3, rtol=0, atol=1e-12)
    np.testing.assert_allclose(SocAfter(0.9, y, t, p), 0.3, atol=1e-12)
    assert TimeToSoc(0.5, 0.5, 33.0, p) == 0.0
    assert TimeToSoc(0.5, 0.6, 33.0, p) == 0.0
    assert TimeToSoc(0.5, 0.3, 0.0, p) == math.inf
    assert TimeToSoc(0.5, 0.3, -4.0, p) == math.inf


def test_soc_after_is_clipped_to_empty():
    p = Reference()
    assert SocAfter(0.1, 33.0, 1e4, p) == 0.0
    assert SocAfter(1.0, -100.0, 1e4, p) == 1.0


def test_power_budget_is_b_times_capacity_times_voltage():
    p = Reference()
    assert PowerBudget(1.0, p) == pytest.approx(Q * V, rel=1e-15)  # 47.36, authors' bat.csv row 0
    np.testing.assert_allclose(PowerBudget(np.array([0.0, 0.5]), p), [0.0, 0.5 * Q * V])


# -- Battery system -----------------------------------------------------------------------------

H = 0.01
PLAN_I_FAULTS = [BatteryFault(time=93.0, soc_drop=0.06), BatteryFault(time=270.0, soc_drop=0.09)]


def MakeDiagram(params: BatteryParams, power: float, time_step: float = H):
    builder = DiagramBuilder()
    battery = builder.AddSystem(Battery(params, time_step=time_step))
    source = builder.AddSystem(ConstantVectorSource([power]))
    builder.Connect(source.get_output_port(), battery.GetInputPort("power"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = battery.GetMyContextFromRoot(simulator.get_mutable_context())
    return battery, simulator, context


def Soc(battery, context) -> float:
    return float(battery.GetOutputPort("soc").Eval(context)[0])


def test_ports_and_sizes():
    battery = Battery(Reference(), time_step=H)
    assert battery.num_input_ports() == 1 and battery.num_output_ports() == 5
    assert battery.GetInputPort("power").size() == 1
    for name in ("soc", "current", "power_budget", "brownout"):
        assert battery.GetOutputPort(name).size() == 1
    assert battery.GetOutputPort("state").size() == len(BatteryState._fields)
    # SoC, budget and state come from the state; current and brownout follow the load directly.
    feedthrough = {
        name
        for name in ("soc", "current", "power_budget", "brownout", "state")
        if battery.HasDirectFeedthrough(0, battery.GetOutputPort(name).get_index())
    }
    assert feedthrough == {"current", "brownout"}
    assert battery.time_step == H


def test_outputs_match_pure_functions():
    params = Reference()
    params.initial_soc = 0.7
    battery, _, context = MakeDiagram(params, 33.0)
    assert Soc(battery, context) == 0.7
    assert battery.GetOutputPort("power_budget").Eval(context)[0] == pytest.approx(
        PowerBudget(0.7, params), rel=1e-15
    )
    assert battery.GetOutputPort("current").Eval(context)[0] == pytest.approx(
        RintCurrent(33.0, V, R), rel=1e-15
    )
    assert battery.GetOutputPort("brownout").Eval(context)[0] == 0.0


def test_constant_power_matches_closed_form_in_simulator():
    params = Reference()
    battery, simulator, context = MakeDiagram(params, 33.0)
    rate = SocDerivative(33.0, params)
    for t in (1.0, 100.0, 500.0):
        # Advance half a step past t so that the last update is the one at t (k = t / h).
        simulator.AdvanceTo(t + H / 2)
        assert Soc(battery, context) == pytest.approx(1.0 + rate * t, abs=1e-10)
        assert battery.GetOutputPort("power_budget").Eval(context)[0] == pytest.approx(
            PowerBudget(1.0 + rate * t, params), abs=1e-8
        )


def test_33_watts_empty_the_battery_at_784_s_and_the_simulation_ends_there():
    params = Reference()  # reserve 0: the flight ends when the battery is empty
    battery, simulator, context = MakeDiagram(params, 33.0)
    t_empty = TimeToSoc(1.0, 0.0, 33.0, params)  # 784.094 s
    status = simulator.AdvanceTo(t_empty - 2 * H)
    assert status.succeeded()
    assert 0.0 < Soc(battery, context) < 3 * H * -SocDerivative(33.0, params)
    status = simulator.AdvanceTo(900.0)
    assert status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition
    assert status.message() == STATUS_RESERVE == "reserve_reached"
    assert status.system().get_name() == battery.get_name()
    # Ends at the first update at or after t_empty, the state of that update applied.
    assert t_empty <= context.get_time() <= t_empty + H + 1e-9
    assert Soc(battery, context) == 0.0
    assert battery.GetOutputPort("power_budget").Eval(context)[0] == 0.0


def test_reaching_the_reserve_ends_the_simulation_at_that_update():
    params = Reference(reserve_soc=0.3)
    battery, simulator, context = MakeDiagram(params, 33.0)
    t_reserve = TimeToSoc(1.0, 0.3, 33.0, params)  # 548.9 s
    status = simulator.AdvanceTo(1000.0)
    assert status.message() == STATUS_RESERVE
    t = context.get_time()
    assert t_reserve <= t <= t_reserve + H + 1e-9
    assert round(t / H) * H == t  # an update time k·h
    soc = Soc(battery, context)
    assert 0.3 + SocDerivative(33.0, params) * H < soc <= 0.3
    assert soc == pytest.approx(SocAfter(1.0, 33.0, t, params), abs=1e-10)


def test_plan_i_fault_schedule_lands_at_93_and_270_s_exactly_once():
    params = Reference()
    params.faults = list(PLAN_I_FAULTS)
    y = 30.0
    battery, simulator, context = MakeDiagram(params, y)
    step = SocDerivative(y, params) * H  # SoC change per step without faults (< 0)

    def SocAt(t):
        simulator.AdvanceTo(t)
        return Soc(battery, context)

    for fault_time, drop, dropped_before in ((93.0, 0.06, 0.0), (270.0, 0.09, 0.06)):
        before = SocAt(fault_time - H / 2)  # last update at fault_time − h
        at = SocAt(fault_time + H / 2)  # the update at fault_time applies the drop
        after = SocAt(fault_time + 3 * H / 2)
        assert before == pytest.approx(
            1.0 + (fault_time - H) * step / H - dropped_before, abs=1e-10
        )
        assert at - before == pytest.approx(step - drop, abs=1e-10)
        assert after - at == pytest.approx(step, abs=1e-10)
    # Exactly once each: at 400 s only the two drops and the steady discharge.
    assert SocAt(400.0 + H / 2) == pytest.approx(1.0 + 400.0 * step / H - 0.15, abs=1e-10)


def test_off_grid_fault_applies_at_the_next_update_and_never_below_zero():
    params = Reference()
    params.initial_soc = 0.05
    params.faults = [BatteryFault(time=2.004, soc_drop=0.5), BatteryFault(time=2.004, soc_drop=0.2)]
    battery, simulator, context = MakeDiagram(params, 10.0)
    simulator.AdvanceTo(2.005)  # last update at 2.00
    assert Soc(battery, context) > 0.04
    simulator.AdvanceTo(2.015)  # update at 2.01 contains 2.004
    assert Soc(battery, context) == 0.0
    simulator.AdvanceTo(3.0)
    assert Soc(battery, context) == 0.0


def test_fault_at_time_zero_is_applied_by_the_first_update():
    params = Reference()
    params.faults = [BatteryFault(time=0.0, soc_drop=0.1)]
    battery, simulator, context = MakeDiagram(params, 0.0)
    simulator.AdvanceTo(0.005)
    assert Soc(battery, context) == pytest.approx(0.9, abs=1e-15)
    simulator.AdvanceTo(1.0)
    assert Soc(battery, context) == pytest.approx(0.9, abs=1e-15)


def test_overload_is_a_brownout_that_ends_the_simulation_without_nan():
    params = Reference()
    overload = 2.0 * MaxDeliverablePower(V, R)
    battery, simulator, context = MakeDiagram(params, overload)
    status = simulator.AdvanceTo(0.5)
    # The first update (t = 0) samples the load and ends the simulation: a brown-out.
    assert status.message() == STATUS_BROWNOUT == "brownout"
    assert context.get_time() == 0.0
    assert battery.GetOutputPort("brownout").Eval(context)[0] == 1.0
    assert battery.GetOutputPort("current").Eval(context)[0] == pytest.approx(V / (2 * R))
    assert Soc(battery, context) == 1.0  # nothing drawn before t = 0
    for name in ("soc", "current", "power_budget", "brownout"):
        assert np.all(np.isfinite(battery.GetOutputPort(name).Eval(context)))
    # Held over a step, an overload discharges at the maximum-power current V / (2 R_r).
    expected = 1.0 - KB * V / (2 * R) / Q * 0.1
    assert SocAfter(1.0, overload, 0.1, params) == pytest.approx(expected, abs=1e-12)


def test_system_keeps_a_copy_of_its_params():
    params = Reference()
    params.faults = [BatteryFault(time=1.0, soc_drop=0.5)]
    battery, simulator, context = MakeDiagram(params, 10.0)
    params.faults.clear()
    params.initial_soc = 0.5
    params.capacity = 1.0
    assert battery.params.capacity == Q and len(battery.params.faults) == 1
    simulator.AdvanceTo(1.0 + H / 2)
    assert Soc(battery, context) == pytest.approx(SocAfter(1.0, 10.0, 1.0, Reference()) - 0.5)


def test_state_is_the_named_battery_state():
    battery, simulator, context = MakeDiagram(Reference(), 20.0)
    simulator.AdvanceTo(0.025)  # updates at 0, 0.01, 0.02
    x = BatteryState(context.get_discrete_state_vector().value())
    assert x.soc == Soc(battery, context)
    assert x.held_power == 20.0 and x.next_fault == 0.0


def test_non_finite_power_is_an_error_not_a_nan():
    battery, simulator, context = MakeDiagram(Reference(), math.nan)
    with pytest.raises(RuntimeError, match="power"):
        battery.GetOutputPort("current").Eval(context)
    with pytest.raises(RuntimeError, match="power"):
        simulator.AdvanceTo(0.1)


def test_a_negative_power_is_an_error_not_a_charge():
    battery, simulator, context = MakeDiagram(Reference(), -1e6)
    with pytest.raises(RuntimeError, match=r"input 'power' must be >= 0 W \(a load\), got -1e\+06"):
        simulator.AdvanceTo(0.1)


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("capacity", -1.0, "battery.capacity"),
        ("internal_resistance", 0.0, "battery.internal_resistance"),
        ("voltage", math.nan, "battery.voltage"),
        ("k_b", 0.0, "battery.k_b"),
        ("initial_soc", 1.5, "battery.initial_soc"),
        ("faults", [BatteryFault(time=1.0, soc_drop=0.0)], r"battery.faults\[0\].soc_drop"),
        ("faults", [BatteryFault(time=-1.0, soc_drop=0.1)], r"battery.faults\[0\].time"),
    ],
)
def test_bad_params_name_the_field(field, value, message):
    params = Reference()
    setattr(params, field, value)
    with pytest.raises(ValueError, match=message):
        Battery(params, time_step=H)


@pytest.mark.parametrize("time_step", [0.0, -0.01, math.inf, "0.01"])
def test_bad_time_step_is_named(time_step):
    with pytest.raises(ValueError, match="time_step"):
        Battery(Reference(), time_step=time_step)


REFERENCE_DIR = ReferenceDirectory()
AUTHORS = REFERENCE_DIR / "plan_I" / "bat.csv"


@pytest.mark.authors_data
def test_authors_plan_I_budget_column_and_absolute_fault_drops():
    # bat.csv: t, b, b·Q_c·V. Their SoC is a scripted piecewise-linear profile (not the Rint
    # model), so only the budget definition and the fault semantics are comparable.
    data = np.loadtxt(AUTHORS, delimiter=",")
    np.testing.assert_allclose(PowerBudget(data[:, 1], Reference()), data[:, 2], atol=1e-3)
    jumps = np.diff(data[:, 1])
    big = np.flatnonzero(jumps < -0.01)
    # Two drops, right at 93 s and 270 s (1 s log), of 0.06 and 0.09 of full charge (absolute),
    # each on top of ≈1 s of steady discharge (< 0.003).
    assert len(big) == 2
    np.testing.assert_allclose(data[big + 1, 0], [93.0, 270.0], atol=1.0)
    np.testing.assert_allclose(-jumps[big], [0.06, 0.09], atol=0.003)
