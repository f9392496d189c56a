"""Matplotlib figures of a flight, in the spirit of paper 003 Fig. 6, and of several policies.

The math behind the pictures is in plain functions over numpy (:func:`UncoveredArea`,
:func:`RobustRange`, :func:`StagePoints`, :func:`SampleQuality`), each tested on its own. Each
``Plot*`` function draws into a given ``Axes`` (so notebooks can compose them):
:func:`PlotFlight` makes the four-panel figure of one flight and :func:`SaveFlightPlots` writes it
as PNG; :func:`PlotPolicyComparison` draws several flights of one world side by side.

On every time panel the planner's warm-up is shaded and each battery fault is a dotted line.
"""

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.path import Path as MplPath
from matplotlib.transforms import ScaledTranslation

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.files import AtomicWrite
from eaplan_drake.flight.coverage import APPROACH, TurningRadius2
from eaplan_drake.flightlog import (
    FlightLog,
    NormalisedParameters,
    NormaliseParameters,
    SampleQuality,
)
from eaplan_drake.params import Scenario, WindVector

__all__ = [
    "DrawPlan",
    "DrawSurveyArea",
    "MarkEvents",
    "PlotFlight",
    "PlotParameters",
    "PlotPath",
    "PlotPolicyComparison",
    "PlotPower",
    "PlotSoc",
    "RobustRange",
    "SaveFigure",
    "SaveFlightPlots",
    "SavePolicyComparison",
    "StagePoints",
    "UncoveredArea",
    "UncoveredRadius",
]

_WARMUP_COLOR = "0.88"
_FAULT_COLOR = "tab:red"
_C1_COLOR = "tab:blue"
_C2_COLOR = "tab:orange"


# --- the math behind the pictures -----------------------------------------------------------


def StagePoints(stage, step: float = 2.0) -> np.ndarray:
    """Points [m] (k × 2) of a plan stage from its entry to its trigger: the segment of a line,
    or the arc of a circle in the direction of travel, sampled every ≈ ``step`` metres."""
    entry = np.asarray(stage.entry, dtype=float)
    if not stage.is_circle:
        return np.array([entry, np.asarray(stage.trigger, dtype=float)])
    o, r = np.asarray(stage.path.center, dtype=float), float(stage.path.radius)
    v, t = entry - o, stage.path.tangent(entry)
    sign = 1.0 if v[0] * t[1] - v[1] * t[0] > 0 else -1.0  # counter-clockwise: +1
    n = 2 + int(stage.length / step)
    a = math.atan2(v[1], v[0]) + sign * np.linspace(0.0, stage.length / r, n)
    return o + r * np.column_stack([np.cos(a), np.sin(a)])


def UncoveredArea(
    polygon, path, radius: float, resolution: float = 2.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The part of the survey ``polygon`` [m] farther than ``radius`` [m] from the flown
    ``path`` [m] (k × 2), on a grid of cell size ``resolution`` [m].

    Returns ``(x, y, mask, fraction)``: the cell centres along x and y, the boolean mask
    (len(y) × len(x), True = inside the polygon and not covered) and the uncovered fraction of
    the polygon's cells.
    """
    poly = np.asarray(polygon, dtype=float)
    if resolution <= 0.0 or radius < 0.0:
        raise ValueError(f"resolution must be > 0 and radius ≥ 0, got {resolution}, {radius}")
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    x = np.arange(lo[0] + resolution / 2, hi[0], resolution)
    y = np.arange(lo[1] + resolution / 2, hi[1], resolution)
    gx, gy = np.meshgrid(x, y)
    inside = MplPath(poly).contains_points(np.column_stack([gx.ravel(), gy.ravel()]))
    inside = inside.reshape(gx.shape)
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    # Resample the path so consecutive points are at most half a cell apart.
    dense = [p[:1]]
    for a, b in zip(p[:-1], p[1:], strict=True):
        k = max(1, int(np.ceil(2.0 * np.linalg.norm(b - a) / resolution)))
        dense.append(a + np.outer(np.arange(1, k + 1) / k, b - a))
    p = np.vstack(dense)
    # Mark the cells the path visits (with a margin of the radius), then dilate by a disk.
    reach = int(np.ceil(radius / resolution)) + 1
    ix = np.floor((p[:, 0] - lo[0]) / resolution).astype(int) + reach
    iy = np.floor((p[:, 1] - lo[1]) / resolution).astype(int) + reach
    hit = np.zeros((len(y) + 2 * reach, len(x) + 2 * reach), dtype=bool)
    ok = (ix >= 0) & (ix < hit.shape[1]) & (iy >= 0) & (iy < hit.shape[0])
    hit[iy[ok], ix[ok]] = True
    covered = np.zeros(gx.shape, dtype=bool)
    for di in range(-reach, reach + 1):
        for dj in range(-reach, reach + 1):
            if (abs(di) - 0.5) ** 2 + (abs(dj) - 0.5) ** 2 > (radius / resolution) ** 2 and (
                di or dj
            ):
                continue
            covered |= hit[reach + di : reach + di + len(y), reach + dj : reach + dj + len(x)]
    mask = inside & ~covered
    fraction = float(mask.sum() / inside.sum()) if inside.any() else 0.0
    return x, y, mask, fraction


def UncoveredRadius(scenario: Scenario) -> float:
    """Half the widest line spacing of the plan [m]: (2 r1 − 2 r2(c̲1)) / 2 with
    r1 = r + x_d/2 and r2 = sqrt(r² + c1) (paper 003 Eq. 14): a point of the survey area
    farther than this from every flown line was not swept at any c1."""
    cov = scenario.coverage
    r1 = cov.turning_radius + 0.5 * cov.swath_spacing
    lo = float(scenario.planner.path_parameter_bounds[0])
    return r1 - TurningRadius2(lo, cov.turning_radius)


def RobustRange(values, quantiles=(0.005, 0.995), pad: float = 0.08) -> tuple[float, float]:
    """(low, high) axis limits that hold the ``quantiles`` of the finite ``values`` widened by
    ``pad`` × their span on each side: a short transient (the estimator's start-up) does not set
    the range."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = np.quantile(v, quantiles)
    span = hi - lo if hi > lo else max(abs(hi), 1.0)
    return float(lo - pad * span), float(hi + pad * span)


# --- drawing helpers --------------------------------------------------------------------------


def DrawSurveyArea(ax, polygon, start=None) -> None:
    """The survey polygon [m] (grey) and the start position (black dot), equal axes."""
    poly = np.asarray(polygon, dtype=float)
    ax.fill(poly[:, 0], poly[:, 1], color="0.92", zorder=0, label="survey area")
    if start is not None:
        ax.plot(*np.asarray(start, dtype=float), "ko", ms=4, label="start", zorder=4)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def DrawPlan(ax, stages, color="tab:blue", lw: float = 1.0, label=None, triggers=True) -> None:
    """The stages of a plan: lines and arcs (the approach dashed), triggering points as dots."""
    # The label goes on the first solid stage, so the legend shows a solid line.
    labelled = next((i for i, s in enumerate(stages) if s.primitive != APPROACH), 0)
    for i, s in enumerate(stages):
        pts = StagePoints(s)
        ls = "--" if s.primitive == APPROACH else "-"
        ax.plot(*pts.T, color=color, lw=lw, ls=ls, label=label if i == labelled else None)
    if triggers and len(stages):
        trig = np.array([s.trigger for s in stages])
        ax.plot(*trig.T, ".", color=color, ms=3)


def MarkEvents(ax, scenario: Scenario, legend: bool = True) -> list:
    """Shades the planner's warm-up [0, warm-up] and draws each battery fault as a dotted
    vertical line on a time axis; returns legend handles."""
    handles = []
    warmup = float(scenario.planner.warmup)
    if warmup > 0.0 and scenario.planner.policy not in ("static", "hindsight"):
        ax.axvspan(0.0, warmup, color=_WARMUP_COLOR, zorder=0, lw=0)
        handles.append(Patch(color=_WARMUP_COLOR, label=f"warm-up ({warmup:g} s)"))
    for fault in scenario.battery.faults:
        ax.axvline(fault.time, color=_FAULT_COLOR, ls=":", lw=1.2, zorder=1)
    if scenario.battery.faults:
        drops = ", ".join(
            f"−{100 * f.soc_drop:g} % at {f.time:g} s" for f in scenario.battery.faults
        )
        handles.append(Line2D([], [], color=_FAULT_COLOR, ls=":", label=f"fault ({drops})"))
    return handles if legend else []


def _EndText(summary: dict) -> str:
    status = summary.get("status", "?")
    t = summary.get("duration", float("nan"))
    if status == "complete":
        return f"survey complete at {t:.1f} s"
    if status == "reserve_reached":
        return f"reserve reached at {t:.1f} s"
    if status == "brownout":
        return f"brown-out at {t:.1f} s"
    if status == "time_limit":
        return f"time limit {t:.0f} s"
    return f"{status} at {t:.1f} s"


def _WindArrow(ax, scenario: Scenario) -> None:
    """The wind as an arrow with its speed in the band above the flown area (axes coordinates,
    the direction true on the equal-aspect axes)."""
    speed = float(scenario.wind.speed)
    if speed <= 0.0:
        ax.text(0.02, 0.97, "no wind", transform=ax.transAxes, va="top", fontsize="small")
        return
    w = WindVector(1.0, scenario.wind.direction_deg)
    half = 13.0 / 72.0  # half the arrow's length [inch]
    anchor = (0.07, 0.925)

    def shifted(sign):
        return ax.transAxes + ScaledTranslation(
            sign * half * w[0], sign * half * w[1], ax.figure.dpi_scale_trans
        )

    ax.annotate(
        "",
        xy=anchor,
        xycoords=shifted(1.0),
        xytext=anchor,
        textcoords=shifted(-1.0),
        arrowprops={"arrowstyle": "-|>", "color": "tab:red", "lw": 1.8},
    )
    ax.text(
        anchor[0] + 0.05,
        anchor[1],
        f"wind {speed:g} m/s towards {scenario.wind.direction_deg:g}°",
        transform=ax.transAxes,
        color="tab:red",
        va="center",
        fontsize="small",
    )


# --- the panels -------------------------------------------------------------------------------


def PlotPath(
    ax,
    log: FlightLog,
    scenario: Scenario,
    colour_by: str = "path",
    legend: bool = True,
    colorbar: bool = True,
):
    """Flown path over the survey polygon, coloured by the normalised path parameter c̃1
    (``colour_by="path"``) or the quality ½c̃1 + ½c̃2 (``"quality"``); the end point with its
    status, the part of the area left uncovered (hatched) when the survey did not complete, and
    the wind arrow in a band above the flown area. Returns the path's ``LineCollection`` (for a
    shared colour bar)."""
    p = log["position"]
    poly = np.asarray(scenario.coverage.polygon, dtype=float)
    DrawSurveyArea(ax, poly, p[0])
    if colour_by == "quality":
        value, label = SampleQuality(log), "quality ½c̃1 + ½c̃2"
    else:
        lo, hi = scenario.planner.path_parameter_bounds
        value = NormaliseParameters(log["path_parameters"][:, 0], lo, hi)
        label = "c̃1 (normalised path parameter)"
    segments = np.stack([p[:-1], p[1:]], axis=1)
    lc = LineCollection(segments, cmap="viridis", norm=plt.Normalize(0.0, 1.0), linewidth=1.2)
    lc.set_array(value[:-1])
    ax.add_collection(lc)
    if colorbar:
        ax.figure.colorbar(lc, ax=ax, label=label, shrink=0.8)
    handles = [
        Patch(color="0.92", label="survey area"),
        Line2D([], [], color=plt.get_cmap("viridis")(0.6), lw=1.2, label="flown path"),
        Line2D([], [], marker="o", color="k", ls="", ms=4, label="start"),
    ]
    s = log.summary
    end_color = "tab:green" if s.get("completed") else "tab:red"
    ax.plot(*p[-1], marker="X", color=end_color, ms=9, mec="k", mew=0.6, ls="", zorder=5)
    handles.append(
        Line2D(
            [], [], marker="X", color=end_color, mec="k", ls="", ms=8, label="end: " + _EndText(s)
        )
    )
    if s and not s.get("completed", True):
        x, y, mask, fraction = UncoveredArea(poly, p, UncoveredRadius(scenario))
        if mask.any():
            ax.contourf(
                x,
                y,
                mask.astype(float),
                levels=[0.5, 1.5],
                colors="none",
                hatches=["////"],
                zorder=1,
            )
            ax.contour(x, y, mask.astype(float), levels=[0.5], colors="tab:red", linewidths=0.8)
            handles.append(
                Patch(
                    facecolor="none",
                    edgecolor="tab:red",
                    hatch="////",
                    label=f"not covered ({100 * fraction:.0f} % of the area)",
                )
            )
    lo = np.min(np.vstack([p, poly]), axis=0)
    hi = np.max(np.vstack([p, poly]), axis=0)
    span = hi - lo
    # A band above the flown area for the wind arrow, one below for the legend.
    ax.set_xlim(lo[0] - 0.03 * span[0], hi[0] + 0.03 * span[0])
    ax.set_ylim(lo[1] - 0.04 * span[1], hi[1] + 0.16 * span[1])
    _WindArrow(ax, scenario)
    if legend:
        ax.legend(
            handles=handles,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.1),
            fontsize="small",
            ncol=3,
            frameon=False,
        )
    ax.set_title("path")
    return lc


def PlotPower(ax, log: FlightLog, scenario: Scenario | None = None) -> None:
    """Measured, true and estimated power [W], with the period estimate on a twin axis; the
    y-range holds 99 % of the measured and true samples (the estimator's start-up transient may
    leave it)."""
    t = log.times
    handles = [] if scenario is None else MarkEvents(ax, scenario)
    (m,) = ax.plot(t, log["measured_power"][:, 0], color="0.7", lw=0.6, label="measured Υ")
    (tr,) = ax.plot(t, log["true_power"][:, 0], color="k", lw=0.8, label="true y")
    (est,) = ax.plot(
        t, log["estimated_power"][:, 0], color="tab:orange", lw=1.0, label="estimated ŷ"
    )
    lo, hi = RobustRange(np.concatenate([log["measured_power"][:, 0], log["true_power"][:, 0]]))
    ax.set_ylim(lo, hi)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("power [W]")
    twin = ax.twinx()
    (per,) = twin.plot(t, log["period"][:, 0], color="tab:purple", lw=1.0, ls="--")
    per.set_label("period T (right)")
    plo, phi = RobustRange(log["period"][:, 0], quantiles=(0.0, 1.0), pad=0.1)
    twin.set_ylim(plo - 1.5 * (phi - plo), phi + 0.1 * (phi - plo))
    twin.set_ylabel("period T [s]", color="tab:purple")
    _FinishTimePanel(ax, [m, tr, est, per, *handles], 3, (t[0], t[-1]), "energy")


def PlotSoc(ax, log: FlightLog, scenario: Scenario) -> None:
    """State of charge b with the battery faults, the reserve and the end status."""
    handles = MarkEvents(ax, scenario)
    (b,) = ax.plot(log.times, log["soc"][:, 0], color="tab:green", label="SoC b")
    reserve = scenario.battery.reserve_soc
    rl = ax.axhline(reserve, color="tab:red", ls="--", label=f"reserve {reserve:g}")
    s = log.summary
    t_end, b_end = log.times[-1], log["soc"][-1, 0]
    color = "tab:green" if s.get("completed") else "tab:red"
    ax.plot(t_end, b_end, marker="X", color=color, mec="k", ms=9, ls="", zorder=5)
    margin = s.get("final_margin", b_end - reserve)
    ax.annotate(
        f"{_EndText(s)}\nb = {b_end:.3f} (margin {margin:+.3f})",
        xy=(t_end, b_end),
        xytext=(-8, 22),
        textcoords="offset points",
        ha="right",
        fontsize="small",
        color=color,
        bbox={"boxstyle": "round", "fc": "white", "ec": color, "alpha": 0.9},
    )
    ax.set_ylim(0.0, 1.05)
    ax.set_xlim(log.times[0], log.times[-1])
    ax.set_xlabel("t [s]")
    ax.set_ylabel("b [-]")
    ax.legend(handles=[b, rl, *handles], loc="lower left", fontsize="small", framealpha=0.9)
    ax.set_title("battery")


def PlotParameters(ax, log: FlightLog, scenario: Scenario | None = None) -> None:
    """Path parameter c1 [m²] (left axis, limited to its bounds) and computation parameter(s) c2
    (right axis, limited to the table's range). Both axes put their bounds at the same heights,
    so equal normalised values coincide: c2 is drawn wide and light, c1 thin on top."""
    handles = [] if scenario is None else MarkEvents(ax, scenario)
    t = log.times
    c1 = log["path_parameters"][:, 0]
    c2 = np.asarray(log["computation_parameters"], dtype=float).reshape(len(t), -1)
    twin = ax.twinx()
    ax.set_zorder(twin.get_zorder() + 1)  # c1 on top of c2
    ax.patch.set_visible(False)
    c2_lines = []
    for j in range(c2.shape[1]):
        (line,) = twin.step(
            t,
            c2[:, j],
            where="post",
            color=_C2_COLOR,
            lw=4.0,
            alpha=0.45,
            ls=["-", "--", ":"][j % 3],
            label="c2" if c2.shape[1] == 1 else f"c2[{j}]",
        )
        c2_lines.append(line)
    (c1_line,) = ax.step(t, c1, where="post", color=_C1_COLOR, lw=1.4, label="c1")
    if scenario is not None:
        lo, hi = (float(v) for v in scenario.planner.path_parameter_bounds)
        table = LoadComputationTable(scenario.computation.table)
        clo, chi = float(np.min(table.lower)), float(np.max(table.upper))
    else:
        lo, hi = float(np.min(c1)), float(np.max(c1))
        clo, chi = float(np.min(c2)), float(np.max(c2))
    for axis, a, b in ((ax, lo, hi), (twin, clo, chi)):
        span = b - a if b > a else 1.0
        axis.set_ylim(a - 0.06 * span, b + 0.06 * span)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("c1 [m²]", color=_C1_COLOR)
    twin.set_ylabel("c2 [table units, fps]", color=_C2_COLOR)
    _FinishTimePanel(ax, [c1_line, *c2_lines, *handles], 4, (t[0], t[-1]), "parameters")


def PlotFlight(log: FlightLog, scenario: Scenario):
    """The four-panel figure (path, energy, battery, parameters); returns the ``Figure``."""
    fig, axes = plt.subplots(2, 2, figsize=(14, 10), layout="constrained")
    PlotPath(axes[0, 0], log, scenario)
    PlotPower(axes[0, 1], log, scenario)
    PlotSoc(axes[1, 0], log, scenario)
    PlotParameters(axes[1, 1], log, scenario)
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
    colors = plt.get_cmap("tab10")
    for i, name in enumerate(names):
        log = logs[name]
        lc = PlotPath(
            path_axes[i], log, scenario, colour_by="quality", legend=False, colorbar=False
        )
        s = log.summary
        path_axes[i].set_title(
            f"{name}: {s.get('status', '?')}, quality {s.get('quality', float('nan')):.3f}",
            color=colors(i),
        )
        t = log.times
        ax_soc.plot(t, log["soc"][:, 0], color=colors(i), label=name)
        ax_soc.plot(t[-1], log["soc"][-1, 0], "X", color=colors(i), mec="k")
        c1n, c2n = NormalisedParameters(log)
        # Each flight a little lower than the previous so equal steps stay visible.
        offset = -0.012 * i
        ax_c1.step(t, c1n + offset, where="post", color=colors(i), lw=1.3, label=name)
        ax_c2.step(t, c2n + offset, where="post", color=colors(i), lw=1.3, label=name)
    top.colorbar(lc, ax=path_axes, label="quality ½c̃1 + ½c̃2", shrink=0.8)
    ax_soc.axhline(scenario.battery.reserve_soc, color="tab:red", ls="--", label="reserve")
    for ax, ylabel, title in (
        (ax_soc, "b [-]", "battery"),
        (ax_c1, "c̃1 [-]", "path parameter (normalised)"),
        (ax_c2, "c̃2 [-]", "computation parameter (normalised)"),
    ):
        handles = MarkEvents(ax, scenario)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.set_ylim(-0.08, 1.08)
        ax.legend(
            handles=[*ax.get_legend_handles_labels()[0], *handles],
            loc="upper center",
            bbox_to_anchor=(0.5, -0.14),
            fontsize="small",
            ncol=2,
            frameon=False,
        )
    fig.suptitle(
        f"policies on one world: {scenario.name} (dot: start, X: end, hatched: not covered)"
    )
    return fig


def _FinishTimePanel(ax, handles, ncol: int, time_range, title: str) -> None:
    """A time panel's legend below its axes, its time range [s] and its title."""
    ax.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.1),
        fontsize="small",
        ncol=ncol,
        frameon=False,
    )
    ax.set_xlim(*time_range)
    ax.set_title(title)


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
