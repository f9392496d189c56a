"""Saving a flight's result directory as a unit: the log, its summary, the figure, the replay."""

from pathlib import Path

from eaplan_drake.files import ResultDirectory
from eaplan_drake.flightlog import FlightLog
from eaplan_drake.output.plots import SaveFlightPlots
from eaplan_drake.params import CheckType, Scenario

__all__ = ["FLOWN_ALTITUDE", "SaveFlight", "SaveFlownMissions"]

FLOWN_ALTITUDE = 50.0
"""Altitude above home [m] of the missions as flown (the simulation is planar)."""


def SaveFlight(
    log: "FlightLog", scenario: Scenario, directory: str | Path, *, replay: bool = False
) -> list[Path]:
    """Writes a flight's result directory as a unit
    (:func:`~eaplan_drake.files.ResultDirectory`): ``log.npz``, ``summary.json``, ``flight.png``;
    for a field (``coverage.field``) the missions as flown, ``flown.plan`` (QGroundControl),
    ``flown.waypoints`` (WPL 110) and ``flown.xml`` (Paparazzi)
    (:func:`SaveFlownMissions`); with ``replay``, the Meshcat replay ``replay.html``
    (:func:`~eaplan_drake.output.replay.SaveFlightReplay`). Returns the paths of the figure, the
    missions and the replay.

    Every flight that ran keeps its log, summary and figure: an export with nothing to export
    (the missions of a field flight that ended before its first survey line) is skipped, and
    ``summary["skipped_exports"]`` says why."""
    CheckType(log, FlightLog, "log", "a FlightLog (from Simulate)")
    CheckType(scenario, Scenario, "scenario", "a Scenario")
    final = Path(directory)
    with ResultDirectory(final) as tmp:
        written = [SaveFlightPlots(log, scenario, tmp)]
        if scenario.coverage.field:
            missions = SaveFlownMissions(log, scenario, tmp)
            if not missions:
                log.summary["skipped_exports"] = [
                    "the missions as flown: the flight ended before its first survey line"
                ]
            written += missions
        log.Save(tmp)
        if replay:
            from eaplan_drake.output.replay import SaveFlightReplay

            written.append(SaveFlightReplay(log, scenario, tmp / "replay.html"))
    return [final / f.name for f in written]


def SaveFlownMissions(log: "FlightLog", scenario: Scenario, directory: str | Path) -> list[Path]:
    """Writes the missions of a field flight as flown into ``directory``: the stages replayed
    from the log (:func:`~eaplan_drake.flight.coverage.FlownStages`), their lines, turns and
    transits (:meth:`~eaplan_drake.field.source.FieldCoverage.FlownRoute`), as ``flown.plan``,
    ``flown.waypoints`` and ``flown.xml`` (:func:`~eaplan_drake.field.missions.WriteMissions`)
    at :data:`FLOWN_ALTITUDE` above the ground at ``coverage.ground_alt``, from and back to
    ``coverage.home`` (or the first line's start), ending as ``coverage.mission_end``, inside
    the airspace the flown route declares (:func:`~eaplan_drake.field.airspace.MakeAirspace`).
    Returns their paths; none when the flight flew no survey line (nothing to export)."""
    import numpy as np

    from eaplan_drake.field.airspace import MakeAirspace
    from eaplan_drake.field.missions import MissionEnds, WriteMissions
    from eaplan_drake.field.source import MakeFieldPlanSource
    from eaplan_drake.flight.coverage import FlownStages

    c1 = log.signals["flown_path_parameter"][:, 0]
    plan = MakeFieldPlanSource(scenario, float(c1[0]))
    route = plan.FlownRoute(FlownStages(plan, log.signals["stage"][:, 0], c1))
    if route.Count("line") == 0:
        return []
    coverage = scenario.coverage
    home = None
    if coverage.home:
        home = tuple(float(v) for v in plan.field.frame.ToLocal(np.array([coverage.home]))[0])
    ends = MissionEnds(home, float(coverage.ground_alt), coverage.mission_end)
    extra = [ends.ApproachFix(route)] if ends.end == "land" else []
    airspace = MakeAirspace(
        route,
        plan.field,
        scenario,
        margin=coverage.airspace_margin,
        home=ends.Home(route),
        extra_points=extra,
        no_fly=plan.field.holes if coverage.no_fly_holes else (),
    )
    written = WriteMissions(
        directory,
        route,
        plan.field,
        altitude=FLOWN_ALTITUDE,
        cruise_speed=scenario.vehicle.airspeed,
        ends=ends,
        fence=airspace.Fence(),
        stem="flown",
    )
    return list(written.values())
