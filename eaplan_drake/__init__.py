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

__version__ = "0.1.0"
