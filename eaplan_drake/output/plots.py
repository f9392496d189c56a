"""Matplotlib figures of a flight, in the spirit of paper 003 Fig. 6, and of several policies.

The math behind the pictures is in plain functions over numpy (:func:`UncoveredArea`,
:func:`RobustRange`, :func:`StagePoints`, :func:`TimeMarkStep`, :func:`Runs`,
:func:`ParameterSteps`), each tested on its own. Each ``Plot*`` function draws into a given
``Axes`` (so notebooks can compose them): :func:`PlotFlight` makes the five-panel figure of one
flight (path, energy, parameters, battery, planner) and :func:`SaveFlightPlots` writes it as PNG;
:func:`PlotPolicyComparison` draws several flights of one world side by side.

The conventions of every figure here and of the Meshcat replay
(:mod:`~eaplan_drake.output.replay`):

- the parameters are drawn normalised, c̃ = (c − c̲)/(c̄ − c̲) ∈ [0, 1], 0 the lowest quality and
  1 the highest, by the bounds the log's summary carries. The path parameter is
  c1 = r2² − r² [m²] ≤ 0 (r the turning radius of the plan, r2 = sqrt(r² + c1) ≤ r the inner
  one; c1 = 0 flies the densest lines), the computation parameters c2 are in the computation
  table's units (fps for the PedNet detector);
- the flown path is coloured by the quality ½c̃1 + ½c̃2 on :data:`QUALITY_COLORMAP`, the integrand
  of the summary's quality;
- one colour, one meaning (:data:`COLORS`); on every time panel the planner's warm-up is shaded
  grey and each battery fault is a red dotted line; text goes in legends outside the data.
"""

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.legend_handler import HandlerBase
from matplotlib.lines import Line2D
from matplotlib.markers import MarkerStyle
from matplotlib.patches import Patch
from matplotlib.path import Path as MplPath
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import Affine2D, ScaledTranslation

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
    "COLORS",
    "DrawPlan",
    "DrawSurveyArea",
    "InfeasibleCause",
    "MarkEvents",
    "ParameterSteps",
    "PlotFlight",
    "PlotParameters",
    "PlotPath",
    "PlotPlanner",
    "PlotPolicyComparison",
    "PlotPower",
    "PlotSoc",
    "QUALITY_COLORMAP",
    "RobustRange",
    "Runs",
    "SaveFigure",
    "SaveFlightPlots",
    "SavePolicyComparison",
    "StagePoints",
    "TimeMarkStep",
    "UncoveredArea",
    "UncoveredRadius",
]

QUALITY_COLORMAP = "viridis"
"""The colour map of the quality ½c̃1 + ½c̃2 ∈ [0, 1] (purple 0, yellow 1), in the figures and in
the replay."""

COLORS = {
    "c1": "tab:blue",  # c1 / c̃1, and the markers where c1 changed
    "c2": "tab:orange",  # c2 / c̃2
    "soc": "tab:green",  # SoC b
    "reserve": "tab:cyan",  # the reserve SoC
    "fault": "tab:red",  # battery faults
    "warmup": "0.88",  # the planner's warm-up
    "measured": "0.7",  # measured power Υ
    "true": "k",  # true power y
    "estimated": "tab:brown",  # estimated power ŷ
    "period": "tab:purple",  # period T
    "budget": "tab:olive",  # the paper's output bound b·Q_c·V
    "infeasible": "tab:pink",  # planner steps whose constraint could not be met
    "progress": "k",  # start, end, time marks and direction on the path
    "wind": "0.3",  # the wind arrow
    "uncovered": "0.3",  # the part of the area not covered
}
"""One colour, one meaning, in every figure here (and the replay's bars)."""

_QUALITY_LABEL = "quality ½c̃1 + ½c̃2 [-]"
_C1_NOTE = "c1 = r2² − r² ≤ 0"
_POWER_BUDGET_POLICIES = ("paper", "greedy_authors")
_INFEASIBLE_CAUSES = {
    # policy: (why a step is infeasible, what the policy flew then, what mission_feasible = 1 says)
    "paper": (
        "the paper's output constraint y ≤ b·Q_c·V cannot hold",
        "flew the lowest c2 there",
        "y ≤ b·Q_c·V holds at some c2",
    ),
    "greedy_authors": (
        "the paper's output constraint y ≤ b·Q_c·V cannot hold",
        "flew the lowest c2 there",
        "y ≤ b·Q_c·V holds at some c2",
    ),
    "mpc": (
        "even the lowest plan ends below reserve + margin",
        "flew the lowest plan there",
        "the lowest plan ends at or above reserve + margin",
    ),
    "greedy": (
        "no c1 of the grid ends at or above the reserve",
        "moved c1 towards the lowest there",
        "some c1 of the grid ends at or above the reserve",
    ),
    "static": ("never: the static policy does not plan", "", "always, never re-planned"),
}


def InfeasibleCause(policy: str) -> tuple[str, str]:
    """(why, what was flown) for the planner steps of ``policy`` with ``mission_feasible`` = 0,
    e.g. for ``paper``: ("the paper's output constraint y ≤ b·Q_c·V cannot hold", "flew the
    lowest c2 there")."""
    return _Cause(policy)[:2]


def _Cause(policy: str) -> tuple[str, str, str]:
    return _INFEASIBLE_CAUSES.get(
        policy,
        (
            "the policy's constraint cannot be met",
            "flew the policy's fallback there",
            "the policy's constraint can be met",
        ),
    )


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


def TimeMarkStep(duration: float, max_marks: int = 10) -> float:
    """The spacing [s] of time marks over ``duration`` [s]: the smallest of 5, 10, 20, 30, 60,
    120, 300, 600, 1200, 1800, 3600 s (then whole hours) that puts at most ``max_marks`` marks."""
    duration = max(float(duration), 0.0)
    for step in (5, 10, 20, 30, 60, 120, 300, 600, 1200, 1800, 3600):
        if duration / step <= max_marks:
            return float(step)
    return 3600.0 * math.ceil(duration / (max_marks * 3600.0))


def Runs(mask) -> list[tuple[int, int]]:
    """The runs of True in the boolean ``mask``: (first, last + 1) index pairs, in order."""
    m = np.asarray(mask, dtype=bool).ravel()
    edges = np.diff(np.r_[0, m.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()
    return list(zip(starts, stops, strict=True))


def ParameterSteps(times, values, threshold: float, merge: float = 5.0) -> np.ndarray:
    """Indices of the samples where ``values`` steps by at least ``threshold`` from the previous
    sample (a planner's change of c1, not its small rate-limited drift); a step within ``merge``
    [s] after a kept one is left out."""
    t = np.asarray(times, dtype=float)
    v = np.asarray(values, dtype=float).ravel()
    if v.size < 2:
        return np.zeros(0, dtype=int)
    steps = np.flatnonzero(np.abs(np.diff(v)) >= threshold) + 1
    kept: list[int] = []
    for i in steps:
        if not kept or t[i] - t[kept[-1]] > merge:
            kept.append(int(i))
    return np.array(kept, dtype=int)


# --- drawing helpers --------------------------------------------------------------------------


def DrawSurveyArea(ax, polygon, start=None) -> None:
    """The survey polygon [m] (grey) and the start position (black dot), equal axes."""
    poly = np.asarray(polygon, dtype=float)
    ax.fill(poly[:, 0], poly[:, 1], color="0.92", zorder=0, label="survey area")
    if start is not None:
        ax.plot(*np.asarray(start, dtype=float), "o", color=COLORS["progress"], ms=5, label="start")
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
    vertical line on a time axis (both below the data of ``ax``); returns legend handles."""
    handles = []
    warmup = float(scenario.planner.warmup)
    if warmup > 0.0 and scenario.planner.policy not in ("static", "hindsight"):
        ax.axvspan(0.0, warmup, color=COLORS["warmup"], zorder=0, lw=0)
        handles.append(Patch(color=COLORS["warmup"], label=f"warm-up ({warmup:g} s)"))
    for fault in scenario.battery.faults:
        ax.axvline(fault.time, color=COLORS["fault"], ls=":", lw=1.2, zorder=1)
    if scenario.battery.faults:
        handles.append(
            Line2D([], [], color=COLORS["fault"], ls=":", label=f"fault ({_Faults(scenario)})")
        )
    return handles if legend else []


def _Faults(scenario: Scenario) -> str:
    return ", ".join(f"−{100 * f.soc_drop:g} % at {f.time:g} s" for f in scenario.battery.faults)


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


def _TimeRange(log: FlightLog) -> tuple[float, float]:
    """The time axis [s] of every time panel: the flight, and 2.5 % more on the right so the end
    marker is drawn whole."""
    t0, t1 = float(log.times[0]), float(log.times[-1])
    return t0, t1 + 0.025 * max(t1 - t0, 1.0)


def _Policy(log: FlightLog, scenario: Scenario | None) -> str:
    default = scenario.planner.policy if scenario is not None else "?"
    return str(log.summary.get("policy", default))


class _ColourmapHandle(Line2D):
    """A legend entry drawn as a line through :data:`QUALITY_COLORMAP` (:class:`_ColourmapLine`)."""


class _ColourmapLine(HandlerBase):
    def create_artists(
        self, legend, orig_handle, xdescent, ydescent, width, height, fontsize, trans
    ):
        x = np.linspace(-xdescent, width - xdescent, 9)
        y = np.full_like(x, 0.5 * height - ydescent)
        points = np.column_stack([x, y])
        lc = LineCollection(
            np.stack([points[:-1], points[1:]], axis=1),
            cmap=QUALITY_COLORMAP,
            norm=Normalize(0.0, 1.0),
            linewidth=2.5,
            transform=trans,
        )
        lc.set_array(np.linspace(0.0, 1.0, 8))
        return [lc]


def _Arrowhead(angle_deg: float) -> MarkerStyle:
    """A triangle marker pointing at ``angle_deg`` (counter-clockwise from +x; on the path's
    equal-aspect axes the direction of the data)."""
    return MarkerStyle(">", transform=Affine2D().rotate_deg(angle_deg))


def _WindArrow(ax, scenario: Scenario) -> None:
    """The wind as an arrow with its speed in the band above the flown area (axes coordinates,
    the direction true on the equal-aspect axes)."""
    speed = float(scenario.wind.speed)
    if speed <= 0.0:
        ax.text(0.02, 0.97, "no wind", transform=ax.transAxes, va="top", fontsize="small")
        return
    w = WindVector(1.0, scenario.wind.direction_deg)
    half = 13.0 / 72.0  # half the arrow's length [inch]
    anchor = (0.07, 0.935)

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
        arrowprops={"arrowstyle": "-|>", "color": COLORS["wind"], "lw": 1.8},
    )
    ax.text(
        anchor[0] + 0.05,
        anchor[1],
        f"wind {speed:g} m/s towards {scenario.wind.direction_deg:g}°",
        transform=ax.transAxes,
        color=COLORS["wind"],
        va="center",
        fontsize="small",
    )


def _PathMarks(ax, log: FlightLog, scenario: Scenario, labels: bool = True) -> list:
    """Time marks (dot and "60 s") every :func:`TimeMarkStep` seconds, direction arrowheads
    between them, a star where each battery fault came and a diamond where c1 changed; returns
    legend handles. Labels sit beside the path, on the left of the direction of flight."""
    t, p = log.times, np.asarray(log["position"], dtype=float)
    if len(t) < 3:
        return []
    t0, t1 = float(t[0]), float(t[-1])
    step = TimeMarkStep(t1 - t0)

    def index(at):
        return int(np.clip(np.searchsorted(t, at), 1, len(t) - 2))

    def direction(i):
        d = p[min(i + 2, len(p) - 1)] - p[max(i - 2, 0)]
        n = float(np.hypot(*d))
        return d / n if n > 0 else np.array([1.0, 0.0])

    def label(i, text, side, color, **kw):
        d = direction(i)
        n = side * np.array([-d[1], d[0]])  # +1: left of the direction of flight
        ax.annotate(
            text,
            xy=p[i],
            xytext=8.0 * n,
            textcoords="offset points",
            ha="left" if n[0] > 0.35 else "right" if n[0] < -0.35 else "center",
            va="bottom" if n[1] > 0.35 else "top" if n[1] < -0.35 else "center",
            fontsize=7,
            color=color,
            zorder=7,
            **kw,
        )

    handles = []
    marks = np.arange(t0 + step, t1 - 0.2 * step, step)
    if marks.size:
        idx = [index(m) for m in marks]
        ax.plot(*p[idx].T, "o", color=COLORS["progress"], ms=3.5, ls="", zorder=6)
        if labels:
            for i, m in zip(idx, marks, strict=True):
                box = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}
                label(i, f"{m - t0:g} s", 1.0, COLORS["progress"], bbox=box)
        handles.append(
            Line2D(
                [],
                [],
                marker="o",
                color=COLORS["progress"],
                ms=3.5,
                ls="",
                label=f"every {step:g} s",
            )
        )
    for a in np.arange(t0 + step / 6.0, t1 - 0.1 * step, step / 3.0):
        i = index(a)
        d = direction(i)
        ax.plot(
            *p[i],
            marker=_Arrowhead(math.degrees(math.atan2(d[1], d[0]))),
            color=COLORS["progress"],
            ms=7,
            ls="",
            zorder=6,
        )
    handles.append(
        Line2D([], [], marker=">", color=COLORS["progress"], ms=7, ls="", label="direction")
    )
    faults = [f for f in scenario.battery.faults if t0 <= f.time <= t1]
    for f in faults:
        i = index(f.time)
        ax.plot(*p[i], "*", color=COLORS["fault"], mec="k", mew=0.5, ms=12, ls="", zorder=7)
        if labels:
            box = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}
            label(i, f"fault {f.time:g} s", -1.0, COLORS["fault"], bbox=box)
    if faults:
        handles.append(
            Line2D(
                [],
                [],
                marker="*",
                color=COLORS["fault"],
                mec="k",
                mew=0.5,
                ms=11,
                ls="",
                label=f"fault ({_Faults(scenario)})",
            )
        )
    lo, hi = _PathBounds(log, scenario)
    changes = ParameterSteps(t, log["path_parameters"][:, 0], 0.05 * (hi - lo))
    if changes.size:
        ax.plot(*p[changes].T, "D", mfc="white", mec=COLORS["c1"], mew=1.5, ms=6, ls="", zorder=6)
        handles.append(
            Line2D(
                [],
                [],
                marker="D",
                mfc="white",
                mec=COLORS["c1"],
                mew=1.5,
                ms=6,
                ls="",
                label="c1 changed (a step ≥ 5 % of its range)",
            )
        )
    return handles


def _PathBounds(log: FlightLog, scenario: Scenario | None) -> tuple[float, float]:
    bounds = log.summary.get("path_parameter_bounds")
    if bounds is None and scenario is not None:
        bounds = scenario.planner.path_parameter_bounds
    if bounds is None:
        c1 = log["path_parameters"][:, 0]
        bounds = (float(np.min(c1)), float(np.max(c1)))
    return float(bounds[0]), float(bounds[1])


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


def PlotPath(
    ax,
    log: FlightLog,
    scenario: Scenario,
    colour_by: str = "quality",
    legend: bool = True,
    colorbar: bool = True,
    time_marks: bool = True,
):
    """Flown path over the survey polygon, coloured by the quality ½c̃1 + ½c̃2
    (``colour_by="quality"``, as in the replay) or by c̃1 alone (``"path"``), on
    :data:`QUALITY_COLORMAP`; with ``time_marks`` a dot and its time every
    :func:`TimeMarkStep` seconds, arrowheads in the direction of flight, a red star where each
    battery fault came and a blue diamond where c1 changed. The end point with its status, the
    part of the area left uncovered (hatched) when the survey did not complete, and the wind
    arrow in a band above the flown area. Returns the path's ``LineCollection`` (for a shared
    colour bar)."""
    p = np.asarray(log["position"], dtype=float)
    poly = np.asarray(scenario.coverage.polygon, dtype=float)
    DrawSurveyArea(ax, poly, p[0])
    if colour_by == "quality":
        value, label = SampleQuality(log), _QUALITY_LABEL
    elif colour_by == "path":
        value = NormaliseParameters(log["path_parameters"][:, 0], *_PathBounds(log, scenario))
        label = f"c̃1 [-] ({_C1_NOTE}, normalised)"
    else:
        raise ValueError(f"colour_by: 'quality' or 'path', got {colour_by!r}")
    segments = np.stack([p[:-1], p[1:]], axis=1)
    lc = LineCollection(
        segments, cmap=QUALITY_COLORMAP, norm=Normalize(0.0, 1.0), linewidth=1.4, zorder=2
    )
    lc.set_array(value[:-1])
    ax.add_collection(lc)
    legend_ax = ax
    if colorbar:  # below the path, the legend below it: the path keeps the column's width
        bar = ax.figure.colorbar(lc, ax=ax, label=label, location="bottom", shrink=0.6, aspect=40)
        bar.ax.xaxis.set_label_position("top")
        legend_ax = bar.ax
    handles = [
        Patch(color="0.92", label="survey area"),
        _ColourmapHandle([], [], label=f"flown path, colour: {label}"),
        Line2D([], [], marker="o", color=COLORS["progress"], ls="", ms=5, label="start"),
    ]
    s = log.summary
    end = {"marker": "X", "color": COLORS["progress"], "mec": "white", "mew": 0.8, "ls": ""}
    ax.plot(*p[-1], ms=10, zorder=8, **end)
    handles.append(Line2D([], [], ms=9, label="end: " + _EndText(s), **end))
    if time_marks:
        handles += _PathMarks(ax, log, scenario)
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
            ax.contour(
                x, y, mask.astype(float), levels=[0.5], colors=COLORS["uncovered"], linewidths=0.8
            )
            handles.append(
                Patch(
                    facecolor="none",
                    edgecolor=COLORS["uncovered"],
                    hatch="////",
                    label=f"not covered ({100 * fraction:.0f} % of the area)",
                )
            )
    lo = np.min(np.vstack([p, poly]), axis=0)
    hi = np.max(np.vstack([p, poly]), axis=0)
    span = np.maximum(hi - lo, 1.0)
    # A band above the flown area for the wind arrow; the legend goes below the axes.
    ax.set_xlim(lo[0] - 0.05 * span[0], hi[0] + 0.05 * span[0])
    ax.set_ylim(lo[1] - 0.06 * span[1], hi[1] + 0.17 * span[1])
    _WindArrow(ax, scenario)
    if legend:
        legend_ax.legend(
            handles=handles,
            handler_map={_ColourmapHandle: _ColourmapLine()},
            loc="upper center",
            bbox_to_anchor=(0.5, -0.07 if legend_ax is ax else -2.6),
            fontsize="small",
            ncol=2,
            frameon=False,
        )
    ax.set_title("path")
    return lc


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
    (:func:`InfeasibleCause`); for the policies of the paper's output constraint y ≤ b·Q_c·V
    (paper, greedy_authors) the bound ``power_budget`` b·Q_c·V and the estimated power ŷ the
    planner predicts from, otherwise ``mission_feasible`` itself (1: the constraint holds)."""
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
    if policy in _POWER_BUDGET_POLICIES and "power_budget" in log.signals:
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
        if policy in ("static", "hindsight"):
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
