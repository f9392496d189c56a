"""The path panel's pieces (eaplan_drake.output.path_plot)."""

import matplotlib.pyplot as plt

from eaplan_drake.flight.coverage import MakeCoveragePlan
from eaplan_drake.params import Scenario


def test_draw_plan_labels_a_solid_stage():
    from eaplan_drake.output.path_plot import DrawPlan

    plan = MakeCoveragePlan(Scenario().coverage, Scenario().vehicle, c1=0.0, k_e=0.05)
    fig, ax = plt.subplots()
    DrawPlan(ax, plan.Stages(0.0), label="plan")
    handles, labels = ax.get_legend_handles_labels()
    assert labels == ["plan"] and handles[0].get_linestyle() == "-"
    assert len(ax.lines) == len(plan.Stages(0.0)) + 1  # every stage and the triggering points
    plt.close(fig)
