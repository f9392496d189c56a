"""eaplan_drake: energy-aware planning-scheduling for battery-powered fixed-wing UAVs in Drake.

Modules (each: the math as plain numpy functions, then a thin Drake ``LeafSystem``):
``params`` (scenario dataclasses and YAML), ``paths`` (implicit path functions),
``computation`` (powprofiler table, ``ComputationLoad``), ``energy_model`` (Fourier model,
``FourierEnergyModel``), ``battery`` (Rint, ``Battery``), ``sensor`` (``PowerSensor``),
``estimator`` (Kalman filter, ``EnergyEstimator``), ``coverage`` (Zamboni-like plan, Alg. 1),
``planfile`` (authors' ``.pln`` format), ``plant`` (``FixedWingPlant``), ``guidance``
(``VectorFieldGuidance``), ``sequencer`` (``StageSequencer``), ``planner``
(``PlannerScheduler``), ``diagram`` (``MakeEaplanDiagram``), ``simulation`` (``Simulate``).
"""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("eaplan-drake")
except _metadata.PackageNotFoundError:  # imported from a source tree that is not installed
    __version__ = "0+unknown"
