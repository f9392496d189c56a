"""Computation power g(c) from a measured powprofiler table (paper 003 Sec. III-B, Eq. 11).

A powprofiler table lists, one row per measured configuration, the σ computation parameters
c = (c_1, …, c_σ) followed by the average power [W] the computing hardware draws there, e.g. the
PedNet detector on a Jetson Nano (fps → W). For σ > 1 the rows form a full grid (every
combination of the per-parameter values, in lexicographic order).

g(c) interpolates the table piecewise-linearly (σ = 1) or multilinearly on the grid (σ > 1);
parameters outside the table are clamped to its range, so g is defined everywhere and never NaN.

Eq. 11 linearises g between the lower and upper bounds c̲, c̄ of each parameter,

    ν_j = (g(c̄_j) − g(c̲_j)) / (c̄_j − c̲_j),
    τ_j = c̲_j (g(c̲_j) − g(c̄_j)) / (c̄_j − c̲_j) + g(c̲_j),

so that û = diag(ν) c + τ (Eq. 9) is the straight line through (c̲, g(c̲)) and (c̄, g(c̄)).
For σ > 1 the paper leaves the other parameters open; here g(c̄_j) is taken along the edge of the
grid from the lower corner c̲ (the other parameters at their lower bounds) and the constant term is
shared, τ_j = −ν_j c̲_j + g(c̲)/σ, so that the *sum* of the components, Σ_j (ν_j c_j + τ_j) =
g(c̲) + Σ_j ν_j (c_j − c̲_j), is the first-order model of g about the lower corner (exact at c̲
and along the σ edges through it). For σ = 1 this is Eq. 11 exactly.
"""

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from eaplan_drake.files import MissingFile
from eaplan_drake.packaged import PACKAGED_TABLES

__all__ = [
    "ComputationLoad",
    "ComputationTable",
    "ComputationTableError",
    "LoadComputationTable",
    "ParseComputationTable",
]


MAX_TABLE_ROWS = 10_000
"""Largest number of data rows of a powprofiler table [-]."""
MAX_TABLE_BYTES = 1_000_000
"""Largest powprofiler table file [bytes]."""


class ComputationTableError(ValueError):
    """A powprofiler table is malformed; the message names the file and the line."""


@dc.dataclass(frozen=True, eq=False)
class ComputationTable:
    """A measured computation-power table g(c) on a full grid (frozen).

    Attributes:
        parameter_grids: σ strictly increasing arrays, the admissible (measured) values of each
            computation parameter [table units, e.g. fps]; each has at least two entries.
        values: g on the grid [W], shape (len(grid_1), …, len(grid_σ)), finite.
        source: where the table came from (file name), used in messages.
    """

    parameter_grids: tuple[np.ndarray, ...]
    values: np.ndarray
    source: str = "<table>"

    def __post_init__(self):
        grids = []
        for j, g in enumerate(self.parameter_grids):
            g = np.array(g, dtype=float).reshape(-1)
            if g.size < 2:
                raise ComputationTableError(
                    f"{self.source}: parameter {j} needs at least 2 grid values, got {g.size}"
                )
            if not np.all(np.isfinite(g)) or not np.all(np.diff(g) > 0.0):
                raise ComputationTableError(
                    f"{self.source}: parameter {j} grid must be finite and strictly "
                    f"increasing, got {g.tolist()}"
                )
            g.setflags(write=False)
            grids.append(g)
        if not grids:
            raise ComputationTableError(f"{self.source}: needs at least one parameter")
        values = np.array(self.values, dtype=float)
        shape = tuple(g.size for g in grids)
        if values.shape != shape:
            raise ComputationTableError(
                f"{self.source}: values must have shape {shape}, got {values.shape}"
            )
        if not np.all(np.isfinite(values)):
            raise ComputationTableError(f"{self.source}: power values must be finite")
        values.setflags(write=False)
        lower = np.array([g[0] for g in grids])
        upper = np.array([g[-1] for g in grids])
        lower.setflags(write=False)
        upper.setflags(write=False)
        object.__setattr__(self, "parameter_grids", tuple(grids))
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "_lower", lower)
        object.__setattr__(self, "_upper", upper)

    @property
    def num_parameters(self) -> int:
        """σ, the number of computation parameters."""
        return len(self.parameter_grids)

    @property
    def lower(self) -> np.ndarray:
        """c̲, the smallest value of each parameter, shape (σ,)."""
        return self._lower

    @property
    def upper(self) -> np.ndarray:
        """c̄, the largest value of each parameter, shape (σ,)."""
        return self._upper

    def clamp(self, c) -> np.ndarray:
        """c clamped to the table's range [c̲, c̄], shape (σ,)."""
        c = np.asarray(c, dtype=float).reshape(-1)
        if c.size != self.num_parameters:
            raise ValueError(
                f"{self.source}: expected {self.num_parameters} computation parameter(s), "
                f"got {c.size}"
            )
        if not np.all(np.isfinite(c)):
            raise ValueError(f"{self.source}: computation parameters must be finite, got {c}")
        return np.minimum(np.maximum(c, self._lower), self._upper)

    def _cell(self, c: np.ndarray):
        """Lower grid index and fraction t ∈ [0, 1] of each parameter (c already clamped)."""
        index = []
        frac = []
        for g, x in zip(self.parameter_grids, c, strict=True):
            i = int(np.searchsorted(g, x, side="right")) - 1
            i = min(max(i, 0), g.size - 2)
            index.append(i)
            frac.append((x - g[i]) / (g[i + 1] - g[i]))
        return index, frac

    def power(self, c) -> float:
        """g(c) [W]: piecewise-(multi)linear interpolation, c clamped to the table's range."""
        c = self.clamp(c)
        if self.num_parameters == 1:
            return float(np.interp(c[0], self.parameter_grids[0], self.values))
        index, frac = self._cell(c)
        cube = self.values[tuple(slice(i, i + 2) for i in index)]
        for t in frac:  # contract the leading axis each time
            cube = cube[0] * (1.0 - t) + cube[1] * t
        return float(cube)

    def gradient(self, c) -> np.ndarray:
        """∂g/∂c [W per unit] at c (the slope of the cell c lies in; at a grid value the cell
        above it, at the upper bound the last cell). Outside the range the slope of the
        nearest cell is returned (the clamped g is flat there, but this keeps optimisers moving).
        """
        c = self.clamp(c)
        index, frac = self._cell(c)
        cube = self.values[tuple(slice(i, i + 2) for i in index)]
        grad = np.empty(self.num_parameters)
        for j in range(self.num_parameters):
            sub = cube
            for k, t in enumerate(frac):
                if k == j:
                    sub = sub[1] - sub[0]
                else:
                    sub = sub[0] * (1.0 - t) + sub[1] * t
            g = self.parameter_grids[j]
            grad[j] = float(sub) / (g[index[j] + 1] - g[index[j]])
        return grad

    def scaling_factors(self) -> tuple[np.ndarray, np.ndarray]:
        """(ν, τ) of Eq. 11, each shape (σ,); see the module docstring for σ > 1."""
        sigma = self.num_parameters
        g_low = self.power(self._lower)
        nu = np.empty(sigma)
        tau = np.empty(sigma)
        for j in range(sigma):
            corner = self._lower.copy()
            corner[j] = self._upper[j]
            span = self._upper[j] - self._lower[j]
            g_up = self.power(corner)
            nu[j] = (g_up - g_low) / span
            if sigma == 1:
                tau[j] = self._lower[j] * (g_low - g_up) / span + g_low  # Eq. 11b verbatim
            else:
                tau[j] = -nu[j] * self._lower[j] + g_low / sigma
        return nu, tau

    def linear_power(self, c) -> float:
        """Σ_j (ν_j c_j + τ_j) [W], the Eq. 9/11 linear model of g (c not clamped)."""
        nu, tau = self.scaling_factors()
        c = np.asarray(c, dtype=float).reshape(-1)
        return float(np.sum(nu * c + tau))


def _parse_number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ComputationTableError(f"{where}: not a number: {text.strip()!r}") from None
    if not math.isfinite(value):
        raise ComputationTableError(f"{where}: not a finite number: {text.strip()!r}")
    return value


def ParseComputationTable(text: str, source: str = "<table>") -> ComputationTable:
    """Parses powprofiler CSV text: rows ``c_1,…,c_σ,watts``.

    Blank lines and lines starting with ``#`` are skipped; a first row whose fields are all
    non-numeric is taken as a header. Rows must be strictly increasing in lexicographic order
    (sorted, no duplicate keys) and, for σ > 1, form the full grid of the per-parameter values.
    Raises :class:`ComputationTableError` naming ``source`` and the line on any violation.
    """
    rows, width = _TableRows(text, source)
    grids, watts = _TableGrid(rows, width - 1, source)
    return ComputationTable(grids, watts, source=source)


def _TableRows(text: str, source: str) -> tuple[list[tuple[int, list[float]]], int]:
    """The data rows of powprofiler CSV text as (line number, values), strictly increasing,
    and the number of columns (:func:`ParseComputationTable`)."""
    rows: list[tuple[int, list[float]]] = []
    width = None
    for lineno, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        fields = [f.strip() for f in stripped.split(",")]
        where = f"{source}:{lineno}"
        if not rows and width is None and all(_is_header_field(f) for f in fields):
            width = len(fields)  # header
            if width < 2:
                raise ComputationTableError(
                    f"{where}: a table needs >= 2 columns (parameters, then watts)"
                )
            continue
        if width is None:
            width = len(fields)
            if width < 2:
                raise ComputationTableError(
                    f"{where}: a table needs >= 2 columns (parameters, then watts), got {width}"
                )
        if len(fields) != width:
            raise ComputationTableError(f"{where}: expected {width} columns, got {len(fields)}")
        if len(rows) >= MAX_TABLE_ROWS:
            raise ComputationTableError(f"{where}: more than {MAX_TABLE_ROWS} data rows")
        values = [_parse_number(f, f"{where}:{_Column(stripped, k)}") for k, f in enumerate(fields)]
        if values[-1] < 0.0:
            raise ComputationTableError(
                f"{where}:{_Column(stripped, width - 1)}: power must be >= 0 W, got {values[-1]:g}"
            )
        if rows and tuple(values[:-1]) <= tuple(rows[-1][1][:-1]):
            kind = "duplicate" if values[:-1] == rows[-1][1][:-1] else "unsorted"
            raise ComputationTableError(
                f"{where}: {kind} key {values[:-1]} (rows must be strictly increasing; "
                f"previous key {rows[-1][1][:-1]} on line {rows[-1][0]})"
            )
        rows.append((lineno, values))
    if len(rows) < 2:
        raise ComputationTableError(f"{source}: needs at least 2 data rows, got {len(rows)}")
    return rows, width


def _TableGrid(rows, sigma: int, source: str) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """The per-parameter grids of the σ = ``sigma`` parameters and the watts on that grid
    (C order), checking that the ``rows`` of ``_TableRows`` are the full grid."""
    keys = np.array([r[1][:-1] for r in rows])
    watts = np.array([r[1][-1] for r in rows])
    grids = tuple(np.unique(keys[:, j]) for j in range(sigma))
    shape = tuple(g.size for g in grids)
    for j, g in enumerate(grids):
        if g.size < 2:
            raise ComputationTableError(
                f"{source}: parameter column {j + 1} takes a single value {g[0]:g}; "
                "every parameter needs at least 2 values"
            )
    if math.prod(shape) > MAX_TABLE_ROWS:  # before building the grid in memory
        raise ComputationTableError(
            f"{source}: incomplete grid: {len(rows)} rows but the parameter values "
            f"({' × '.join(str(n) for n in shape)} distinct values) need {math.prod(shape)}"
        )
    # Rows are strictly increasing lexicographically, so they are the grid (in C order) iff
    # each row matches the expected combination and none is missing.
    expected = np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, sigma)
    n = min(len(rows), expected.shape[0])
    mismatch = np.flatnonzero(np.any(keys[:n] != expected[:n], axis=1))
    if mismatch.size:
        k = int(mismatch[0])
        raise ComputationTableError(
            f"{source}:{rows[k][0]}: incomplete grid: key {keys[k].tolist()} where "
            f"{expected[k].tolist()} was expected (the rows must be every combination of "
            f"{[g.tolist() for g in grids]})"
        )
    if len(rows) != expected.shape[0]:
        raise ComputationTableError(
            f"{source}: incomplete grid: {len(rows)} rows but the parameter values "
            f"{[g.tolist() for g in grids]} need {math.prod(shape)}"
        )
    return grids, watts.reshape(shape)


def _Column(line: str, k: int) -> int:
    """1-based column of the k-th comma-separated field of a stripped line."""
    col = 0
    for _ in range(k):
        col = line.index(",", col) + 1
    return col + len(line[col:]) - len(line[col:].lstrip()) + 1


def _is_header_field(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return True
    return False


def LoadComputationTable(name_or_path: str | Path) -> ComputationTable:
    """Loads a powprofiler table: a packaged name
    (:data:`~eaplan_drake.packaged.PACKAGED_TABLES`) or a CSV path."""
    key = str(name_or_path)
    path = PACKAGED_TABLES.get(key, Path(key))
    if MissingFile(path):
        raise ComputationTableError(
            f"computation table {key!r}: {MissingFile(path)} (packaged names: "
            f"{', '.join(sorted(PACKAGED_TABLES))})"
        )
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        raise ComputationTableError(
            f"{path}: {size} bytes, more than the {MAX_TABLE_BYTES} allowed"
        )
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        col = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        raise ComputationTableError(f"{path}:{line}:{col}: not UTF-8 text") from None
    return ParseComputationTable(text, source=str(path))


class ComputationLoad(LeafSystem):
    """Computation power y_c = g(c) + ΔP [W] of the onboard computing hardware (paper 003
    Sec. III-B).

    g is the piecewise-(multi)linear interpolation of a measured powprofiler table
    (:class:`ComputationTable`); parameters outside the table are clamped to its range. ΔP
    [W] (``power_offset``, ``computation.power_offset``; 0 by default) is how far the payload
    draws off the table: ``power`` is what it draws, y_c = g(c) + ΔP (the plant's true load),
    ``table_power`` what the table says, g(c) (what the estimator and the planner know). With
    ΔP = 0 the two are the same number. Direct feedthrough, no state.

    .. pydrake_system::

        name: ComputationLoad
        input_ports:
        - computation_parameters
        output_ports:
        - power
        - table_power
    """

    def __init__(self, table: ComputationTable, *, power_offset: float = 0.0):
        super().__init__()
        if not isinstance(table, ComputationTable):
            raise ValueError(
                f"ComputationLoad: table must be a ComputationTable, got {type(table).__name__}"
            )
        offset = float(power_offset) if isinstance(power_offset, int | float) else math.nan
        if not math.isfinite(offset):
            raise ValueError(
                f"ComputationLoad: power_offset must be finite [W], got {power_offset!r}"
            )
        self._table = table
        self._offset = offset
        self._parameters_port = self.DeclareVectorInputPort(
            "computation_parameters", table.num_parameters
        )
        # g depends on the parameters only: cached until they change (the planner changes them
        # at most once per h_T), not recomputed at every step of the 100 Hz chain.
        self._power_port = self.DeclareVectorOutputPort(
            "power",
            1,
            self._CalcPower,
            prerequisites_of_calc={self._parameters_port.ticket()},
        )
        self._table_power_port = self.DeclareVectorOutputPort(
            "table_power",
            1,
            self._CalcTablePower,
            prerequisites_of_calc={self._parameters_port.ticket()},
        )

    @property
    def table(self) -> ComputationTable:
        return self._table

    @property
    def power_offset(self) -> float:
        """ΔP [W]."""
        return self._offset

    def _TablePower(self, context: Context) -> float:
        c = self._parameters_port.Eval(context)
        if not np.all(np.isfinite(c)):
            raise ValueError(f"ComputationLoad: computation_parameters not finite: {c}")
        return self._table.power(c)

    def _CalcPower(self, context: Context, output: BasicVector) -> None:
        g = self._TablePower(context)
        output.SetAtIndex(0, g + self._offset if self._offset != 0.0 else g)

    def _CalcTablePower(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self._TablePower(context))
