"""Read a PX4 ULog (``.ulg``): the ``battery_status`` topic as time [s] and power [W].

PX4 logs ``battery_status`` with ``timestamp`` [µs since boot], ``voltage_v`` [V] and
``current_a`` [A] (older firmware: ``voltage_filtered_v``, ``current_filtered_a``); power =
voltage × current. PX4 writes a current of −1 when it measures none: samples with a negative or
non-finite current or voltage are dropped. Of several instances (``multi_id``, one per battery)
the one with the most samples is read unless ``instance`` says which.

Needs pyulog (``pip install 'eaplan-drake[ulog]'``). A file that is not a ULog, or a ULog without
the topic (the message lists the topics it has), is one
:class:`~eaplan_drake.logfit.powerlog.PowerLogError` line. A file cut inside a message (a log
whose writer stopped mid-write) is read up to the cut and says so in its source
(:func:`ULogCut`): pyulog itself reads it silently.
"""

import struct
from pathlib import Path

import numpy as np

from eaplan_drake.errors import MissingExtraError
from eaplan_drake.files import MissingFile
from eaplan_drake.logfit.powerlog import PowerLog, PowerLogError

__all__ = ["ULOG_TOPIC", "ReadULog", "ULogCut"]

ULOG_TOPIC = "battery_status"
"""The topic read by default."""
_VOLTAGE = ("voltage_v", "voltage_filtered_v")
_CURRENT = ("current_a", "current_filtered_a")
_MIN_SAMPLES = 16


_HEADER = 16
"""The ULog file header [bytes] (magic, version, timestamp); messages follow, each a uint16
size, a uint8 type and ``size`` bytes."""


def ULogCut(path) -> int | None:
    """The byte offset of the message the file ``path`` ends inside (its header or its payload
    cut short), or None when the file ends at a message boundary."""
    data = Path(path).read_bytes()
    at = _HEADER
    while at < len(data):
        if at + 3 > len(data):
            return at
        (size,) = struct.unpack_from("<H", data, at)
        if at + 3 + size > len(data):
            return at
        at += 3 + size
    return None


def _Load(path: Path, topics):
    try:
        from pyulog import ULog
    except ImportError:
        raise MissingExtraError(
            "reading ULog files needs pyulog: pip install 'eaplan-drake[ulog]'"
        ) from None
    try:
        return ULog(str(path), topics)
    except Exception as e:  # pyulog raises several types for a file that is not a ULog
        text = " ".join(str(e).split()) or type(e).__name__
        raise PowerLogError(f"{path}: not a readable ULog file: {text}") from None


def ReadULog(path, *, topic: str = ULOG_TOPIC, instance: int | None = None, **options) -> PowerLog:
    """Power [W] = voltage × current of ``topic`` in the ULog ``path`` (see the module
    docstring); ``instance`` the multi_id (default: the one with the most samples). The CSV
    reader's column options do not apply and are refused when given."""
    path = Path(path)
    given = sorted(k for k, v in options.items() if v is not None)
    if given:
        flags = ", ".join("--" + k.replace("_", "-") for k in given)
        raise PowerLogError(f"{path}: {flags}: for CSV logs only, not for a ULog")
    if MissingFile(path):
        raise PowerLogError(f"{path}: {MissingFile(path)}")
    ulog = _Load(path, [topic])
    datasets = [d for d in ulog.data_list if d.name == topic]
    if not datasets:
        names = sorted({d.name for d in _Load(path, None).data_list})
        raise PowerLogError(
            f"{path}: no {topic!r} topic; the log has {len(names)}: {', '.join(names) or 'none'}"
        )
    if instance is None:
        data = max(datasets, key=lambda d: len(d.data["timestamp"]))
    else:
        matching = [d for d in datasets if d.multi_id == instance]
        if not matching:
            ids = ", ".join(str(d.multi_id) for d in datasets)
            raise PowerLogError(f"{path}: {topic} has no instance {instance} (it has {ids})")
        data = matching[0]
    voltage = next((f for f in _VOLTAGE if f in data.data), None)
    current = next((f for f in _CURRENT if f in data.data), None)
    if voltage is None or current is None:
        raise PowerLogError(
            f"{path}: {topic} has no {' or '.join(_VOLTAGE)} and {' or '.join(_CURRENT)} fields "
            f"(fields: {', '.join(sorted(data.data))})"
        )
    t = np.asarray(data.data["timestamp"], dtype=float) * 1e-6
    v = np.asarray(data.data[voltage], dtype=float)
    i = np.asarray(data.data[current], dtype=float)
    keep = np.isfinite(t) & np.isfinite(v) & np.isfinite(i) & (v >= 0.0) & (i >= 0.0)
    if keep.sum() < _MIN_SAMPLES:
        raise PowerLogError(
            f"{path}: {topic}: {int(keep.sum())} samples with a measured voltage and current "
            f"(of {t.size}), need at least {_MIN_SAMPLES}"
        )
    t, y = t[keep], v[keep] * i[keep]
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if back.size:
        raise PowerLogError(f"{path}: {topic}: timestamp does not increase at sample {back[0] + 1}")
    source = (
        f"{path.name} (ULog {topic}[{data.multi_id}]): time = timestamp (× 1e-06 s), "
        f"power = {voltage} × {current}"
    )
    cut = ULogCut(path)
    if cut is not None:
        source += (
            f"; the file is truncated (it ends inside the message at byte {cut}): read up to it"
        )
    return PowerLog(times=t - t[0], power=y, source=source)
