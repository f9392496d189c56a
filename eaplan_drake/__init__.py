"""eaplan_drake: energy-aware planning-scheduling for battery-powered fixed-wing UAVs in Drake.

The package is laid out as the closed loop is. At the top, the spine: the scenario
(:mod:`~eaplan_drake.params` schema, :mod:`~eaplan_drake.loading` YAML), its compile step
(:mod:`~eaplan_drake.resolve`), the loop's rates and ticks, the diagram and its builders
(:mod:`~eaplan_drake.diagram`), the simulation, the flight log (:mod:`~eaplan_drake.flightlog`),
whole-or-nothing files (:mod:`~eaplan_drake.files`) and the command line. Below it, one folder
per role: ``energy`` (Fourier energy model, computation load, Rint battery, power sensor, Kalman
estimator), ``flight`` (paths, coverage plans, plant, guidance, sequencer), ``planning`` (the
planner-scheduler system, its policies and their programs), ``studies``, ``logfit`` (power logs)
and ``output`` (figures, replay, diagrams).

The names below are the public face, imported on first use (``import eaplan_drake`` itself
imports neither pydrake nor matplotlib)::

    from eaplan_drake import LoadNamedScenario, Simulate, PlotFlight
"""

import importlib as _importlib
from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("eaplan-drake")
except _metadata.PackageNotFoundError:  # imported from a source tree that is not installed
    __version__ = "0+unknown"

_PUBLIC = {
    # the scenario
    "Scenario": "params.scenario",
    "ScenarioError": "errors",
    "LoadScenario": "loading",
    "LoadNamedScenario": "loading",
    "ResolveScenario": "resolve",
    # flights
    "Simulate": "simulation",
    "FlyHindsight": "simulation",
    "FlightLog": "flightlog",
    "LoadFlightLog": "flightlog",
    "SaveFlight": "output.save",
    # the builders
    "MakeEaplanDiagram": "diagram",
    "AddGuidedAircraft": "diagram",
    "AddEnergyLoop": "diagram",
    "AddPlannerScheduler": "diagram",
    "AddSignalLoggers": "diagram",
    "AddWindEstimator": "flight.wind_estimator",
    # the policy interface
    "PlannerPolicy": "planning.planner",
    "PlannerObservation": "planning.planner",
    "PlannerDecision": "planning.planner",
    "MakePolicy": "planning.policies",
    # the systems
    "FourierEnergyModel": "energy.fourier",
    "ComputationLoad": "energy.computation",
    "Battery": "energy.battery",
    "PowerSensor": "energy.sensor",
    "EnergyEstimator": "energy.estimator",
    "MakeFixedWingPlant": "flight.plant",
    "FixedWingPlant": "flight.plant",
    "FixedWingArcPlant": "flight.plant",
    "VectorFieldGuidance": "flight.guidance",
    "WindSource": "flight.wind",
    "WindEstimator": "flight.wind_estimator",
    "StageSequencer": "flight.sequencer",
    "PlannerScheduler": "planning.planner",
    # output, studies, logs
    "PlotFlight": "output.plots",
    "SaveFlightReplay": "output.replay",
    "LoadStudy": "studies.study",
    "RunStudy": "studies.sweep",
    "StudyReport": "studies.sweep",
    "ReadPowerLog": "logfit.powerlog",
    "FitPowerLog": "logfit.fit",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'eaplan_drake' has no attribute {name!r}")
    value = getattr(_importlib.import_module(f"eaplan_drake.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
