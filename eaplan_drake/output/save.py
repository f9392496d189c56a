"""Saving a flight's result directory as a unit: the log, its summary, the figure, the replay."""

from pathlib import Path

from eaplan_drake.files import ResultDirectory
from eaplan_drake.flightlog import FlightLog
from eaplan_drake.output.plots import SaveFlightPlots
from eaplan_drake.params import CheckType, Scenario

__all__ = ["SaveFlight"]


def SaveFlight(
    log: "FlightLog", scenario: Scenario, directory: str | Path, *, replay: bool = False
) -> list[Path]:
    """Writes a flight's result directory as a unit
    (:func:`~eaplan_drake.files.ResultDirectory`): ``log.npz``, ``summary.json``, ``flight.png``
    and, with ``replay``, the Meshcat replay ``replay.html``
    (:func:`~eaplan_drake.output.replay.SaveFlightReplay`); returns the paths of the figure and
    the replay."""
    CheckType(log, FlightLog, "log", "a FlightLog (from Simulate)")
    CheckType(scenario, Scenario, "scenario", "a Scenario")
    final = Path(directory)
    with ResultDirectory(final) as tmp:
        log.Save(tmp)
        written = [SaveFlightPlots(log, scenario, tmp)]
        if replay:
            from eaplan_drake.output.replay import SaveFlightReplay

            written.append(SaveFlightReplay(log, scenario, tmp / "replay.html"))
    return [final / f.name for f in written]
