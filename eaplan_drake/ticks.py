"""Periodic discrete updates on the loop's base tick, so that event times coincide bit for bit.

Drake places a periodic event at k · period. A system updating every n ≥ 2 base ticks h at
period n·h would get the times k·(n·h), which differ from the loop's (k·n)·h in the last bit
unless n is a power of two; such an update then runs in a step of its own, one ulp off, and sees
the other systems after their update. :func:`DeclareTickedDiscreteUpdateEvent` declares the
event at h instead and runs the handler on every n-th tick (the sensor, the estimator and the
sequencer use it).
"""

from pydrake.systems.framework import EventStatus

from eaplan_drake.params import TicksPerPeriod

__all__ = ["DID_NOTHING", "DeclareTickedDiscreteUpdateEvent"]

DID_NOTHING = EventStatus.DidNothing()
"""The status of a base tick that is not the system's (one object, not one per call)."""


def DeclareTickedDiscreteUpdateEvent(system, period: float, time_step, update) -> int:
    """Declares the discrete-update handler ``update`` of ``system`` every ``period`` [s].

    When ``period`` is n ≥ 2 base ticks ``time_step`` h [s]
    (:func:`~eaplan_drake.params.TicksPerPeriod`), the event is declared at h and ``update``
    runs on the ticks t with round(t/h) divisible by n (the others return :data:`DID_NOTHING`);
    otherwise (``time_step`` None, or not an integer multiple) it is declared at ``period``.
    Returns n (1 in the second case).
    """
    n = TicksPerPeriod(period, time_step)
    if n == 1:
        system.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, update)
        return 1
    h = float(time_step)

    def on_tick(context, discrete_state):
        if round(context.get_time() / h) % n:
            return DID_NOTHING
        return update(context, discrete_state)

    system.DeclarePeriodicDiscreteUpdateEvent(h, 0.0, on_tick)
    return n
