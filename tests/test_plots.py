"""Figures (eaplan_drake.output.plots): what the panels of a flight and of several policies show,
and the saved files."""

import matplotlib.pyplot as plt
import numpy as np
import pytest

from eaplan_drake.flightlog import FlightLog, SampleQuality
from eaplan_drake.output.plots import PlotFlight, PlotPolicyComparison, SaveFlightPlots
from eaplan_drake.params import BatteryFault, Scenario


def _Scenario():
    s = Scenario()
    s.name = "synthetic"
    s.battery.faults = [BatteryFault(time=30.0, soc_drop=0.06)]
    s.planner.warmup = 20.0
    return s


def _Log(completed=False, c1=-500.0, c2=6.0):
    """A 60 s straight flight across the reference area at 5 Hz, with a start-up spike."""
    t = np.linspace(0.0, 60.0, 301)
    x = -110.0 + 3.0 * t
    n = len(t)
    power = 35.0 + np.sin(t)
    estimated = power.copy()
    estimated[0] = 80.0
    soc = 1.0 - 0.01 * t
    return FlightLog(
        times=t,
        signals={
            "position": np.column_stack([x, np.full(n, 80.0)]),
            "path_parameters": np.full((n, 1), c1),
            "computation_parameters": np.full((n, 1), c2),
            "measured_power": power[:, None] + 0.1,
            "true_power": power[:, None],
            "estimated_power": estimated[:, None],
            "period": np.full((n, 1), 48.0),
            "soc": soc[:, None],
        },
        summary={
            "status": "complete" if completed else "reserve_reached",
            "completed": completed,
            "duration": 60.0,
            "final_soc": soc[-1],
            "final_margin": soc[-1] - 0.3,
            "quality": 0.5,
            "metric": None,
            "policy": "mpc",
            "path_parameter_bounds": [-1000.0, 0.0],
            "computation_parameter_bounds": [[2.0], [10.0]],
        },
    )


def _Texts(fig):
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:
            texts += [t.get_text() for t in legend.get_texts()]
    return texts


def test_flight_figure_marks_events_end_and_uncovered_area():
    scenario = _Scenario()
    fig = PlotFlight(_Log(completed=False), scenario)
    texts = _Texts(fig)
    for expected in ("warm-up (20 s)", "survey area", "start", "period T (right)", "every 10 s"):
        assert expected in texts, expected
    assert "c̃1: c1 from -1000 to 0 m² (c1 = r2² − r² ≤ 0; 0: densest lines)" in texts
    assert "c̃2: c2 from 2 to 10 [table units]" in texts
    assert any(t.startswith("fault (−6 % at 30 s") for t in texts)
    assert "fault 30 s" in texts  # the fault's place on the path
    assert "end: reserve reached at 60.0 s" in texts  # the path's legend
    assert any(t.startswith("end: reserve reached at 60.0 s, b = 0.400") for t in texts)
    assert any(t.startswith("not covered (") for t in texts)
    assert any(t.startswith("wind 5 m/s") for t in texts)
    axes = {ax.get_title(): ax for ax in fig.axes if ax.get_title()}
    assert set(axes) == {"path", "energy", "parameters", "battery", "planner (mpc)"}
    # The start-up spike of the estimate (80 W) does not set the energy panel's range.
    assert axes["energy"].get_ylim()[1] < 40.0
    # Both parameters normalised on one axis, ± 6 %; no twin axes over it.
    assert axes["parameters"].get_ylim() == pytest.approx((-0.06, 1.06))
    twins = [
        a
        for a in fig.axes
        if a is not axes["parameters"] and a.bbox.bounds == axes["parameters"].bbox.bounds
    ]
    assert not twins
    # The period's twin axis of the energy panel is ticked only at periods it can show.
    (period,) = [
        a
        for a in fig.axes
        if a is not axes["energy"] and a.bbox.bounds == axes["energy"].bbox.bounds
    ]
    ticks = period.get_yticks()  # 48 s ± 10 %, where the band of the period lies
    assert ticks.size >= 2 and np.all((ticks >= 48.0 - 4.8) & (ticks <= 48.0 + 4.8))
    assert period.get_ylim()[0] < 48.0 - 4.8 * 3  # the band is the panel's top part
    plt.close(fig)
    fig = PlotFlight(_Log(completed=True), scenario)
    texts = _Texts(fig)
    assert "end: survey complete at 60.0 s" in texts
    assert not any(t.startswith("not covered (") for t in texts)
    plt.close(fig)


def test_sample_quality_is_the_mean_of_the_normalised_parameters():
    q = SampleQuality(_Log(c1=-500.0, c2=6.0))
    np.testing.assert_allclose(q, 0.5 * 0.5 + 0.5 * 0.5)
    q = SampleQuality(_Log(c1=0.0, c2=2.0))
    np.testing.assert_allclose(q, 0.5)


def test_saved_png_is_whole_and_leaves_no_temporary_file(tmp_path):
    path = SaveFlightPlots(_Log(), _Scenario(), tmp_path / "run")
    assert path.name == "flight.png"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["flight.png"]


def test_policy_comparison_has_a_path_panel_per_policy():
    logs = {"mpc": _Log(c1=-200.0), "static": _Log(completed=True, c1=-1000.0, c2=2.0)}
    fig = PlotPolicyComparison(logs, _Scenario())
    titles = [ax.get_title() for ax in fig.axes]
    assert "mpc: reserve_reached, quality 0.500" in titles
    assert "static: complete, quality 0.500" in titles
    assert {"battery", "path parameter (normalised)", "computation parameter (normalised)"} <= set(
        titles
    )
    plt.close(fig)
    with pytest.raises(ValueError, match="no flights"):
        PlotPolicyComparison({}, _Scenario())
