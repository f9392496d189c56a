"""Choosing the power-log reader: by name (``fit --reader``) or by the file's suffix.

The readers are :data:`~eaplan_drake.registry.POWER_LOG_READERS` (``csv``: the CSV layouts of
:func:`~eaplan_drake.logfit.powerlog.ReadPowerLog`; ``ulog``: PX4 ULog,
:func:`~eaplan_drake.logfit.ulog.ReadULog`); :data:`POWER_LOG_SUFFIXES` maps a suffix to a reader
(any other suffix: ``csv``).
"""

from pathlib import Path

from eaplan_drake.logfit.powerlog import PowerLog
from eaplan_drake.registry import POWER_LOG_READERS

__all__ = ["POWER_LOG_SUFFIXES", "PowerLogReaderName", "ReadAnyPowerLog"]

POWER_LOG_SUFFIXES = {".ulg": "ulog", ".csv": "csv"}
"""File suffix (lower case) → reader name; other suffixes are read as CSV."""


def PowerLogReaderName(path, reader: str = "") -> str:
    """The reader for ``path``: ``reader`` when given, else by its suffix."""
    if reader:
        POWER_LOG_READERS.Check(reader)
        return reader
    return POWER_LOG_SUFFIXES.get(Path(path).suffix.lower(), "csv")


def ReadAnyPowerLog(path, reader: str = "", **options) -> PowerLog:
    """The power log ``path`` read by :func:`PowerLogReaderName`'s reader with ``options``
    (the CSV reader's column and time options; ``None`` = not given)."""
    name = PowerLogReaderName(path, reader)
    if name == "csv":
        return POWER_LOG_READERS.Make(name, path, **options)
    return POWER_LOG_READERS.Make(name, path, **{k: v for k, v in options.items() if v is not None})
