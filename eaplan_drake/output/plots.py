"""Matplotlib figures of a flight, in the spirit of paper 003 Fig. 6, and of several policies.

The math behind the pictures is in plain functions over numpy
(:mod:`~eaplan_drake.output.plot_math`), each tested on its own; the path panel and its pieces
are in :mod:`~eaplan_drake.output.path_plot`, the colours and the shared texts in
:mod:`~eaplan_drake.output.plot_style`. Each ``Plot*`` function draws into a given ``Axes`` (so
notebooks can compose them): :func:`PlotFlight` makes the five-panel figure of one flight (path,
energy, parameters, battery, planner) and :func:`SaveFlightPlots` writes it as PNG;
:func:`PlotPolicyComparison` draws several flights of one world side by side.

The conventions of every figure here and of the Meshcat replay
(:mod:`~eaplan_drake.output.replay`):

- the parameters are drawn normalised, c̃ = (c − c̲)/(c̄ − c̲) ∈ [0, 1], 0 the lowest quality and
  1 the highest, by the bounds the log's summary carries. The path parameter is
  c1 = r2² − r² [m²] ≤ 0 (r the turning radius of the plan, r2 = sqrt(r² + c1) ≤ r the inner
  one; c1 = 0 flies the densest lines), the computation parameters c2 are in the computation
  table's units (fps for the PedNet detector);
- the flown path is coloured by the quality ½c̃1 + ½c̃2 on
  :data:`~eaplan_drake.output.plot_style.QUALITY_COLORMAP`, the integrand of the summary's
  quality;
- one colour, one meaning (:data:`~eaplan_drake.output.plot_style.COLORS`); on every time panel
  the planner's warm-up is shaded grey and each battery fault is a red dotted line; text goes in
  legends outside the data.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.files import AtomicWrite
from eaplan_drake.flightlog import (
    FlightLog,
    NormalisedParameters,
    NormaliseParameters,
)
from eaplan_drake.output.path_plot import PlotPath
from eaplan_drake.output.plot_math import RobustRange, Runs
from eaplan_drake.output.plot_style import (
    _C1_NOTE,
    _QUALITY_LABEL,
    COLORS,
    InfeasibleCause,
    _Cause,
    _EndText,
    _Faults,
    _PathBounds,
)
from eaplan_drake.params import Scenario
from eaplan_drake.registry import POLICIES

__all__ = [
    "MarkEvents",
    "PlotFlight",
    "PlotParameters",
    "PlotPlanner",
    "PlotPolicyComparison",
    "PlotPower",
    "PlotSoc",
    "SaveFigure",
    "SaveFlightPlots",
    "SavePolicyComparison",
]


def MarkEvents(ax, scenario: Scenario, legend: bool = True) -> list:
    """Shades the planner's warm-up [0, warm-up] and draws each battery fault as a dotted
    vertical line on a time axis (both below the data of ``ax``); returns legend handles."""
    handles = []
    warmup = float(scenario.planner.warmup)
    if warmup > 0.0 and not POLICIES.Info(scenario.planner.policy).holds_parameters:
        ax.axvspan(0.0, warmup, color=COLORS["warmup"], zorder=0, lw=0)
        handles.append(Patch(color=COLORS["warmup"], label=f"warm-up ({warmup:g} s)"))
    for fault in scenario.battery.faults:
        ax.axvline(fault.time, color=COLORS["fault"], ls=":", lw=1.2, zorder=1)
    if scenario.battery.faults:
        handles.append(
            Line2D([], [], color=COLORS["fault"], ls=":", label=f"fault ({_Faults(scenario)})")
        )
    return handles if legend else []


def _TimeRange(log: FlightLog) -> tuple[float, float]:
    """The time axis [s] of every time panel: the flight, and 2.5 % more on the right so the end
    marker is drawn whole."""
    t0, t1 = float(log.times[0]), float(log.times[-1])
    return t0, t1 + 0.025 * max(t1 - t0, 1.0)


def _Policy(log: FlightLog, scenario: Scenario | None) -> str:
    default = scenario.planner.policy if scenario is not None else "?"
    return str(log.summary.get("policy", default))


def _ComputationBounds(log: FlightLog, scenario: Scenario | None) -> tuple[np.ndarray, np.ndarray]:
    bounds = log.summary.get("computation_parameter_bounds")
    if bounds is None and scenario is not None:
        table = LoadComputationTable(scenario.computation.table)
        bounds = (table.lower, table.upper)
    if bounds is None:
        c2 = np.asarray(log["computation_parameters"], dtype=float).reshape(len(log.times), -1)
        bounds = (c2.min(axis=0), c2.max(axis=0))
    return np.asarray(bounds[0], dtype=float).ravel(), np.asarray(bounds[1], dtype=float).ravel()


def _FinishTimePanel(ax, handles, ncol: int, time_range, title: str) -> None:
    """A time panel's legend below its axes, its time range [s] and its title."""
    ax.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.13),
        fontsize="small",
        ncol=ncol,
        frameon=False,
    )
    ax.set_xlim(*time_range)
    ax.set_xlabel("t [s]")
    ax.set_title(title)


# --- the panels -------------------------------------------------------------------------------


def PlotPower(ax, log: FlightLog, scenario: Scenario | None = None) -> None:
    """Measured, true and estimated power [W], with the period estimate on a twin axis.

    The y-range holds the 0.5–99.5 % quantiles of all three signals widened by 20 % of their
    span on each side: a few samples (the estimator's and the aircraft's start-up) do not squeeze
    the rest into a band, and every reading of the flight (a sensor's peak included) is shown.
    Samples beyond that range are not drawn off the axes but as triangles on its edge, counted
    with their extreme value in the legend."""
    t = log.times
    handles = [] if scenario is None else MarkEvents(ax, scenario)
    series = (
        ("measured_power", "measured Υ", COLORS["measured"], 0.6),
        ("true_power", "true y", COLORS["true"], 0.8),
        ("estimated_power", "estimated ŷ", COLORS["estimated"], 1.0),
    )
    values = {name: np.asarray(log[name], dtype=float)[:, 0] for name, *_ in series}
    lo, hi = RobustRange(np.concatenate(list(values.values())), pad=0.2)
    lines = []
    beyond = {+1: [], -1: []}
    for name, label, color, lw in series:
        v = values[name]
        over, under = v > hi, v < lo
        (line,) = ax.plot(t, np.where(over | under, np.nan, v), color=color, lw=lw, label=label)
        lines.append(line)
        for side, mask, edge, marker in ((+1, over, hi, "^"), (-1, under, lo, "v")):
            if mask.any():
                ax.plot(
                    t[mask],
                    np.full(mask.sum(), edge),
                    marker,
                    color=color,
                    ms=5,
                    ls="",
                    clip_on=False,
                    zorder=4,
                )
                beyond[side].append((t[mask], v[mask]))
    for side, found in beyond.items():
        if found:
            tb = np.concatenate([a for a, _ in found])
            vb = np.concatenate([b for _, b in found])
            extreme = vb.max() if side > 0 else vb.min()
            where = "above" if side > 0 else "below"
            when = (
                f"{tb.min():.1f} s" if tb.min() == tb.max() else f"{tb.min():.1f}–{tb.max():.1f} s"
            )
            handles.append(
                Line2D(
                    [],
                    [],
                    marker="^" if side > 0 else "v",
                    color="0.4",
                    ls="",
                    ms=5,
                    label=f"{where} the axis: {tb.size} sample{'s' * (tb.size > 1)}, "
                    f"to {extreme:.1f} W ({when})",
                )
            )
    ax.set_ylim(lo, hi)
    ax.set_ylabel("power [W]")
    twin = ax.twinx()
    (per,) = twin.plot(t, log["period"][:, 0], color=COLORS["period"], lw=1.0, ls="--")
    per.set_label("period T (right)")
    plo, phi = RobustRange(log["period"][:, 0], quantiles=(0.0, 1.0), pad=0.1)
    # The period in the top third of the panel, ticked only where it can be.
    twin.set_ylim(plo - 1.5 * (phi - plo), phi + 0.1 * (phi - plo))
    ticks = MaxNLocator(4).tick_values(plo, phi)
    twin.set_yticks(ticks[(ticks >= plo - 1e-9) & (ticks <= phi + 1e-9)] if phi > plo else [plo])
    twin.set_ylabel("period T [s]", color=COLORS["period"])
    _FinishTimePanel(ax, [*lines, per, *handles], 3, _TimeRange(log), "energy")


def PlotSoc(ax, log: FlightLog, scenario: Scenario) -> None:
    """State of charge b with the battery faults, the reserve and the end (a marker, and its
    status in the legend)."""
    handles = MarkEvents(ax, scenario)
    (b,) = ax.plot(log.times, log["soc"][:, 0], color=COLORS["soc"], label="SoC b")
    reserve = scenario.battery.reserve_soc
    rl = ax.axhline(reserve, color=COLORS["reserve"], ls="--", label=f"reserve {reserve:g}")
    s = log.summary
    t_end, b_end = log.times[-1], log["soc"][-1, 0]
    end = {"marker": "X", "color": COLORS["progress"], "mec": "white", "mew": 0.8, "ls": ""}
    ax.plot(t_end, b_end, ms=10, zorder=5, **end)
    margin = s.get("final_margin", b_end - reserve)
    end_handle = Line2D(
        [], [], ms=9, label=f"end: {_EndText(s)}, b = {b_end:.3f} (margin {margin:+.3f})", **end
    )
    predicted = _PredictedSoc(ax, log)
    lowest = min([0.0, *(float(np.nanmin(ln.get_ydata())) for ln in predicted)])
    ax.set_ylim(lowest - (0.03 if lowest < 0.0 else 0.0), 1.05)
    ax.set_ylabel("b [-]")
    _FinishTimePanel(ax, [b, rl, *predicted, end_handle, *handles], 2, _TimeRange(log), "battery")


def _PredictedSoc(ax, log: FlightLog) -> list:
    """The planner's logged ``predicted_soc`` as dashed step lines where finite: the end SoC it
    predicts for the plan it chose and the SoC it requires at the end (reserve + margin)."""
    values = np.asarray(log.signals.get("predicted_soc", np.zeros((0, 0))), dtype=float)
    if values.ndim != 2 or values.shape[0] != len(log.times) or values.shape[1] < 2:
        return []
    lines = []
    for i, label, color, ls in (
        (0, "predicted end SoC (chosen plan)", COLORS["soc"], "--"),
        (1, "required at the end (reserve + margin)", COLORS["reserve"], (0, (2.0, 1.5))),
    ):
        v = np.where(np.isfinite(values[:, i]), values[:, i], np.nan)
        if np.any(np.isfinite(v)):
            (line,) = ax.step(
                log.times, v, where="post", color=color, ls=ls, lw=1.0, label=label, zorder=2
            )
            lines.append(line)
    return lines


def PlotParameters(ax, log: FlightLog, scenario: Scenario | None = None) -> None:
    """The path parameter c̃1 and the computation parameter(s) c̃2, normalised to [0, 1] by the
    bounds of the log's summary (0 the lowest quality, 1 the highest; the legend gives the
    bounds in their units). c̃2 is drawn wide and light, c̃1 thin on top, so equal values
    coincide and both stay visible."""
    handles = [] if scenario is None else MarkEvents(ax, scenario)
    t = log.times
    lo, hi = _PathBounds(log, scenario)
    clo, chi = _ComputationBounds(log, scenario)
    c1n = NormaliseParameters(log["path_parameters"][:, 0], lo, hi)
    c2 = np.asarray(log["computation_parameters"], dtype=float).reshape(len(t), -1)
    c2n = NormaliseParameters(c2, clo, chi)
    c2_lines = []
    for j in range(c2.shape[1]):
        name = "c2" if c2.shape[1] == 1 else f"c2[{j}]"
        (line,) = ax.step(
            t,
            c2n[:, j],
            where="post",
            color=COLORS["c2"],
            lw=4.0,
            alpha=0.45,
            ls=["-", "--", ":"][j % 3],
            zorder=2,
            label=f"c̃{name[1:]}: {name} from {clo[j]:g} to {chi[j]:g} [table units]",
        )
        c2_lines.append(line)
    (c1_line,) = ax.step(
        t,
        c1n,
        where="post",
        color=COLORS["c1"],
        lw=1.4,
        zorder=3,
        label=f"c̃1: c1 from {lo:g} to {hi:g} m² ({_C1_NOTE}; 0: densest lines)",
    )
    ax.set_ylim(-0.06, 1.06)
    ax.set_ylabel("c̃ = (c − c̲)/(c̄ − c̲) [-]")
    _FinishTimePanel(ax, [c1_line, *c2_lines, *handles], 2, _TimeRange(log), "parameters")


def PlotPlanner(ax, log: FlightLog, scenario: Scenario) -> None:
    """What the planner logged: the steps with ``mission_feasible`` = 0 shaded, with their cause
    (:func:`~eaplan_drake.output.plot_style.InfeasibleCause`); for the policies of the paper's
    output constraint y ≤ b·Q_c·V (paper, greedy_authors) the bound ``power_budget`` b·Q_c·V and
    the estimated power ŷ the planner predicts from, otherwise ``mission_feasible`` itself (1: the
    constraint holds)."""
    t = log.times
    policy = _Policy(log, scenario)
    handles = MarkEvents(ax, scenario)
    feasible = np.asarray(log.signals.get("mission_feasible", np.ones((len(t), 1))))[:, 0]
    infeasible = Runs(feasible < 0.5)
    t_end = _TimeRange(log)[1]
    for a, b in infeasible:
        right = t[b] if b < len(t) else t_end
        ax.axvspan(t[a], right, color=COLORS["infeasible"], alpha=0.35, lw=0, zorder=0.5)
    lines = []
    if POLICIES.Info(policy).power_budget and "power_budget" in log.signals:
        budget = np.asarray(log["power_budget"], dtype=float)[:, 0]
        estimate = np.asarray(log["estimated_power"], dtype=float)[:, 0]
        (lb,) = ax.plot(
            t, budget, color=COLORS["budget"], lw=1.4, label="b·Q_c·V, logged power_budget"
        )
        (le,) = ax.plot(t, estimate, color=COLORS["estimated"], lw=0.9, label="estimated ŷ")
        lines = [lb, le]
        v = np.concatenate([budget, estimate])
        v = v[np.isfinite(v)]
        lo, hi = (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)
        span = max(hi - lo, 1.0)
        ax.set_ylim(lo - 0.06 * span, hi + 0.06 * span)
        ax.set_ylabel("power [W]; b·Q_c·V [Ah·V, read as W]")
        title = "planner: the paper's output constraint y ≤ b·Q_c·V"
    else:
        (lf,) = ax.step(
            t,
            feasible,
            where="post",
            color=COLORS["infeasible"],
            lw=1.4,
            label=f"mission_feasible (1: {_Cause(policy)[2]})",
        )
        lines = [lf]
        ax.set_ylim(-0.1, 1.1)
        ax.set_yticks([0.0, 1.0])
        ax.set_ylabel("mission_feasible [-]")
        title = f"planner ({policy})"
        if POLICIES.Info(policy).holds_parameters:
            title = f"planner ({policy}: the initial parameters held, never re-planned)"
    if infeasible:
        steps = log.summary.get("planner", {}).get("infeasible")
        if steps is None:
            period = float(scenario.planner.period)
            steps = int(round(sum(t[min(b, len(t) - 1)] - t[a] for a, b in infeasible) / period))
        why, what = InfeasibleCause(policy)
        handles.insert(
            0,
            Patch(
                color=COLORS["infeasible"],
                alpha=0.35,
                label=f"infeasible: {steps} steps where {why};\n{what}",
            ),
        )
    _FinishTimePanel(ax, [*lines, *handles], 2, _TimeRange(log), title)


def PlotFlight(log: FlightLog, scenario: Scenario):
    """The five-panel figure of a flight: the path (left, two rows), energy and parameters
    (right), the battery and the planner (bottom); returns the ``Figure``."""
    fig = plt.figure(figsize=(16, 16), layout="constrained")
    grid = fig.add_gridspec(3, 2, width_ratios=[1.3, 1.0])
    PlotPath(fig.add_subplot(grid[0:2, 0]), log, scenario)
    PlotPower(fig.add_subplot(grid[0, 1]), log, scenario)
    PlotParameters(fig.add_subplot(grid[1, 1]), log, scenario)
    PlotSoc(fig.add_subplot(grid[2, 0]), log, scenario)
    PlotPlanner(fig.add_subplot(grid[2, 1]), log, scenario)
    fig.suptitle(_Title(log, scenario))
    return fig


def _Title(log: FlightLog, scenario: Scenario) -> str:
    s = log.summary
    metric = s.get("metric")
    return (
        f"{scenario.name} (policy {s.get('policy', scenario.planner.policy)}): "
        f"{s.get('status', '?')} after {s.get('duration', float('nan')):.1f} s, "
        f"quality {s.get('quality', float('nan')):.3f}, "
        f"final SoC {s.get('final_soc', float('nan')):.3f}, "
        f"P = {'fail' if metric is None else f'{metric:.3f}'}"
    )


_FLIGHT_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:olive")
"""Colours of the flights of :func:`PlotPolicyComparison` (no red: faults; no cyan: reserve)."""


def PlotPolicyComparison(logs: dict, scenario: Scenario):
    """Several flights of one world side by side (``logs``: name → :class:`FlightLog`, e.g. one
    per planner policy): a path panel per flight coloured by the quality ½c̃1 + ½c̃2, and below
    the SoC, c̃1 and c̃2 of all of them over time. Returns the ``Figure``."""
    names = list(logs)
    if not names:
        raise ValueError("PlotPolicyComparison: no flights given")
    n = len(names)
    fig = plt.figure(figsize=(max(13.0, 4.6 * n), 10), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.0, 1.0])
    path_axes = top.subplots(1, n, squeeze=False)[0]
    ax_soc, ax_c1, ax_c2 = bottom.subplots(1, 3)
    t_end = 0.0
    for i, name in enumerate(names):
        log = logs[name]
        color = _FLIGHT_COLORS[i % len(_FLIGHT_COLORS)]
        lc = PlotPath(
            path_axes[i], log, scenario, colour_by="quality", legend=False, colorbar=False
        )
        s = log.summary
        path_axes[i].set_title(
            f"{name}: {s.get('status', '?')}, quality {s.get('quality', float('nan')):.3f}",
            color=color,
        )
        t = log.times
        t_end = max(t_end, _TimeRange(log)[1])
        ax_soc.plot(t, log["soc"][:, 0], color=color, label=name)
        ax_soc.plot(t[-1], log["soc"][-1, 0], "X", color=color, mec="k")
        c1n, c2n = NormalisedParameters(log)
        # Each flight a little lower than the previous so equal steps stay visible.
        offset = -0.012 * i
        ax_c1.step(t, c1n + offset, where="post", color=color, lw=1.3, label=name)
        ax_c2.step(t, c2n + offset, where="post", color=color, lw=1.3, label=name)
    top.colorbar(lc, ax=path_axes, label=_QUALITY_LABEL, shrink=0.8)
    ax_soc.axhline(scenario.battery.reserve_soc, color=COLORS["reserve"], ls="--", label="reserve")
    for ax, ylabel, title in (
        (ax_soc, "b [-]", "battery"),
        (ax_c1, f"c̃1 [-] ({_C1_NOTE}, normalised)", "path parameter (normalised)"),
        (ax_c2, "c̃2 [-]", "computation parameter (normalised)"),
    ):
        handles = MarkEvents(ax, scenario)
        ax.set_xlabel("t [s]")
        ax.set_xlim(0.0, t_end)
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.set_ylim(-0.08, 1.08)
        ax.legend(
            handles=[*ax.get_legend_handles_labels()[0], *handles],
            loc="upper center",
            bbox_to_anchor=(0.5, -0.14),
            fontsize="small",
            ncol=1,
            frameon=False,
        )
    fig.suptitle(
        f"policies on one world: {scenario.name} (dot: start, X: end, hatched: not covered)"
    )
    return fig


# --- files ------------------------------------------------------------------------------------


def SaveFigure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Saves ``fig`` to ``path`` whole or not at all (temporary file, fsync, rename; see
    :func:`~eaplan_drake.files.AtomicWrite`) and closes it; the format is the suffix's."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fmt = path.suffix.lstrip(".") or "png"
    try:
        AtomicWrite(path, lambda f: fig.savefig(f, format=fmt, dpi=dpi), binary=True)
    finally:
        plt.close(fig)
    return path


def SaveFlightPlots(log: FlightLog, scenario: Scenario, directory: str | Path) -> Path:
    """Saves :func:`PlotFlight` as ``<directory>/flight.png``; returns the path."""
    return SaveFigure(PlotFlight(log, scenario), Path(directory) / "flight.png")


def SavePolicyComparison(logs: dict, scenario: Scenario, path: str | Path) -> Path:
    """Saves :func:`PlotPolicyComparison` as PNG at ``path``; returns the path."""
    return SaveFigure(PlotPolicyComparison(logs, scenario), path)
