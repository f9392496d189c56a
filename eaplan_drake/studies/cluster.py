"""Flights on a Dask cluster through its own futures (``distributed.Client.submit``), so that every
flight ends as a row.

:func:`MapOnDask` connects to a scheduler (or uses a given ``distributed.Client``), waits for a
worker, and submits one task per flight, never more at once than the connected workers have
threads (a flight sent to a worker waits for a free thread there, so a worker that dies loses only
the flights it was flying). Every task ends in exactly one call:

- ``on_result(i, value)`` with the task's return value;
- ``on_failure(i, why)`` when the cluster could not run it, ``why`` one line naming the
  exception: a worker that died while flying it more times than the scheduler allows
  (``KilledWorker``; the scheduler's ``distributed.scheduler.allowed-failures``, default 3, bounds
  the deaths), or an exception raised on the worker outside the flight (e.g. the package missing
  there), tried :data:`TASK_RETRIES` more times first.

It raises :class:`ClusterError` (one line) when no scheduler answers, when no worker is connected
for ``wait`` seconds (at the start or later), or when the scheduler is lost; the tasks left are
then cancelled, and their flights have no row (a re-run flies them).
"""

import contextlib
import logging
import math
import time
import uuid

__all__ = [
    "MAX_WAIT",
    "TASK_RETRIES",
    "WAIT_FOR_WORKERS",
    "ClusterError",
    "MapOnDask",
    "QuietDistributed",
    "Wait",
]

WAIT_FOR_WORKERS = 60.0
"""Default time [s] to wait for a scheduler and a worker (``sweep --wait-for-workers``)."""
MAX_WAIT = 86_400.0
"""Largest ``wait`` [s] (one day)."""
TASK_RETRIES = 2
"""Extra tries of a task that raised on its worker (a flight's own exception is its row's error,
so only what fails around it counts: unpickling, a missing package)."""
_POLL = 0.5
"""Interval [s] of the checks for connected workers while no flight finishes."""


class ClusterError(RuntimeError):
    """The Dask cluster cannot fly the study: no scheduler, no worker for the stated time, or the
    scheduler lost. The message is one line."""


def Wait(value, name: str = "wait_for_workers") -> float:
    """``value`` [s] as a float if it is a number in (0, :data:`MAX_WAIT`]; else ValueError
    naming ``name`` and the range."""
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and 0.0 < value <= MAX_WAIT):
        raise ValueError(f"{name}: must be a number of seconds in (0, {MAX_WAIT:g}], got {value!r}")
    return float(value)


def _OneLine(e: BaseException) -> str:
    return " ".join(str(e).split()) or type(e).__name__


def _Why(e: BaseException) -> str:
    """A failed task's exception as one line for its row."""
    from distributed.scheduler import KilledWorker

    if isinstance(e, KilledWorker):
        last = getattr(e.last_worker, "address", e.last_worker)
        return (
            f"KilledWorker: the Dask worker flying it died {e.allowed_failures + 1} times "
            f"(the scheduler's allowed-failures is {e.allowed_failures}; last worker {last}); "
            "the worker's log says why"
        )
    return f"{type(e).__name__}: {_OneLine(e)}"


def _Connect(scheduler, wait: float):
    """(client, whether we made it, address)."""
    from distributed import Client

    if isinstance(scheduler, Client):
        return scheduler, False, scheduler.scheduler.address
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ValueError(
            "scheduler: backend dask needs a scheduler address (tcp://host:8786) or a "
            f"distributed.Client, got {scheduler!r}"
        )
    try:
        client = Client(scheduler, timeout=wait, set_as_default=False)
    except ValueError as e:
        raise ValueError(f"scheduler: {_OneLine(e)}") from None
    except OSError:
        raise ClusterError(f"no Dask scheduler answered at {scheduler} within {wait:g} s") from None
    return client, True, scheduler


def MapOnDask(
    scheduler,
    func,
    arguments: list[tuple],
    *,
    names: list[str],
    on_result,
    on_failure,
    wait: float = WAIT_FOR_WORKERS,
    say=lambda text: None,
) -> None:
    """Runs ``func(*arguments[i])`` on the cluster for every i (see the module docstring).

    Args:
        scheduler: a scheduler address (``tcp://host:8786``) or a ``distributed.Client`` (kept
            open; a client made here is closed).
        func: a module-level function (workers import it by name).
        names: one short name per task (part of its Dask key, for the worker logs).
        on_result, on_failure: called in the calling thread as tasks end (in any order).
        wait: [s] for the scheduler to answer and for a worker to be connected.
        say: prints a progress line (waiting for a worker).

    While it runs, ``distributed``'s own loggers print nothing below CRITICAL
    (:func:`QuietDistributed`): a scheduler or worker that dies ends in this package's one
    line (:class:`ClusterError` or an error row), not in the client's tracebacks.
    """

    with QuietDistributed():
        _MapOnDask(scheduler, func, arguments, names, on_result, on_failure, wait, say)


def _MapOnDask(scheduler, func, arguments, names, on_result, on_failure, wait, say) -> None:
    from distributed import as_completed

    wait = Wait(wait)
    client, own, address = _Connect(scheduler, wait)
    pending: dict = {}
    token = uuid.uuid4().hex[:8]
    try:
        _WaitForWorker(client, address, wait, say)
        finished = as_completed(loop=client.loop)
        queue = list(range(len(arguments)))[::-1]  # popped from the end: in flight order
        threads = _Threads(client, address)
        check = time.monotonic() + _POLL
        idle_since = None
        while queue or pending:
            while queue and len(pending) < max(1, threads):
                i = queue.pop()
                future = client.submit(
                    func,
                    *arguments[i],
                    key=f"eaplan-{names[i]}-{token}",
                    pure=False,
                    retries=TASK_RETRIES,
                )
                pending[future] = i
                finished.add(future)
            done = finished.next_batch(block=False)
            _Deliver(done, pending, on_result, on_failure, address)
            if not done and time.monotonic() < check:
                time.sleep(0.02)
                continue
            threads = _Threads(client, address)  # after a flight ends, and every _POLL s
            check = time.monotonic() + _POLL
            if threads or done:
                idle_since = None
            elif idle_since is None:
                idle_since = time.monotonic()
                say(f"no Dask worker connected to {address}; waiting up to {wait:g} s ...")
            elif time.monotonic() - idle_since > wait:
                raise ClusterError(f"no Dask worker connected to {address} for {wait:g} s")
    finally:
        _Release(client, pending, own, wait)


@contextlib.contextmanager
def QuietDistributed():
    """Within the block, every ``distributed`` logger (the package's and its modules', each with
    a level of its own) prints only CRITICAL records; their levels are restored after it."""
    loggers = [logging.getLogger("distributed")] + [
        logging.getLogger(name)
        for name in list(logging.root.manager.loggerDict)
        if name.startswith("distributed.")
    ]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


def _WaitForWorker(client, address: str, wait: float, say) -> None:
    """Returns once a worker is connected; ClusterError after ``wait`` [s] without one."""
    if not _Threads(client, address):
        say(f"waiting up to {wait:g} s for a Dask worker at {address} ...")
        try:
            client.wait_for_workers(1, timeout=wait)
        except TimeoutError:
            raise ClusterError(
                f"no Dask worker connected to {address} within {wait:g} s "
                f"(start one with: dask worker {address})"
            ) from None


def _Deliver(done, pending: dict, on_result, on_failure, address: str) -> None:
    """Calls ``on_result`` or ``on_failure`` for each future of ``done`` (taken out of
    ``pending``: future → task index) and releases it; ClusterError for a future the scheduler
    dropped."""
    for future in done:
        i = pending.pop(future)
        if future.status == "finished":
            on_result(i, future.result())
        elif future.status == "error":
            on_failure(i, _Why(future.exception()))
        else:  # cancelled or lost: the cluster's doing, not the flight's
            raise ClusterError(
                f"the Dask scheduler at {address} dropped a flight ({future.status}); "
                "run the study again to fly what is left"
            )
        future.release()


def _Release(client, pending: dict, own: bool, wait: float) -> None:
    """Cancels the tasks still ``pending`` and closes the client if we made it (``own``)."""
    if pending:
        try:
            client.cancel(list(pending))
        except Exception:  # the scheduler may be gone: nothing left to cancel
            pass
    if own:
        try:
            client.close(timeout=min(wait, 10.0))
        except Exception:  # likewise: a client whose scheduler is gone
            pass


def _Threads(client, address: str) -> int:
    """Threads of the workers connected now."""
    try:
        return int(sum(client.nthreads().values()))
    except OSError as e:
        raise ClusterError(f"lost the Dask scheduler at {address}: {_OneLine(e)}") from None
