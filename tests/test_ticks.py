"""Ticked updates (eaplan_drake.ticks): an event declared at the base tick that acts every n-th
tick."""

import numpy as np
from pydrake.systems.analysis import Simulator

from eaplan_drake.diagram import MakeEaplanDiagram
from eaplan_drake.loading import LoadNamedScenario


def test_a_ticked_update_runs_on_every_nth_base_tick_or_at_its_own_period():
    from pydrake.systems.framework import LeafSystem

    from eaplan_drake.ticks import DeclareTickedDiscreteUpdateEvent

    class Counter(LeafSystem):
        def __init__(self, period, time_step):
            super().__init__()
            self.DeclareDiscreteState(1)
            self.times = []
            self.ticks = DeclareTickedDiscreteUpdateEvent(self, period, time_step, self._Update)

        def _Update(self, context, discrete_state):
            self.times.append(context.get_time())
            discrete_state.get_mutable_value()[0] += 1.0

    for period, time_step, ticks in ((0.05, 0.01, 5), (0.01, 0.01, 1), (0.015, 0.01, 1)):
        counter = Counter(period, time_step)
        simulator = Simulator(counter)
        simulator.AdvanceTo(0.3 + 1e-9)
        assert counter.ticks == ticks
        expected = [k * period for k in range(int(round(0.3 / period)) + 1)]
        np.testing.assert_allclose(counter.times, expected, rtol=0, atol=1e-12)
        count = simulator.get_context().get_discrete_state_vector().GetAtIndex(0)
        assert count == len(expected)  # the other ticks leave the state as it was


def test_a_10_hz_point_sensor_and_filter_on_the_100_hz_tick_add_no_steps():
    # k·0.1 and (10k)·0.01 differ in the last bit at about one k in six; declared at their own
    # period the sensor and the filter would add ulp-long steps (1018 steps in 10 s).
    scenario = LoadNamedScenario(
        "plan_I", ["{'sensor': {'rate': 10.0}, 'estimator': {'rate': 10.0}}"]
    )
    simulator = Simulator(MakeEaplanDiagram(scenario, log_period=0.0))
    simulator.Initialize()
    simulator.AdvanceTo(10.0)
    assert simulator.get_num_steps_taken() == 1000
