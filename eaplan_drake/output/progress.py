"""Progress of flights on the command line: survey covered, SoC and an ETA.

A flight ends when the survey is covered, the battery reaches its reserve or the time limit
comes, whichever is first, so its progress is the largest of the three fractions
(:func:`FlightFraction`). The ETA is
wall-clock time (elapsed × remaining / done): it is for the person waiting and never enters a
flight's result.

:class:`ProgressBar` rewrites one line in place on a terminal and prints plain lines (one per
tenth of the work) when the stream is not a TTY, e.g. a CI log. :class:`FlightProgress` is the
``progress(t, soc, covered)`` callback of :func:`~eaplan_drake.simulation.Simulate`; several
flights in a row (``compare``) share one bar.
"""

import math
import sys
import time
from collections.abc import Callable

__all__ = ["FlightFraction", "FlightProgress", "FormatDuration", "ProgressBar"]


def FlightFraction(
    covered: float,
    soc: float,
    initial_soc: float,
    reserve_soc: float,
    t: float = 0.0,
    time_limit: float = math.inf,
) -> float:
    """How far a flight is towards its end, in [0, 1]: the largest of the survey fraction
    ``covered``, the battery fraction used towards the reserve (b0 − b) / (b0 − b_reserve) and
    the time fraction t / time_limit (each an end of the flight)."""
    used = (initial_soc - soc) / (initial_soc - reserve_soc) if initial_soc > reserve_soc else 1.0
    value = max(covered, used, t / time_limit)
    return min(1.0, max(0.0, value)) if math.isfinite(value) else 0.0


def FormatDuration(seconds: float | None) -> str:
    """``m:ss`` (or ``h:mm:ss``) of a non-negative duration [s]; ``--:--`` when unknown."""
    if seconds is None or not math.isfinite(seconds) or seconds < 0:
        return "--:--"
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class ProgressBar:
    """One progress line on ``stream`` (default ``sys.stderr``).

    ``Update(fraction, text)``: on a TTY the line is rewritten in place (at most every
    ``refresh`` seconds of wall time); otherwise a plain line is printed each time the fraction
    passes another ``plain_step`` below 1 (the last line is :meth:`Close`'s). ``clock`` [s] is
    injectable for tests.
    """

    def __init__(
        self,
        label: str = "",
        stream=None,
        width: int = 20,
        refresh: float = 0.2,
        plain_step: float = 0.1,
        clock: Callable[[], float] = time.monotonic,
        tty: bool | None = None,
    ):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.refresh = refresh
        self.plain_step = plain_step
        self.clock = clock
        self.tty = self._IsTty(self.stream) if tty is None else tty
        self.start = clock()
        self.fraction = 0.0
        self.text = ""
        self._last_draw = -math.inf
        self._next_plain = plain_step
        self._closed = False

    @staticmethod
    def _IsTty(stream) -> bool:
        try:
            return bool(stream.isatty())
        except (AttributeError, ValueError):
            return False

    def Eta(self) -> float | None:
        """Remaining wall time [s] at the current rate, ``None`` before any progress."""
        if self.fraction <= 0.0:
            return None
        elapsed = self.clock() - self.start
        return elapsed * (1.0 - self.fraction) / self.fraction

    def Line(self) -> str:
        filled = int(round(self.width * self.fraction))
        bar = "#" * filled + "." * (self.width - filled)
        label = f"{self.label}  " if self.label else ""
        text = f"  {self.text}" if self.text else ""
        return (
            f"{label}[{bar}] {100 * self.fraction:3.0f} %{text}  "
            f"elapsed {FormatDuration(self.clock() - self.start)}  "
            f"ETA {FormatDuration(self.Eta())}"
        )

    def Update(self, fraction: float, text: str = "") -> None:
        self.fraction = min(1.0, max(self.fraction, float(fraction)))
        self.text = text
        if self.tty:
            now = self.clock()
            if now - self._last_draw >= self.refresh:
                self._last_draw = now
                self.stream.write("\r" + self.Line() + "\x1b[K")
                self.stream.flush()
        elif self.fraction + 1e-12 >= self._next_plain and self.fraction < 1.0:
            # (the line at 100 % is :meth:`Close`'s, with the final text)
            while self._next_plain <= self.fraction + 1e-12:
                self._next_plain += self.plain_step
            self._Plain()

    def _Plain(self) -> None:
        print(self.Line(), file=self.stream, flush=True)

    def Close(self, text: str | None = None, fraction: float | None = None) -> None:
        """Draws the final line (and ends it on a terminal), with ``text`` and ``fraction``
        when given."""
        if self._closed:
            return
        self._closed = True
        if text is not None:
            self.text = text
        if fraction is not None:
            self.fraction = min(1.0, max(self.fraction, float(fraction)))
        if self.tty:
            self.stream.write("\r" + self.Line() + "\x1b[K\n")
            self.stream.flush()
        else:
            self._Plain()


class FlightProgress:
    """The ``progress(t, soc, covered)`` callback of
    :func:`~eaplan_drake.simulation.Simulate` drawing on a :class:`ProgressBar`: the flight's
    :func:`FlightFraction` with the survey covered, the SoC and the simulated time. Flight
    ``index`` of ``count`` fills the bar's share [index/count, (index+1)/count]."""

    def __init__(self, scenario, bar: ProgressBar, index: int = 0, count: int = 1):
        self.name = scenario.name
        self.initial_soc = scenario.battery.initial_soc
        self.reserve_soc = scenario.battery.reserve_soc
        self.time_limit = scenario.simulation.time_limit
        self.bar = bar
        self.index = index
        self.count = count

    def __call__(self, t: float, soc: float, covered: float) -> None:
        f = FlightFraction(covered, soc, self.initial_soc, self.reserve_soc, t, self.time_limit)
        flight = f"{self.name} ({self.index + 1}/{self.count}) " if self.count > 1 else ""
        self.bar.Update(
            (self.index + f) / self.count,
            f"{flight}t = {t:4.0f} s, survey {100 * covered:3.0f} % covered, SoC {soc:.3f}",
        )
