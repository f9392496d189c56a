"""Read a recorded power log: time [s] and power [W] (or voltage [V] × current [A]).

Two layouts are recognised:

- **CSV with a header.** Columns are found by name (case-insensitive), or given explicitly:
  time ``t``, ``time``, ``time_s``, ``timestamp`` (microseconds, the PX4 convention),
  ``time_us``, ``time_ms``, ``timestamp_us``; power ``power``, ``power_w``, ``p``, ``w``;
  voltage ``voltage_v``, ``voltage``, ``v``, ``vbat``, ``bat``; current ``current_a``,
  ``current``, ``i``, ``amp``, ``amps``. A PX4 ``battery_status`` CSV export (ulog2csv:
  ``timestamp`` [µs], ``voltage_v``, ``current_a``, …) gives power = voltage_v × current_a.
- **CSV without a header** (Paparazzi logs of the authors): one column is the Paparazzi energy
  log (``pprz_energy.csv``: power [W] at a fixed time step, 0.5 s by default, see
  :data:`PAPARAZZI_TIME_STEP`); with two or more columns nothing says which is which, so the
  columns must be named by 0-based index: time (or a time step) and power (or voltage and
  current), e.g. ``pprz_throttle.csv`` (t, throttle, W): time 0, power 2; the authors'
  ``energy_resized.csv`` (t, measured W, estimated W, q…): time 0, power 1.

Every problem is one :class:`PowerLogError` naming ``file:line:col`` or the missing column.
"""

import dataclasses as dc
import math
import os
from pathlib import Path

import numpy as np

from eaplan_drake.files import MissingFile

__all__ = [
    "AUTHORS_CONTROL_STEP",
    "PAPARAZZI_TIME_STEP",
    "REFERENCE_ENV",
    "PowerLog",
    "PowerLogError",
    "ReadPeriodLog",
    "ReadPowerLog",
    "ReferenceDirectory",
]

REFERENCE_ENV = "EAPLAN_REFERENCE_DIR"
"""Environment variable naming the authors' reference data (default:
``../shared/reference/seewald2022`` beside the repository)."""


def ReferenceDirectory() -> Path:
    """The reference data directory: ``$EAPLAN_REFERENCE_DIR`` or the default beside the repo
    (it may not exist; callers skip or say so)."""
    given = os.environ.get(REFERENCE_ENV)
    if given:
        return Path(given)
    return Path(__file__).resolve().parents[2].parent / "shared" / "reference" / "seewald2022"


_TIME_NAMES = {
    "t": 1.0,
    "time": 1.0,
    "time_s": 1.0,
    "t_s": 1.0,
    "seconds": 1.0,
    "timestamp": 1e-6,
    "timestamp_us": 1e-6,
    "time_us": 1e-6,
    "time_ms": 1e-3,
    "timestamp_ms": 1e-3,
}
_POWER_NAMES = ("power", "power_w", "p", "p_w", "w", "watts")
_VOLTAGE_NAMES = ("voltage_v", "voltage", "v", "vbat", "bat", "voltage_filtered_v")
_CURRENT_NAMES = ("current_a", "current", "i", "amp", "amps", "current_filtered_a")
PAPARAZZI_TIME_STEP = 0.5
"""Default step of a one-column Paparazzi energy log [s]: the Opterra ``pprz_energy.csv`` has the
640 rows of ``pprz_throttle.csv`` from the same flight, stamped every 0.5 s (the authors'
``scripts/energy/MAIN.m`` assumes 200 ms; give ``time_step`` when it differs)."""


class PowerLogError(ValueError):
    """A power log that cannot be read; the message names the file and line/column or field."""


@dc.dataclass
class PowerLog:
    """A power series read from a file."""

    times: np.ndarray
    """t [s], increasing."""
    power: np.ndarray
    """y [W]."""
    source: str
    """How it was read (layout and columns), one line."""


def _Index(header: list[str], given, names, path: Path, what: str, option: str):
    """Column index: the given name/index, else the first recognised name, else None."""
    lower = [h.strip().lower() for h in header]
    if given is not None and str(given) != "":
        g = str(given).strip()
        if g.lower() in lower:
            return lower.index(g.lower())
        if g.lstrip("-").isdigit() and -len(header) <= int(g) < len(header):
            return int(g) % len(header)
        raise PowerLogError(
            f"{path}:1: {option} {g!r} is not a column (columns: {', '.join(header)})"
        )
    for n in names:
        if n in lower:
            return lower.index(n)
    return None


def _Parse(path: Path, lines: list[str], first: int, columns: int) -> np.ndarray:
    data = np.empty((len(lines) - first, columns))
    row = 0
    for i in range(first, len(lines)):
        text = lines[i].strip()
        if not text:
            continue
        cells = text.split(",")
        if len(cells) != columns:
            raise PowerLogError(
                f"{path}:{i + 1}:1: expected {columns} comma-separated values, got {len(cells)}"
            )
        col = 1
        for j, cell in enumerate(cells):
            try:
                data[row, j] = float(cell) if cell.strip() else math.nan
            except ValueError:
                raise PowerLogError(
                    f"{path}:{i + 1}:{col}: not a number: {cell.strip()[:40]!r}"
                ) from None
            col += len(cell) + 1
        row += 1
    return data[:row]


def _ReadLines(path: Path) -> tuple[list[str], int]:
    """The lines of ``path`` and the index of its first non-blank one."""
    if MissingFile(path):
        raise PowerLogError(f"{path}: {MissingFile(path)}")
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise PowerLogError(f"{path}: cannot read: {e}") from None
    first = next((i for i, s in enumerate(lines) if s.strip()), None)
    if first is None:
        raise PowerLogError(f"{path}: empty file")
    return lines, first


def _IsNumber(cell: str) -> bool:
    try:
        float(cell)
        return True
    except ValueError:
        return False


def _HeaderColumns(path: Path, header: list[str], given, time_step) -> tuple:
    """(time, power, voltage, current) column indices of a log with a header (None: absent)
    from the ``given`` names or indices, else by the recognised names."""
    time_column, power_column, voltage_column, current_column = given
    it = _Index(header, time_column, list(_TIME_NAMES), path, "time", "--time-column")
    if it is None and time_step is None:
        raise PowerLogError(
            f"{path}:1: no time column (recognised: {', '.join(_TIME_NAMES)}); give "
            f"--time-column or --time-step"
        )
    ip = _Index(header, power_column, _POWER_NAMES, path, "power", "--power-column")
    if ip is not None:
        return it, ip, None, None
    iv = _Index(header, voltage_column, _VOLTAGE_NAMES, path, "voltage", "--voltage-column")
    ic = _Index(header, current_column, _CURRENT_NAMES, path, "current", "--current-column")
    if iv is None or ic is None:
        raise PowerLogError(
            f"{path}:1: no power column, nor voltage and current columns (recognised: "
            f"{', '.join(_POWER_NAMES)}; {', '.join(_VOLTAGE_NAMES[:3])} × "
            f"{', '.join(_CURRENT_NAMES[:3])}); give --power-column or "
            f"--voltage-column and --current-column"
        )
    return it, None, iv, ic


def _NumberedColumns(path: Path, names: list[str], given, time_step) -> tuple:
    """(time, power, voltage, current) column indices of a log without a header: the one
    column is power; several must be named by 0-based index (``given``)."""
    if len(names) == 1:
        return None, 0, None, None
    time_column, power_column, voltage_column, current_column = given
    it = _Index(names, time_column, (), path, "time", "--time-column")
    ip = _Index(names, power_column, (), path, "power", "--power-column")
    iv = _Index(names, voltage_column, (), path, "voltage", "--voltage-column")
    ic = _Index(names, current_column, (), path, "current", "--current-column")
    missing = []
    if it is None and time_step is None:
        missing.append("--time-column (or --time-step)")
    if ip is None and (iv is None or ic is None):
        missing.append("--power-column (or --voltage-column and --current-column)")
    if missing:
        raise PowerLogError(
            f"{path}: no header and {len(names)} columns: name them by 0-based index: "
            f"{' and '.join(missing)}"
        )
    return it, ip, iv, ic


def _TimeAndPower(data, names, columns, time_scale, time_step):
    """(t [s], y [W], how they were read) from the parsed rows and the column indices."""
    it, ip, iv, ic = columns
    if ip is not None:
        y = data[:, ip]
        what = f"power = {names[ip]}"
    else:
        y = data[:, iv] * data[:, ic]
        what = f"power = {names[iv]} × {names[ic]}"
    if it is not None:
        name = names[it].strip().lower()
        scale = time_scale if time_scale is not None else _TIME_NAMES.get(name, 1.0)
        t = data[:, it] * float(scale)
        what = f"time = {names[it]} (× {scale:g} s), {what}"
    else:
        t = float(time_step) * np.arange(data.shape[0])
        what = f"time = row × {time_step:g} s, {what}"
    return t, y, what


def _UsableRows(path: Path, t, y, first_row_line: int):
    """(t, y) without the rows of a non-finite time or power; at least 16 rows, increasing
    times (else the error names the line, the first data row being ``first_row_line``)."""
    keep = np.isfinite(t) & np.isfinite(y)
    t, y = t[keep], y[keep]
    if t.size < 16:
        raise PowerLogError(f"{path}: {t.size} usable rows, need at least 16")
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        line = first_row_line + int(np.flatnonzero(keep)[bad[0] + 1])
        raise PowerLogError(f"{path}:{line}: time does not increase ({t[bad[0] + 1]:g} s)")
    return t, y


def ReadPowerLog(
    path,
    time_column=None,
    power_column=None,
    voltage_column=None,
    current_column=None,
    time_scale: float | None = None,
    time_step: float | None = None,
) -> PowerLog:
    """Read ``path`` (see the module docstring for the layouts and recognised names).

    Args:
        time_column, power_column, voltage_column, current_column: a column name (header) or a
            0-based index; default: recognised by name (header) or by position (no header).
        time_scale: seconds per unit of the time column (default: from its name; 1 otherwise).
        time_step: step [s] of a log without a time column (one-column Paparazzi energy log;
            default :data:`PAPARAZZI_TIME_STEP`).

    Rows with a non-finite time or power are dropped; the rest must have increasing times.
    """
    path = Path(path)
    lines, first = _ReadLines(path)
    head = [c.strip() for c in lines[first].split(",")]
    has_header = not all(_IsNumber(c) for c in head if c)
    if time_step is not None and not (math.isfinite(time_step) and time_step > 0.0):
        raise PowerLogError(f"--time-step: must be finite and > 0 [s], got {time_step!r}")
    given = (time_column, power_column, voltage_column, current_column)
    if has_header:
        data = _Parse(path, lines, first + 1, len(head))
        if data.shape[0] == 0:
            raise PowerLogError(f"{path}: a header but no data rows")
        names, columns = head, _HeaderColumns(path, head, given, time_step)
    else:
        data = _Parse(path, lines, first, len(head))
        names = [f"column {j}" for j in range(len(head))]
        columns = _NumberedColumns(path, names, given, time_step)
        if len(head) == 1 and time_step is None:
            time_step = PAPARAZZI_TIME_STEP
    t, y, what = _TimeAndPower(data, names, columns, time_scale, time_step)
    t, y = _UsableRows(path, t, y, first + (2 if has_header else 1))
    layout = "header" if has_header else "no header"
    return PowerLog(times=t - t[0], power=y, source=f"{path.name} ({layout}): {what}")


AUTHORS_CONTROL_STEP = 0.01
"""Step [s] of the authors' control loop: the rows of ``plan_X/ctl.csv`` and the step count in
``plan_X/perioddata.csv``."""


def ReadPeriodLog(path, step: float = AUTHORS_CONTROL_STEP) -> tuple[np.ndarray, np.ndarray]:
    """(t [s], T [s]) of the authors' running period estimate ``perioddata.csv``.

    Rows are (control step, T [s]), logged when T changes; t = step × ``step``. Their estimator
    reports the time since the last lap start while it exceeds the last lap's duration (the
    first lap: T grows from 1 s), and holds the last lap's duration otherwise. A row that is
    not two numbers, or steps that decrease, is a :class:`PowerLogError` naming the line; so is
    a ``step`` that is not a finite number > 0 [s].
    """
    if not (isinstance(step, int | float) and math.isfinite(step) and step > 0.0):
        raise PowerLogError(
            f"period log step (fit --period-log-step) must be a finite number > 0 s, got {step!r}"
        )
    path = Path(path)
    lines, first = _ReadLines(path)
    data = _Parse(path, lines, first, 2)
    line = [i + 1 for i in range(first, len(lines)) if lines[i].strip()]  # 1-based, per row
    bad = np.flatnonzero(~np.all(np.isfinite(data), axis=1) | (data[:, 1] <= 0.0))
    if bad.size:
        raise PowerLogError(f"{path}:{line[bad[0]]}: needs a step and a period T > 0 [s]")
    back = np.flatnonzero(np.diff(data[:, 0]) < 0.0)
    if back.size:
        raise PowerLogError(f"{path}:{line[back[0] + 1]}: step decreases")
    return data[:, 0] * float(step), data[:, 1]
