"""The figure of a flight (flight.png), read from its matplotlib artists: no text box covers a data
line, each panel's data lie inside its limits, c2 is visible in the warm-up, the end marker is
whole, the path carries time, and the path and the replay share one colour map of the quality."""

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.cbook import pts_to_poststep
from matplotlib.collections import LineCollection
from matplotlib.patches import Rectangle

from eaplan_drake.flightlog import FlightLog, SampleQuality
from eaplan_drake.output.plot_math import Runs, TimeMarkStep
from eaplan_drake.output.plot_style import COLORS, QUALITY_COLORMAP, InfeasibleCause
from eaplan_drake.output.plots import PlotFlight
from eaplan_drake.params import BatteryFault, Scenario

T_END = 120.0
FAULTS = (30.0, 100.0)
C1_JUMPS = (40.0, 101.0)


def _Scenario(policy="paper"):
    s = Scenario()
    s.name = "synthetic"
    s.planner.policy = policy
    s.planner.warmup = 20.0
    s.battery.faults = [BatteryFault(time=t, soc_drop=0.06) for t in FAULTS]
    return s


def _Racetrack(t):
    """A racetrack over the reference area at 12 m/s: lines x = ±60 m joined by half circles of
    60 m around (0, 40) and (0, 120) [m]."""
    r, straight = 60.0, 80.0
    lap = 2.0 * straight + 2.0 * np.pi * r
    s = (12.0 * t) % lap
    x, y = np.empty_like(s), np.empty_like(s)
    up = s < straight  # x = +60, going up
    arc1 = (s >= straight) & (s < straight + np.pi * r)
    down = (s >= straight + np.pi * r) & (s < 2 * straight + np.pi * r)
    arc2 = s >= 2 * straight + np.pi * r
    x[up], y[up] = r, 40.0 + s[up]
    a = (s[arc1] - straight) / r
    x[arc1], y[arc1] = r * np.cos(a), 120.0 + r * np.sin(a)
    x[down], y[down] = -r, 120.0 - (s[down] - straight - np.pi * r)
    a = np.pi + (s[arc2] - 2 * straight - np.pi * r) / r
    x[arc2], y[arc2] = r * np.cos(a), 40.0 + r * np.sin(a)
    return np.column_stack([x, y])


def _Log(policy="paper", completed=True):
    """A 120 s flight at 10 Hz with what the real ones show: the estimator's and the aircraft's
    start-up overshoot, a measured peak near 78 s, a fault at 30 s and one near the end (after
    which the SoC runs close to where the end text used to sit), c1 jumps, infeasible steps."""
    t = np.round(np.arange(0.0, T_END + 1e-9, 0.1), 10)
    n = len(t)
    power = 33.0 + 2.0 * np.sin(2 * np.pi * t / 48.0)
    true = power + 14.0 * np.exp(-t / 0.3)  # start-up, as the reference flights
    measured = true + 0.3 * np.sin(37.0 * t)
    measured[0] = np.nan  # the sensor's first sample
    measured[772:786] += 1.2  # readings near 78 s above the true peak, as plan i's
    measured[900] = 60.0  # one spike of the sensor
    estimated = power.copy()
    estimated[:8] = np.linspace(47.9, 36.0, 8)  # the estimator's start-up
    soc = 1.0 - 0.004 * t
    for f in FAULTS:
        soc -= 0.06 * (t >= f)
    c1 = np.where(t < C1_JUMPS[0], -500.0, -100.0)
    c1 = np.where(t >= C1_JUMPS[1], -800.0, c1)
    c2 = np.where(t < 20.0, 10.0, np.where(t < 60.0, 6.0, 2.0))
    feasible = np.ones(n)
    feasible[(t >= 60.0) & (t < 80.0)] = 0.0
    feasible[t >= 105.0] = 0.0
    predicted = np.full((n, 2), np.nan)  # the planner's view: NaN until it acts (mpc only)
    if policy == "mpc":
        step = np.floor(t / 10.0) * 10.0  # a planner step every 10 s from the warm-up on
        acted = t >= 20.0
        predicted[acted, 0] = np.interp(step[acted], t, soc) - 0.25
        predicted[acted, 1] = 0.3 + 0.002 * (T_END - step[acted])
        predicted[(t >= 110.0) & (t < 115.0), 0] = -np.inf  # a brown-out prediction: not drawn
    return FlightLog(
        times=t,
        signals={
            "position": _Racetrack(t),
            "heading": np.arctan2(*np.gradient(_Racetrack(t), axis=0).T[::-1])[:, None],
            "path_parameters": c1[:, None],
            "computation_parameters": c2[:, None],
            "measured_power": measured[:, None],
            "true_power": true[:, None],
            "estimated_power": estimated[:, None],
            "period": np.where(t < 50.0, 46.0, 50.5)[:, None],
            "soc": soc[:, None],
            "power_budget": (47.36 * soc)[:, None],
            "mission_feasible": feasible[:, None],
            "predicted_soc": predicted,
        },
        summary={
            "status": "complete" if completed else "reserve_reached",
            "completed": completed,
            "duration": T_END,
            "final_soc": soc[-1],
            "final_margin": soc[-1] - 0.3,
            "quality": 0.5,
            "metric": None,
            "policy": policy,
            "path_parameter_bounds": [-1000.0, 0.0],
            "computation_parameter_bounds": [[2.0], [10.0]],
            "planner": {"solves": 100, "infeasible": 35, "failures": 0},
        },
    )


@pytest.fixture(scope="module", params=[("paper", True), ("mpc", False), ("static", True)])
def figure(request):
    policy, completed = request.param
    log, scenario = _Log(policy, completed), _Scenario(policy)
    fig = PlotFlight(log, scenario)
    fig.canvas.draw()  # the constrained layout, the positions of every artist
    yield fig, log, scenario
    plt.close(fig)


def _Panels(fig) -> dict:
    return {ax.get_title().split(":")[0].split(" (")[0]: ax for ax in fig.axes if ax.get_title()}


def _Densified(points: np.ndarray, step: float = 1.5) -> np.ndarray:
    """Display points of a polyline, at most ``step`` pixels apart (NaN breaks the line)."""
    out = []
    for a, b in zip(points[:-1], points[1:], strict=True):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            continue
        k = max(1, int(np.ceil(np.hypot(*(b - a)) / step)))
        out.append(a + np.outer(np.arange(k + 1) / k, b - a))
    return np.vstack(out) if out else points[np.all(np.isfinite(points), axis=1)]


def _LinePoints(ax) -> list[tuple[str, np.ndarray]]:
    """(label, display points inside the axes) of every data line and line collection of
    ``ax``, each line sampled along its drawn segments (steps included)."""
    found = []
    box = ax.bbox
    for line in ax.lines:
        if not line.get_visible():
            continue
        xy = np.asarray(line.get_xydata(), dtype=float)
        if line.get_drawstyle() == "steps-post":
            xy = np.column_stack(pts_to_poststep(xy[:, 0], xy[:, 1]))
        pts = line.get_transform().transform(xy)
        if line.get_linestyle() not in ("None", "", " "):
            pts = _Densified(pts)
        found.append((line.get_label(), pts))
    for coll in ax.collections:
        if isinstance(coll, LineCollection) and coll.get_visible():
            for seg in coll.get_segments():
                found.append(("path", _Densified(coll.get_transform().transform(seg))))
    inside = []
    for label, pts in found:
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        keep = (
            (pts[:, 0] >= box.x0)
            & (pts[:, 0] <= box.x1)
            & (pts[:, 1] >= box.y0)
            & (pts[:, 1] <= box.y1)
        )
        inside.append((label, pts[keep]))
    return inside


def _TextBoxes(fig):
    """(description, display bbox) of every text in an axes (annotations, labels on the path,
    the wind) and of every legend."""
    renderer = fig.canvas.get_renderer()
    boxes = []
    for ax in fig.axes:
        for text in ax.texts:
            if text.get_visible() and text.get_text():
                boxes.append((f"text {text.get_text()!r}", text.get_window_extent(renderer)))
        legend = ax.get_legend()
        if legend is not None:
            boxes.append((f"legend of {ax.get_title()!r}", legend.get_window_extent(renderer)))
    return boxes


def test_no_text_box_covers_a_data_line(figure):
    fig, _, _ = figure
    lines = [(ax, label, pts) for ax in fig.axes for label, pts in _LinePoints(ax)]
    assert sum(len(p) for _, _, p in lines) > 5000  # the lines are there to be covered
    for name, box in _TextBoxes(fig):
        for ax, label, pts in lines:
            hit = (
                (pts[:, 0] > box.x0)
                & (pts[:, 0] < box.x1)
                & (pts[:, 1] > box.y0)
                & (pts[:, 1] < box.y1)
            )
            assert not hit.any(), (
                f"{name} covers {hit.sum()} points of {label!r} in {ax.get_title()!r}, e.g. "
                f"{pts[hit][0]} inside {box}"
            )


def test_no_legend_runs_into_another_panel(figure):
    fig, _, _ = figure
    renderer = fig.canvas.get_renderer()
    legends = [(ax, ax.get_legend()) for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 5  # one per panel (the path's below its colour bar)
    for ax, legend in legends:
        box = legend.get_window_extent(renderer)
        for other in fig.axes:
            if other is ax:
                continue
            for name, b in (
                ("axes", other.bbox),
                ("title", other.title.get_window_extent(renderer)),
            ):
                assert not box.overlaps(b), (
                    f"the legend of {ax.get_title()!r} runs into the {name} of "
                    f"{other.get_title() or other.get_xlabel()!r}"
                )


def test_each_panel_holds_its_data(figure):
    fig, log, _ = figure
    checked = 0
    for ax in fig.axes:
        x0, x1 = sorted(ax.get_xlim())
        y0, y1 = sorted(ax.get_ylim())
        tol_x, tol_y = 1e-9 * (x1 - x0), 1e-9 * (y1 - y0)
        for line in ax.lines:
            if line.get_transform() != ax.transData:
                continue  # axvline, axhline: drawn across the axes
            xy = np.asarray(line.get_xydata(), dtype=float)
            xy = xy[np.all(np.isfinite(xy), axis=1)]
            assert np.all((xy[:, 0] >= x0 - tol_x) & (xy[:, 0] <= x1 + tol_x)), line.get_label()
            assert np.all((xy[:, 1] >= y0 - tol_y) & (xy[:, 1] <= y1 + tol_y)), (
                f"{line.get_label()!r} of {ax.get_title()!r} leaves [{y0}, {y1}]: "
                f"{xy[:, 1].min()} … {xy[:, 1].max()}"
            )
            checked += len(xy)
        for coll in ax.collections:
            if isinstance(coll, LineCollection) and coll.axes is ax and coll.get_segments():
                seg = np.concatenate(coll.get_segments())
                assert np.all((seg[:, 0] >= x0) & (seg[:, 0] <= x1))
                assert np.all((seg[:, 1] >= y0) & (seg[:, 1] <= y1))
    assert checked > 5 * len(log.times)
    panels = _Panels(fig)
    assert set(panels) >= {"path", "energy", "parameters", "battery", "planner"}
    # The time panels show the whole flight, on one time axis.
    for name in ("energy", "parameters", "battery", "planner"):
        lo, hi = panels[name].get_xlim()
        assert lo == pytest.approx(0.0) and hi == pytest.approx(T_END * 1.025)


def test_energy_panel_shows_the_readings_and_marks_the_start_up_beyond_its_range(figure):
    fig, log, _ = figure
    ax = _Panels(fig)["energy"]
    lo, hi = ax.get_ylim()
    # The readings near 78 s are inside the range (it is not set by the start-up, 47.9 W).
    peak = np.nanmax(log["measured_power"][700:800, 0])
    assert lo < 31.0 and peak < hi < peak + 3.0
    # Every sample is drawn: on its line inside the range, or as a triangle on the edge.
    lines = {ln.get_label(): ln for ln in ax.lines}
    edge = [ln for ln in ax.lines if ln.get_marker() == "^"]
    beyond = {ln.get_color(): ln for ln in edge}
    for name, label in (
        ("measured_power", "measured Υ"),
        ("true_power", "true y"),
        ("estimated_power", "estimated ŷ"),
    ):
        v = log[name][:, 0]
        drawn = lines[label].get_ydata()
        inside = np.isfinite(v) & (v <= hi) & (v >= lo)
        np.testing.assert_array_equal(drawn[inside], v[inside])
        assert np.all(np.isnan(drawn[~inside]))
        over = np.isfinite(v) & (v > hi)
        marks = beyond[lines[label].get_color()]
        np.testing.assert_array_equal(marks.get_xdata(), log.times[over])
        np.testing.assert_allclose(marks.get_ydata(), hi)
        assert not marks.get_clip_on()  # the triangle is drawn whole on the edge
    t_beyond = np.concatenate([ln.get_xdata() for ln in edge])
    assert np.all((t_beyond < 1.0) | np.isclose(t_beyond, 90.0))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    when = f"{t_beyond.min():.1f}–{t_beyond.max():.1f} s"
    assert f"above the axis: {t_beyond.size} samples, to 60.0 W ({when})" in labels


def test_parameters_are_normalised_and_c2_is_visible_in_the_warm_up(figure):
    fig, _, scenario = figure
    ax = _Panels(fig)["parameters"]
    assert ax.get_ylim() == pytest.approx((-0.06, 1.06))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "c̃1: c1 from -1000 to 0 m² (c1 = r2² − r² ≤ 0; 0: densest lines)" in labels
    assert "c̃2: c2 from 2 to 10 [table units]" in labels
    # No axes is drawn over the parameters (the warm-up shading of a raised twin hid c2).
    assert not [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds]
    # The pixel of c̃2 = 1 at 10 s, in the warm-up, is c2's orange over the shading, not grey.
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255.0
    x, y = ax.transData.transform((10.0, 1.0))
    r, g, b = image[int(round(image.shape[0] - y)), int(round(x))]
    if scenario.planner.policy == "static":  # no warm-up shading: orange over white
        assert (r, g, b) == pytest.approx((1.0, 0.775, 0.57), abs=0.04)
    else:
        assert (r, g, b) == pytest.approx((0.93, 0.71, 0.51), abs=0.04)


def test_end_marker_is_whole_and_its_status_in_the_legend(figure):
    fig, log, _ = figure
    ax = _Panels(fig)["battery"]
    (end,) = [ln for ln in ax.lines if ln.get_marker() == "X"]
    x, y = ax.transData.transform((end.get_xdata()[0], end.get_ydata()[0]))
    half = 0.5 * end.get_markersize() * fig.dpi / 72.0
    assert ax.bbox.x0 + half <= x <= ax.bbox.x1 - half
    assert ax.bbox.y0 + half <= y <= ax.bbox.y1 - half
    status = "survey complete" if log.summary["completed"] else "reserve reached"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    soc = log["soc"][-1, 0]
    assert f"end: {status} at 120.0 s, b = {soc:.3f} (margin {soc - 0.3:+.3f})" in labels
    assert not ax.texts  # the status is not a box over the data


def test_path_carries_time_direction_faults_and_c1_changes(figure):
    fig, log, _ = figure
    ax = _Panels(fig)["path"]
    p = log["position"]
    step = TimeMarkStep(T_END)
    assert step == 20.0
    marks = {t.get_text(): t for t in ax.texts if t.get_text().endswith(" s")}
    for k in range(1, 6):
        label = f"{k * step:g} s"
        assert label in marks, label
        np.testing.assert_allclose(marks[label].xy, p[int(k * step * 10)], atol=1e-9)
    dots = [ln for ln in ax.lines if ln.get_marker() == "o" and len(ln.get_xdata()) == 5]
    assert len(dots) == 1
    arrows = [ln for ln in ax.lines if ln.get_marker() == ">"]
    times = np.arange(step / 6, T_END - 0.1 * step, step / 3)
    assert len(arrows) == len(times)
    for arrow, at in zip(arrows, times, strict=True):  # each points along the path, in order
        i = int(np.searchsorted(log.times, at))
        np.testing.assert_allclose(arrow.get_xydata()[0], p[i], atol=1e-9)
        d = p[i + 2] - p[i - 2]
        tip = arrow._marker.get_user_transform().transform([1.0, 0.0])  # ">" points along +x
        assert np.degrees(np.arctan2(tip[1], tip[0])) == pytest.approx(
            np.degrees(np.arctan2(d[1], d[0])), abs=1e-6
        )
    stars = [ln for ln in ax.lines if ln.get_marker() == "*"]
    np.testing.assert_allclose(
        np.column_stack(
            [
                np.concatenate([s.get_xdata() for s in stars]),
                np.concatenate([s.get_ydata() for s in stars]),
            ]
        ),
        p[[int(t * 10) for t in FAULTS]],
    )
    assert [t.get_text() for t in ax.texts if t.get_text().startswith("fault")] == [
        "fault 30 s",
        "fault 100 s",
    ]
    (diamonds,) = [ln for ln in ax.lines if ln.get_marker() == "D"]
    np.testing.assert_allclose(diamonds.get_xydata(), p[[int(t * 10) for t in C1_JUMPS]])
    assert diamonds.get_markeredgecolor() == COLORS["c1"]


def test_path_and_replay_colour_the_quality_on_one_map(figure):
    fig, log, _ = figure
    ax = _Panels(fig)["path"]
    (path,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert path.get_cmap().name == QUALITY_COLORMAP
    np.testing.assert_allclose(path.get_array(), SampleQuality(log)[:-1])
    assert path.norm.vmin == 0.0 and path.norm.vmax == 1.0
    colorbars = [a for a in fig.axes if a.get_xlabel() == "quality ½c̃1 + ½c̃2 [-]"]
    assert len(colorbars) == 1
    # The path's legend hangs below its colour bar; its swatch runs through the same map.
    legend = colorbars[0].get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert "flown path, colour: quality ½c̃1 + ½c̃2 [-]" in labels
    # The replay's flown chunks are coloured by the same map at their quality bin.
    from eaplan_drake.output.replay import PathChunks, SaveFlightReplay

    meshcat = _RecordingMeshcat()
    SaveFlightReplay(log, _Scenario(), _TmpHtml(), frame_rate=1.0, meshcat=meshcat)
    cmap = matplotlib.colormaps[QUALITY_COLORMAP]
    chunks = PathChunks(SampleQuality(log), num_colours=8)
    flown = [c for c in meshcat.calls if c[0] == "SetTriangleMesh" and "/flown/" in c[1][0]]
    assert len(flown) == len(chunks)
    for (_, args), (_, _, colour) in zip(flown, chunks, strict=True):
        rgba = args[3]
        expected = cmap((colour + 0.5) / 8)[:3]
        assert (rgba.r(), rgba.g(), rgba.b()) == pytest.approx(expected, abs=1e-12)


class _RecordingMeshcat:
    """Records every call; the one answer needed is StaticHtml's page."""

    def __init__(self):
        self.calls = []

    def StaticHtml(self):
        return "<html><body></body></html>"

    def __getattr__(self, name):
        def record(*args, **kwargs):
            self.calls.append((name, args))

        return record


def _TmpHtml():
    import tempfile
    from pathlib import Path

    return Path(tempfile.mkdtemp()) / "replay.html"


def test_planner_panel_shades_the_infeasible_steps_with_their_cause(figure):
    fig, log, scenario = figure
    ax = _Panels(fig)["planner"]
    policy = scenario.planner.policy
    spans = [
        p
        for p in ax.patches
        if isinstance(p, Rectangle)
        and p.get_facecolor()[:3] == pytest.approx(matplotlib.colors.to_rgb(COLORS["infeasible"]))
    ]
    runs = Runs(log["mission_feasible"][:, 0] < 0.5)
    assert len(spans) == len(runs) == 2
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    why, what = InfeasibleCause(policy)
    assert f"infeasible: 35 steps where {why};\n{what}" in labels
    lines = {ln.get_label(): ln for ln in ax.lines}
    if policy == "paper":
        assert why == "the paper's output constraint y ≤ b·Q_c·V cannot hold"
        budget = lines["b·Q_c·V, logged power_budget"]
        np.testing.assert_allclose(budget.get_ydata(), log["power_budget"][:, 0])
        assert "estimated ŷ" in lines
    else:
        (flag,) = [ln for ln in ax.lines if ln.get_label().startswith("mission_feasible")]
        np.testing.assert_allclose(flag.get_ydata(), log["mission_feasible"][:, 0])
        assert "power_budget" not in " ".join(lines)
    if policy == "mpc":
        assert why == "even the lowest plan ends below reserve + margin"


def test_battery_panel_draws_the_planners_predicted_and_required_end_soc(figure):
    fig, log, scenario = figure
    ax = _Panels(fig)["battery"]
    lines = {ln.get_label(): ln for ln in ax.lines}
    names = ("predicted end SoC (chosen plan)", "required at the end (reserve + margin)")
    if scenario.planner.policy != "mpc":  # NaN throughout: nothing drawn
        assert not set(names) & set(lines)
        return
    for i, (name, color) in enumerate(zip(names, (COLORS["soc"], COLORS["reserve"]), strict=True)):
        line = lines[name]
        assert line.get_linestyle() == "--"
        assert matplotlib.colors.to_rgb(line.get_color()) == matplotlib.colors.to_rgb(color)
        assert line.get_drawstyle() == "steps-post"
        y = np.asarray(line.get_ydata(), dtype=float)
        v = log["predicted_soc"][:, i]
        np.testing.assert_array_equal(np.isfinite(y), np.isfinite(v))
        np.testing.assert_array_equal(y[np.isfinite(y)], v[np.isfinite(v)])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert set(names) <= set(labels)
