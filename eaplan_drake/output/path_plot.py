"""The path panel: the survey area, a plan's stages, and the flown path coloured by the quality
with its time marks, direction, faults, changes of c1, end, uncovered area and wind (the
conventions are :mod:`~eaplan_drake.output.plot_style`'s)."""

import math

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.legend_handler import HandlerBase
from matplotlib.lines import Line2D
from matplotlib.markers import MarkerStyle
from matplotlib.patches import Patch
from matplotlib.transforms import Affine2D, ScaledTranslation

from eaplan_drake.flight.stages import APPROACH, StagePoints
from eaplan_drake.flightlog import (
    FlightLog,
    NormaliseParameters,
    SampleQuality,
)
from eaplan_drake.output.plot_math import (
    ParameterSteps,
    TimeMarkStep,
    UncoveredArea,
    UncoveredRadius,
)
from eaplan_drake.output.plot_style import (
    _C1_NOTE,
    _QUALITY_LABEL,
    COLORS,
    QUALITY_COLORMAP,
    _EndText,
    _Faults,
    _PathBounds,
)
from eaplan_drake.params import Scenario, WindVector

__all__ = ["DrawPlan", "DrawSurveyArea", "PlotPath", "SurveyShapes"]


def SurveyShapes(scenario: Scenario) -> dict:
    """What a flight's figure draws under the path [m]: ``outline`` (the survey polygon, or a
    ``coverage.field``'s outer boundary), its ``holes``, and for a field the ``airspace`` its
    missions declare (:func:`~eaplan_drake.field.airspace.MakeAirspace`, home at the first
    line's start; None when the ``[field]`` extra is missing or for the polygon survey)."""
    shapes = {"outline": np.asarray(scenario.coverage.polygon, dtype=float), "holes": []}
    shapes["airspace"] = None
    if not scenario.coverage.field:
        return shapes
    from eaplan_drake.field.airspace import MakeAirspace
    from eaplan_drake.field.source import MakeFieldPlanSource

    source = MakeFieldPlanSource(scenario, float(scenario.planner.path_parameter_bounds[0]))
    field, route = source.field, source.plan.route
    airspace = MakeAirspace(route, field, scenario, home=route.legs[0].start)
    shapes["outline"] = np.asarray(field.exterior, dtype=float)
    shapes["holes"] = [np.asarray(h, dtype=float) for h in field.holes]
    shapes["airspace"] = np.asarray(airspace.polygon.exterior.coords, dtype=float)
    return shapes


def DrawSurveyArea(ax, polygon, start=None, holes=(), airspace=None) -> None:
    """The survey polygon [m] (grey) with its ``holes`` (white, hatched), the ``airspace`` ring
    [m] (dashed) if given, and the start position (black dot), equal axes."""
    poly = np.asarray(polygon, dtype=float)
    ax.fill(poly[:, 0], poly[:, 1], color="0.92", zorder=0, label="survey area")
    for h in holes:
        h = np.asarray(h, dtype=float)
        ax.fill(h[:, 0], h[:, 1], facecolor="white", edgecolor="0.6", hatch="//", zorder=0)
    if airspace is not None:
        a = np.asarray(airspace, dtype=float)
        ax.plot(a[:, 0], a[:, 1], color="tab:red", lw=0.9, ls="--", zorder=1)
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


class _ColourmapHandle(Line2D):
    """A legend entry drawn as a line through the quality's colour map
    (:data:`~eaplan_drake.output.plot_style.QUALITY_COLORMAP`)."""


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


class _Track:
    """The flown positions ``p`` [m] at the times ``t`` [s] of a log, as the path's marks use
    them: the sample at a time, the direction of flight at a sample, a label beside it."""

    def __init__(self, t, p):
        self.t, self.p = t, p

    def Index(self, at: float) -> int:
        """The sample at time ``at`` [s] (never the first or the last)."""
        return int(np.clip(np.searchsorted(self.t, at), 1, len(self.t) - 2))

    def Direction(self, i: int) -> np.ndarray:
        """The unit direction of flight at sample ``i`` (over ±2 samples)."""
        p = self.p
        d = p[min(i + 2, len(p) - 1)] - p[max(i - 2, 0)]
        n = float(np.hypot(*d))
        return d / n if n > 0 else np.array([1.0, 0.0])

    def Label(self, ax, i: int, text: str, side: float, color, **kw) -> None:
        """``text`` 8 points beside sample ``i``: on the left of the direction of flight for
        ``side`` = +1, on the right for −1."""
        d = self.Direction(i)
        n = side * np.array([-d[1], d[0]])  # +1: left of the direction of flight
        ax.annotate(
            text,
            xy=self.p[i],
            xytext=8.0 * n,
            textcoords="offset points",
            ha="left" if n[0] > 0.35 else "right" if n[0] < -0.35 else "center",
            va="bottom" if n[1] > 0.35 else "top" if n[1] < -0.35 else "center",
            fontsize=7,
            color=color,
            zorder=7,
            **kw,
        )


_LABEL_BOX = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}


def _TimeMarks(ax, track: _Track, step: float, labels: bool) -> list:
    """A dot (and with ``labels`` its time) every ``step`` seconds; returns its legend handle."""
    t0, t1 = float(track.t[0]), float(track.t[-1])
    marks = np.arange(t0 + step, t1 - 0.2 * step, step)
    if not marks.size:
        return []
    idx = [track.Index(m) for m in marks]
    ax.plot(*track.p[idx].T, "o", color=COLORS["progress"], ms=3.5, ls="", zorder=6)
    if labels:
        for i, m in zip(idx, marks, strict=True):
            track.Label(ax, i, f"{m - t0:g} s", 1.0, COLORS["progress"], bbox=dict(_LABEL_BOX))
    return [
        Line2D(
            [], [], marker="o", color=COLORS["progress"], ms=3.5, ls="", label=f"every {step:g} s"
        )
    ]


def _DirectionMarks(ax, track: _Track, step: float) -> list:
    """Arrowheads in the direction of flight, three per ``step`` seconds; returns their legend
    handle."""
    t0, t1 = float(track.t[0]), float(track.t[-1])
    for a in np.arange(t0 + step / 6.0, t1 - 0.1 * step, step / 3.0):
        i = track.Index(a)
        d = track.Direction(i)
        ax.plot(
            *track.p[i],
            marker=_Arrowhead(math.degrees(math.atan2(d[1], d[0]))),
            color=COLORS["progress"],
            ms=7,
            ls="",
            zorder=6,
        )
    return [Line2D([], [], marker=">", color=COLORS["progress"], ms=7, ls="", label="direction")]


def _FaultMarks(ax, track: _Track, scenario: Scenario, labels: bool) -> list:
    """A star where each battery fault of the flight came (with ``labels`` its time); returns
    their legend handle."""
    t0, t1 = float(track.t[0]), float(track.t[-1])
    faults = [f for f in scenario.battery.faults if t0 <= f.time <= t1]
    for f in faults:
        i = track.Index(f.time)
        ax.plot(*track.p[i], "*", color=COLORS["fault"], mec="k", mew=0.5, ms=12, ls="", zorder=7)
        if labels:
            track.Label(ax, i, f"fault {f.time:g} s", -1.0, COLORS["fault"], bbox=dict(_LABEL_BOX))
    if not faults:
        return []
    return [
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
    ]


def _C1Changes(ax, track: _Track, log: FlightLog, scenario: Scenario) -> list:
    """A diamond where c1 stepped by at least 5 % of its range; returns their legend handle."""
    lo, hi = _PathBounds(log, scenario)
    changes = ParameterSteps(track.t, log["path_parameters"][:, 0], 0.05 * (hi - lo))
    if not changes.size:
        return []
    ax.plot(*track.p[changes].T, "D", mfc="white", mec=COLORS["c1"], mew=1.5, ms=6, ls="", zorder=6)
    return [
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
    ]


def _PathMarks(ax, log: FlightLog, scenario: Scenario, labels: bool = True) -> list:
    """Time marks (dot and "60 s") every :func:`~eaplan_drake.output.plot_math.TimeMarkStep`
    seconds, direction arrowheads between them, a star where each battery fault came and a
    diamond where c1 changed; returns legend handles. Labels sit beside the path, on the left of
    the direction of flight."""
    t, p = log.times, np.asarray(log["position"], dtype=float)
    if len(t) < 3:
        return []
    track = _Track(t, p)
    step = TimeMarkStep(float(t[-1]) - float(t[0]))
    return [
        *_TimeMarks(ax, track, step, labels),
        *_DirectionMarks(ax, track, step),
        *_FaultMarks(ax, track, scenario, labels),
        *_C1Changes(ax, track, log, scenario),
    ]


def _PathColour(log: FlightLog, scenario: Scenario, colour_by: str) -> tuple[np.ndarray, str]:
    """The value in [0, 1] each sample of the path is coloured by, and its label: the quality
    ½c̃1 + ½c̃2 (``colour_by="quality"``) or c̃1 (``"path"``)."""
    if colour_by == "quality":
        return SampleQuality(log), _QUALITY_LABEL
    if colour_by == "path":
        value = NormaliseParameters(log["path_parameters"][:, 0], *_PathBounds(log, scenario))
        return value, f"c̃1 [-] ({_C1_NOTE}, normalised)"
    raise ValueError(f"colour_by: 'quality' or 'path', got {colour_by!r}")


def _Uncovered(ax, scenario: Scenario, poly, p) -> list:
    """The part of the survey area ``poly`` [m] the path ``p`` [m] left uncovered, hatched
    (:func:`~eaplan_drake.output.plot_math.UncoveredArea`); returns its legend handle."""
    x, y, mask, fraction = UncoveredArea(poly, p, UncoveredRadius(scenario))
    if not mask.any():
        return []
    ax.contourf(
        x,
        y,
        mask.astype(float),
        levels=[0.5, 1.5],
        colors="none",
        hatches=["////"],
        zorder=1,
    )
    ax.contour(x, y, mask.astype(float), levels=[0.5], colors=COLORS["uncovered"], linewidths=0.8)
    return [
        Patch(
            facecolor="none",
            edgecolor=COLORS["uncovered"],
            hatch="////",
            label=f"not covered ({100 * fraction:.0f} % of the area)",
        )
    ]


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
    :data:`~eaplan_drake.output.plot_style.QUALITY_COLORMAP`; with ``time_marks`` a dot and its
    time every :func:`~eaplan_drake.output.plot_math.TimeMarkStep` seconds, arrowheads in the
    direction of flight, a red star where each battery fault came and a blue diamond where c1
    changed. The end point with its status, the
    part of the area left uncovered (hatched) when the survey did not complete, and the wind
    arrow in a band above the flown area. Returns the path's ``LineCollection`` (for a shared
    colour bar)."""
    p = np.asarray(log["position"], dtype=float)
    shapes = SurveyShapes(scenario)
    poly = shapes["outline"]
    DrawSurveyArea(ax, poly, p[0], shapes["holes"], shapes["airspace"])
    value, label = _PathColour(log, scenario, colour_by)
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
    if shapes["holes"]:
        handles.append(Patch(facecolor="white", edgecolor="0.6", hatch="//", label="hole"))
    if shapes["airspace"] is not None:
        handles.append(Line2D([], [], color="tab:red", lw=0.9, ls="--", label="airspace"))
    s = log.summary
    end = {"marker": "X", "color": COLORS["progress"], "mec": "white", "mew": 0.8, "ls": ""}
    ax.plot(*p[-1], ms=10, zorder=8, **end)
    handles.append(Line2D([], [], ms=9, label="end: " + _EndText(s), **end))
    if time_marks:
        handles += _PathMarks(ax, log, scenario)
    if s and not s.get("completed", True):
        handles += _Uncovered(ax, scenario, poly, p)
    frame = np.vstack([p, poly] + ([] if shapes["airspace"] is None else [shapes["airspace"]]))
    lo, hi = np.min(frame, axis=0), np.max(frame, axis=0)
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
