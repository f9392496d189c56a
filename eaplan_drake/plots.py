"""Matplotlib figures of a flight, in the spirit of paper 003 Fig. 6.

Each ``Plot*`` function draws into a given ``Axes`` (so notebooks can compose them);
:func:`PlotFlight` makes the four-panel figure and :func:`SaveFlightPlots` writes it as PNG.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection

from eaplan_drake.diagram import WindVector
from eaplan_drake.params import Scenario
from eaplan_drake.simulation import AtomicWrite, FlightLog, NormaliseParameters

__all__ = [
    "PlotFlight",
    "PlotParameters",
    "PlotPath",
    "PlotPower",
    "PlotSoc",
    "SaveFlightPlots",
]


def PlotPath(ax, log: FlightLog, scenario: Scenario) -> None:
    """Flown path over the survey polygon, coloured by the normalised path parameter c̃1, with
    the wind arrow."""
    p = log["position"]
    poly = np.asarray(scenario.coverage.polygon, dtype=float)
    ax.fill(poly[:, 0], poly[:, 1], color="0.92", zorder=0, label="survey area")
    segments = np.stack([p[:-1], p[1:]], axis=1)
    lc = LineCollection(segments, cmap="viridis", norm=plt.Normalize(0.0, 1.0), linewidth=1.2)
    lo, hi = scenario.planner.path_parameter_bounds
    lc.set_array(NormaliseParameters(log["path_parameters"][:-1, 0], lo, hi))
    ax.add_collection(lc)
    ax.figure.colorbar(lc, ax=ax, label="c̃1 (normalised path parameter)")
    ax.plot(*p[0], "ko", ms=4, label="start")
    w = WindVector(scenario.wind.speed, scenario.wind.direction_deg)
    lo = np.min(np.vstack([p, poly]), axis=0)
    hi = np.max(np.vstack([p, poly]), axis=0)
    base = lo + 0.08 * (hi - lo)
    scale = 0.12 * np.max(hi - lo) / max(np.linalg.norm(w), 1e-9)
    ax.annotate(
        "", xy=base + scale * w, xytext=base, arrowprops={"arrowstyle": "->", "color": "tab:red"}
    )
    ax.text(
        *(base - np.array([0.0, 0.03 * (hi - lo)[1]])),
        f"wind {scenario.wind.speed:g} m/s",
        color="tab:red",
        va="top",
        fontsize="small",
    )
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("path")


def PlotPower(ax, log: FlightLog) -> None:
    """Measured, true and estimated power [W], with the period estimate on a twin axis."""
    t = log.times
    ax.plot(t, log["measured_power"][:, 0], color="0.7", lw=0.6, label="measured Υ")
    ax.plot(t, log["true_power"][:, 0], color="k", lw=0.8, label="true")
    ax.plot(t, log["estimated_power"][:, 0], color="tab:orange", lw=1.0, label="estimated ŷ")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("power [W]")
    ax.legend(loc="upper right", fontsize="small")
    twin = ax.twinx()
    twin.plot(t, log["period"][:, 0], color="tab:purple", lw=1.0, ls="--")
    twin.set_ylabel("period T [s]", color="tab:purple")
    ax.set_title("energy")


def PlotSoc(ax, log: FlightLog, scenario: Scenario) -> None:
    """State of charge b with the battery faults and the reserve."""
    ax.plot(log.times, log["soc"][:, 0], color="tab:green", label="SoC b")
    ax.axhline(scenario.battery.reserve_soc, color="tab:red", ls="--", label="reserve")
    for i, fault in enumerate(scenario.battery.faults):
        ax.axvline(fault.time, color="0.5", ls=":", label="fault" if i == 0 else None)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("b [-]")
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title("battery")


def PlotParameters(ax, log: FlightLog) -> None:
    """Path parameter c1 [m²] and computation parameter(s) c2 over time."""
    ax.step(log.times, log["path_parameters"][:, 0], where="post", color="tab:blue", label="c1")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("c1 [m²]", color="tab:blue")
    twin = ax.twinx()
    c2 = log["computation_parameters"]
    for j in range(c2.shape[1]):
        twin.step(log.times, c2[:, j], where="post", color="tab:orange", lw=1.0)
    twin.set_ylabel("c2 [fps]", color="tab:orange")
    ax.set_title("parameters")


def PlotFlight(log: FlightLog, scenario: Scenario):
    """The four-panel figure (path, power, SoC, parameters); returns the ``Figure``."""
    fig, axes = plt.subplots(2, 2, figsize=(13, 9), layout="constrained")
    PlotPath(axes[0, 0], log, scenario)
    PlotPower(axes[0, 1], log)
    PlotSoc(axes[1, 0], log, scenario)
    PlotParameters(axes[1, 1], log)
    s = log.summary
    metric = s.get("metric")
    fig.suptitle(
        f"{scenario.name}: {s.get('status', '?')} after {s.get('duration', float('nan')):.1f} s, "
        f"final SoC {s.get('final_soc', float('nan')):.3f}, "
        f"P = {'fail' if metric is None else f'{metric:.3f}'}"
    )
    return fig


def SaveFlightPlots(log: FlightLog, scenario: Scenario, directory: str | Path) -> Path:
    """Saves :func:`PlotFlight` as ``<directory>/flight.png`` (atomically: temporary file, fsync,
    rename); returns the path."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    fig = PlotFlight(log, scenario)
    path = directory / "flight.png"
    try:
        AtomicWrite(path, lambda f: fig.savefig(f, format="png", dpi=110), binary=True)
    finally:
        plt.close(fig)
    return path
