"""Registries: every choice a scenario names, as one name → factory table each.

A :class:`Registry` feeds both the validation of the scenario key that names the choice
(:meth:`Registry.Check`, one line listing the allowed names) and the construction
(:meth:`Registry.Make`). Entries name their factory as ``"module:attribute"`` and are imported
only when used, so the schema can validate a name without importing the systems (and the command
line without importing pydrake). This is Drake's ``Union``-typed configs and Gymnasium's
``register`` in their simplest form.

The tables:

- :data:`POLICIES` (``planner.policy``): factories ``(planner, table, order, battery, *,
  coverage_time_bounds, path_parameter_grid, integer) → PlannerPolicy``;
- :data:`AIRCRAFT_MODELS` (``simulation.plant``): ``(vehicle, simulation) → LeafSystem``;
- :data:`PLAN_SOURCES` (``coverage.plan_file`` set or not): ``(scenario, initial_c1) →
  PlanSource``;
- :data:`BATTERY_MODELS` (``battery.model``): ``(battery) → BatteryModel``, the SoC arithmetic
  that both the battery system and the planner's prediction call;
- :data:`POWER_LOG_READERS` (``fit --reader``, else by the log's suffix):
  ``(path, **options) → PowerLog``.

A new choice is its module plus one line here (or, from Python, :meth:`Registry.Register`).
"""

import dataclasses as dc
import importlib
from collections.abc import Callable

from eaplan_drake.errors import ScenarioError

__all__ = [
    "AIRCRAFT_MODELS",
    "BATTERY_MODELS",
    "PLAN_SOURCES",
    "POLICIES",
    "POWER_LOG_READERS",
    "PolicyInfo",
    "Registry",
]


class Registry:
    """Names → factories for the scenario key ``key``; ``entries`` maps each name to a factory or
    to its ``"module:attribute"`` path. Iterating yields the names in registration order."""

    def __init__(self, key: str, entries: dict[str, str | Callable], info=None, default_info=None):
        self.key = key
        self._entries = dict(entries)
        self._info = dict(info or {})
        self._default_info = default_info

    def Info(self, name: str):
        """What the tables say of the choice ``name`` beside its factory (e.g. a policy's
        :class:`PolicyInfo`); the registry's default for a name without any (None if it has
        none)."""
        return self._info.get(name, self._default_info)

    def Names(self) -> tuple[str, ...]:
        """The registered names, in registration order."""
        return tuple(self._entries)

    def __iter__(self):
        return iter(self._entries)

    def __contains__(self, name) -> bool:
        return name in self._entries

    def Check(self, name, key: str | None = None) -> None:
        """Raises :class:`~eaplan_drake.errors.ScenarioError` ``key: must be one of …, got …``
        unless ``name`` is registered."""
        if not isinstance(name, str) or name not in self._entries:
            raise ScenarioError(
                f"{key or self.key}: must be one of {', '.join(self._entries)}, got {name!r}"
            )

    def Factory(self, name: str) -> Callable:
        """The factory registered as ``name`` (imported on first use)."""
        self.Check(name)
        target = self._entries[name]
        if isinstance(target, str):
            module, _, attribute = target.partition(":")
            target = getattr(importlib.import_module(module), attribute)
            self._entries[name] = target
        return target

    def Make(self, name: str, *args, **kwargs):
        """``Factory(name)(*args, **kwargs)``."""
        return self.Factory(name)(*args, **kwargs)

    def Register(self, name: str, factory: str | Callable, info=None) -> None:
        """Adds (or replaces) the choice ``name`` (with its ``info``, e.g. a
        :class:`PolicyInfo`); a scenario may name it from then on."""
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"{self.key}: a choice's name must be an identifier, got {name!r}")
        if not (callable(factory) or (isinstance(factory, str) and ":" in factory)):
            raise ValueError(f"{self.key}: {name}: expected a callable or 'module:attribute'")
        self._entries[name] = factory
        self._info.pop(name, None)
        if info is not None:
            self._info[name] = info

    def Unregister(self, name: str) -> None:
        """Removes the choice ``name`` (a scenario naming it is then refused)."""
        self.Check(name)
        del self._entries[name]
        self._info.pop(name, None)


@dc.dataclass(frozen=True)
class PolicyInfo:
    """What the summary and the figures say of a policy (:data:`POLICIES`' entry beside its
    factory)."""

    infeasible_why: str = "the policy's constraint cannot be met"
    """Why a step has ``mission_feasible`` = 0."""
    infeasible_flown: str = "flew the policy's fallback there"
    """What the policy flew at such a step."""
    feasible_means: str = "the policy's constraint can be met"
    """What ``mission_feasible`` = 1 says."""
    without_solve: str = "no NLP solved"
    """The summary's line for a flight in which the policy solved no NLP."""
    holds_parameters: bool = False
    """It holds the initial parameters and never re-plans (no warm-up, no planner steps)."""
    power_budget: bool = False
    """It plans with the paper's output bound y ≤ b·Q_c·V (the figures draw the bound)."""


_PAPER_BOUND = PolicyInfo(
    "the paper's output constraint y ≤ b·Q_c·V cannot hold",
    "flew the lowest c2 there",
    "y ≤ b·Q_c·V holds at some c2",
    power_budget=True,
)
_HOLDS = PolicyInfo(
    "never: the static policy does not plan", "", "always, never re-planned", holds_parameters=True
)


POLICIES = Registry(
    "planner.policy",
    {
        "mpc": "eaplan_drake.planning.policies:MakeMpcPolicy",
        "paper": "eaplan_drake.planning.policies:MakePaperPolicy",
        "greedy": "eaplan_drake.planning.policies:MakeGreedyPolicy",
        "greedy_authors": "eaplan_drake.planning.policies:MakeGreedyAuthorsPolicy",
        "static": "eaplan_drake.planning.policies:MakeStaticPolicy",
        "hindsight": "eaplan_drake.planning.policies:MakeStaticPolicy",
        "static_takeoff": "eaplan_drake.planning.policies:MakeStaticTakeoffPolicy",
        "mdp": "eaplan_drake.planning.policies:MakeMdpPolicy",
    },
    info={
        "mpc": PolicyInfo(
            "even the lowest plan ends below reserve + margin",
            "flew the lowest plan there",
            "the lowest plan ends at or above reserve + margin",
            "no NLP solved: at every step the table's grid decided the plan without it, or the "
            "lowest plan was flown",
        ),
        "paper": dc.replace(
            _PAPER_BOUND,
            without_solve="no NLP solved: with integer parameters the paper's planner searches "
            "the table's c2 grid exactly",
        ),
        "greedy": PolicyInfo(
            "no c1 of the grid ends at or above the reserve",
            "moved c1 towards the lowest there",
            "some c1 of the grid ends at or above the reserve",
            "no NLP solved: a one-step rule over the table's c2",
        ),
        "greedy_authors": dc.replace(
            _PAPER_BOUND,
            without_solve="no NLP solved: the authors' rule tries every c2 of the table",
        ),
        "static": _HOLDS,
        "hindsight": _HOLDS,
        "static_takeoff": PolicyInfo(
            "even the lowest plan ends below the reserve at take-off",
            "flew the lowest plan from then on",
            "a static plan within the risk ε was chosen at take-off",
            "no NLP solved: the static plan is chosen on the grids at take-off",
        ),
        "mdp": PolicyInfo(
            "even the lowest plan keeps no margin at take-off, or every plan is lost in the model",
            "flew the lowest plan there",
            "the MDP solved at take-off gave an action",
            "no NLP solved: the MDP is solved by dynamic programming at take-off",
        ),
    },
    default_info=PolicyInfo(),
)
"""``planner.policy``: the planner policies (:mod:`eaplan_drake.planning.policies`), each with its
:class:`PolicyInfo`; ``hindsight`` flights are static (:func:`~eaplan_drake.simulation.FlyHindsight`
flies several)."""

AIRCRAFT_MODELS = Registry(
    "simulation.plant",
    {
        "continuous": "eaplan_drake.flight.plant:MakeContinuousPlant",
        "exact_arc": "eaplan_drake.flight.plant:MakeExactArcPlant",
    },
)
"""``simulation.plant``: the aircraft models (:mod:`eaplan_drake.flight.plant`)."""

PLAN_SOURCES = Registry(
    "coverage.plan_file",
    {
        "zamboni": "eaplan_drake.flight.coverage:MakeZamboniPlanSource",
        "plan_file": "eaplan_drake.flight.planfile:MakePlanFileSource",
        "field": "eaplan_drake.field.source:MakeFieldPlanSource",
    },
)
"""The plan a flight follows: the generated Zamboni-like coverage (``zamboni``, when
``coverage.plan_file`` and ``coverage.field`` are empty), an authors' ``.pln`` file
(``plan_file``) or a field read from a GeoJSON, KML or QGroundControl file (``field``)."""

BATTERY_MODELS = Registry(
    "battery.model",
    {
        "rint": "eaplan_drake.energy.battery:RintBatteryModel",
    },
)
"""``battery.model``: the battery models (:mod:`eaplan_drake.energy.battery`)."""

POWER_LOG_READERS = Registry(
    "fit --reader",
    {
        "csv": "eaplan_drake.logfit.powerlog:ReadPowerLog",
        "ulog": "eaplan_drake.logfit.ulog:ReadULog",
    },
)
"""``fit --reader`` (default: by the log's suffix, :mod:`eaplan_drake.logfit.readers`): the
power-log readers, ``(path, **options) → PowerLog``."""
