"""The flight log: the time series of one flight, its summary, and the quality it scores.

The paper's quality metric (paper 003 Sec. V) is

    P = mean_t(½ c̃1 + ½ c̃2) / (b(t_f) − b_reserve),

c̃ the parameters normalised to [0, 1] by their bounds (the path parameter's from the scenario,
the computation parameters' from the table; both carried in the summary as
``path_parameter_bounds`` and ``computation_parameter_bounds``, so that a figure or a replay of a
saved log needs neither the scenario's table nor its file); a flight that does not complete the
survey or ends with b ≤ b_reserve fails (P is then ``None``). This module is the one owner of
that arithmetic: :func:`NormalisedParameters` and :func:`SampleQuality` per sample,
:func:`QualityMetric` over a flight.
"""

import dataclasses as dc
import json
from pathlib import Path

import numpy as np

from eaplan_drake.files import AtomicWrite, StrictJson

__all__ = [
    "FlightLog",
    "LoadFlightLog",
    "NormaliseParameters",
    "NormalisedParameters",
    "NormalisedSamples",
    "Quality",
    "QualityMetric",
    "SampleQuality",
]


@dc.dataclass
class FlightLog:
    """Time series of one flight (``times`` [s] and one array per signal, samples along axis 0)
    and a JSON-able ``summary``."""

    times: np.ndarray
    signals: dict[str, np.ndarray]
    summary: dict

    def __getitem__(self, name: str) -> np.ndarray:
        return self.signals[name]

    def Save(self, directory: str | Path) -> Path:
        """Writes ``log.npz`` and ``summary.json`` (strict JSON) into ``directory`` (created),
        each file atomically (:func:`~eaplan_drake.files.AtomicWrite`); :func:`SaveFlight` writes
        a whole result directory as a unit."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        AtomicWrite(
            directory / "log.npz",
            lambda f: np.savez_compressed(f, times=self.times, **self.signals),
            binary=True,
        )
        AtomicWrite(
            directory / "summary.json",
            lambda f: f.write(StrictJson(self.summary)),
            binary=False,
        )
        return directory


def LoadFlightLog(directory: str | Path) -> FlightLog:
    """Reads a log written by :meth:`FlightLog.Save`."""
    directory = Path(directory)
    with np.load(directory / "log.npz") as data:
        arrays = {k: data[k] for k in data.files}
    summary = json.loads((directory / "summary.json").read_text())
    times = arrays.pop("times")
    return FlightLog(times=times, signals=arrays, summary=summary)


def Quality(c1n, c2n):
    """The quality ½ c̃1 + ½ c̃2 [-] of normalised parameters (floats or arrays): the integrand of
    the summary's quality and of the paper's metric P."""
    return 0.5 * c1n + 0.5 * c2n


def QualityMetric(
    times: np.ndarray,
    path_parameters: np.ndarray,
    computation_parameters: np.ndarray,
    path_bounds: tuple[float, float],
    computation_bounds: tuple[np.ndarray, np.ndarray],
    final_soc: float,
    reserve_soc: float,
    completed: bool,
) -> tuple[float | None, float, float]:
    """The paper's metric P (``None`` for a failed flight), with mean c̃1 and mean c̃2.

    Means are time-weighted (trapezoid over ``times``); several computation parameters are
    averaged into c̃2 (:func:`NormalisedSamples`).
    """
    c1n, c2n = NormalisedSamples(
        times, path_parameters, computation_parameters, path_bounds, computation_bounds
    )
    mean_c1 = _TimeMean(times, c1n)
    mean_c2 = _TimeMean(times, c2n)
    margin = final_soc - reserve_soc
    if not completed or margin <= 0.0:
        return None, mean_c1, mean_c2
    return Quality(mean_c1, mean_c2) / margin, mean_c1, mean_c2


def NormalisedSamples(
    times: np.ndarray,
    path_parameters: np.ndarray,
    computation_parameters: np.ndarray,
    path_bounds: tuple[float, float],
    computation_bounds: tuple[np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """(c̃1, c̃2) at each sample: c1 [m²] normalised by ``path_bounds``, the computation
    parameters by ``computation_bounds`` (lower, upper per parameter) and averaged into c̃2."""
    lo, hi = path_bounds
    c1n = NormaliseParameters(np.asarray(path_parameters, dtype=float)[:, 0], lo, hi)
    clo, chi = (np.asarray(b, dtype=float) for b in computation_bounds)
    c2 = np.asarray(computation_parameters, dtype=float).reshape(len(times), -1)
    c2n = np.mean(NormaliseParameters(c2, clo, chi), axis=1)
    return c1n, c2n


def NormalisedParameters(log: FlightLog) -> tuple[np.ndarray, np.ndarray]:
    """(c̃1, c̃2) at each sample of ``log``, by the bounds its summary carries
    (``path_parameter_bounds``, ``computation_parameter_bounds``)."""
    try:
        path_bounds = tuple(float(v) for v in log.summary["path_parameter_bounds"])
        computation_bounds = log.summary["computation_parameter_bounds"]
    except KeyError as e:
        raise ValueError(
            f"the flight log's summary has no {e.args[0]} (a log from Simulate carries it)"
        ) from None
    return NormalisedSamples(
        log.times,
        log["path_parameters"],
        log["computation_parameters"],
        path_bounds,
        computation_bounds,
    )


def SampleQuality(log: FlightLog) -> np.ndarray:
    """½ c̃1 + ½ c̃2 at each sample of ``log`` (:func:`NormalisedParameters`), the integrand of the
    quality in the summary."""
    return Quality(*NormalisedParameters(log))


def NormaliseParameters(c, lo, hi):
    """c̃ = (c − lo) / (hi − lo) clipped to [0, 1] (0 where the bounds coincide)."""
    span = np.where(np.asarray(hi) > np.asarray(lo), np.asarray(hi) - np.asarray(lo), 1.0)
    return np.clip((c - lo) / span, 0.0, 1.0)


def _TimeMean(t: np.ndarray, x: np.ndarray) -> float:
    if len(t) < 2 or t[-1] <= t[0]:
        return float(x[-1]) if len(x) else 0.0
    return float(np.sum(0.5 * (x[1:] + x[:-1]) * np.diff(t)) / (t[-1] - t[0]))
