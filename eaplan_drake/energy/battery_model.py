"""The battery-model interface: the SoC arithmetic that the battery system and the planner share.

A :class:`BatteryModel` answers, for a terminal load power y [W] (a scalar or a numpy array,
element-wise), how fast the state of charge b [-] falls, how that rate changes with y, where the
battery browns out, and where b is after a constant load. The
:class:`~eaplan_drake.energy.battery.Battery` system steps b with :meth:`BatteryModel.SocAfter`;
every planner policy predicts b with :meth:`BatteryModel.SocRate` and
:meth:`BatteryModel.SocRateSlope` (:mod:`eaplan_drake.planning.prediction`). ``battery.model``
names the model in :data:`~eaplan_drake.registry.BATTERY_MODELS`; :func:`AsBatteryModel` builds it.

A new battery model is one module with a subclass and one line in the registry (see
CONTRIBUTING.md). The rate may depend on the load only (not on b): the planner's prediction
integrates ḃ(y(t)) by Simpson's rule, exact for such models up to the load's own variation.
"""

from eaplan_drake.params import BatteryParams
from eaplan_drake.registry import BATTERY_MODELS

__all__ = ["AsBatteryModel", "BatteryModel"]


class BatteryModel:
    """The interface; ``params`` is the scenario's ``battery`` subtree (a copy is not made: a
    model must not change it). Units: power y [W], time [s], SoC b [-]."""

    def __init__(self, params: BatteryParams):
        self.params = params

    @property
    def reserve_soc(self) -> float:
        """b_res [-]: the flight fails at or below it."""
        return self.params.reserve_soc

    def SocRate(self, power):
        """ḃ(y) [1/s] (≤ 0 while discharging)."""
        raise NotImplementedError

    def SocRateSlope(self, power):
        """∂ḃ/∂y [1/(W s)] of :meth:`SocRate`."""
        raise NotImplementedError

    def SocAfter(self, soc, power, duration):
        """b after ``duration`` [s] at constant ``power`` from ``soc``, clipped to [0, 1]."""
        raise NotImplementedError

    def Current(self, power):
        """The battery's current [A] at the load ``power`` (logged)."""
        raise NotImplementedError

    def IsBrownout(self, power):
        """True where the battery cannot deliver ``power`` (the flight ends)."""
        raise NotImplementedError

    def PowerBudget(self, soc):
        """The paper's output-constraint bound at SoC ``soc`` [W as the paper reads it]."""
        raise NotImplementedError


def AsBatteryModel(battery) -> BatteryModel:
    """``battery`` itself if it is a :class:`BatteryModel`, else the model its ``model`` key names
    (:data:`~eaplan_drake.registry.BATTERY_MODELS`) built from those parameters."""
    if isinstance(battery, BatteryModel):
        return battery
    return BATTERY_MODELS.Make(battery.model, battery)
