"""The drop sizes a flight learns from the drops it detects: the predictive of a Dirichlet process
around the stated size model (:class:`DirichletDrops`), what the mpc's risk reserve prices after
a drop (``planner.fault_model.prior_sizes``; :doc:`/planner`, "The belief in flight").

Plain functions over numpy, deterministic. Sizes are SoC fractions [-]; the grid step h is
:data:`~eaplan_drake.planning.belief.SIZE_RESOLUTION`.
"""

import dataclasses as dc
import functools
import math

import numpy as np

from eaplan_drake.errors import CheckNumber
from eaplan_drake.planning.belief import SIZE_RESOLUTION
from eaplan_drake.planning.risk import EmpiricalDrops, ExponentialDrops, UniformDrops

__all__ = ["DirichletDrops"]


@dc.dataclass(frozen=True)
class DirichletDrops:
    """The predictive of drop sizes learnt from the drops a flight has seen: a Dirichlet process of
    concentration K (``prior_sizes``, the sizes the declared model is worth) around the declared
    point model G_0 (``base``), after the observed sizes x_1..x_k [-]::

        G = (K G_0 + δ_(x_1) + … + δ_(x_k)) / (K + k),

    so each observed size carries the weight of one of K prior sizes, and a size outside G_0's
    support (heavier than the declared bounds) enters the tails at once. Q_n(m) is the n-fold sum
    of sizes rounded up to h = :data:`~eaplan_drake.planning.belief.SIZE_RESOLUTION` (each by
    < h), computed by convolution on that grid (sums beyond 1 SoC kept as one cell):
    Q_n(m) ≤ Q̂_n(m) ≤ Q_n(m − n h), conservative, and exact for sizes on the grid.
    The base's cells are P((j − 1)h < X ≤ jh) from its own Q_1."""

    base: UniformDrops | ExponentialDrops | EmpiricalDrops
    observed: tuple[float, ...]
    prior_sizes: float

    def __post_init__(self):
        if not isinstance(self.base, (UniformDrops, ExponentialDrops, EmpiricalDrops)):
            raise ValueError(
                "DirichletDrops.base: must be UniformDrops, ExponentialDrops or EmpiricalDrops, "
                f"got {type(self.base).__name__}"
            )
        k = CheckNumber(
            "DirichletDrops.prior_sizes", self.prior_sizes, 0.0, 1e6, "[-]", open_low=True
        )
        values = tuple(
            CheckNumber(
                f"DirichletDrops.observed[{i}]", v, 0.0, 1.0, "(SoC fraction)", open_low=True
            )
            for i, v in enumerate(self.observed)
        )
        object.__setattr__(self, "observed", values)
        object.__setattr__(self, "prior_sizes", k)

    @property
    def upper(self) -> float:
        """The largest size [-]."""
        return max((self.base.upper, *self.observed))

    def Cells(self) -> np.ndarray:
        """P(X̂ = jh) for j = 0..J and P(X̂ > Jh) last (J h = 1), X̂ the size rounded up to h."""
        cells = int(round(1.0 / SIZE_RESOLUTION))
        grid = np.arange(cells + 1) * SIZE_RESOLUTION
        below = 1.0 - self.base.sum_tail(1, grid)[:, 1]  # P(X <= jh)
        pmf = np.diff(np.concatenate(([0.0], below, [1.0])))
        k = self.prior_sizes
        pmf *= k / (k + len(self.observed))
        for x in self.observed:
            pmf[min(int(math.ceil(round(x / SIZE_RESOLUTION, 9))), cells)] += 1.0 / (
                k + len(self.observed)
            )
        return np.maximum(pmf, 0.0)

    def sum_tail(self, n_max: int, margin) -> np.ndarray:
        """Q̂_n(m) for n = 0..n_max, shape margin.shape + (n_max + 1,) (class docstring)."""
        m = np.asarray(margin, dtype=float)
        above = _DirichletAbove(self, -(-(int(n_max) + 1) // 16) * 16)  # (levels, cells)
        # P(Ŝ > m) = P(Ŝ >= (⌊m/h⌋ + 1) h): the index of the first grid sum above each margin
        first = np.clip(np.floor(m / SIZE_RESOLUTION).astype(int) + 1, 0, above.shape[1] - 1)
        q = np.moveaxis(above[: n_max + 1, first], 0, -1)
        return np.where(m[..., None] < 0.0, 1.0, np.minimum(q, 1.0))


@functools.lru_cache(maxsize=64)
def _DirichletAbove(sizes: DirichletDrops, levels: int) -> np.ndarray:
    """P(Ŝ_n >= j h) of :class:`DirichletDrops` for n = 0..levels − 1 and the grid cells j (the
    n-fold convolutions, computed once per size model and kept: a flight asks for them at every
    step)."""
    one = sizes.Cells()
    last = one.size - 1  # the cell of sums beyond 1
    sums = np.zeros(one.size)
    sums[0] = 1.0
    above = np.empty((levels, one.size))
    for n in range(levels):
        if n > 0:
            full = np.convolve(sums, one)
            sums = full[: one.size].copy()
            sums[last] += full[one.size :].sum()
        above[n] = np.cumsum(sums[::-1])[::-1]
    above.flags.writeable = False
    return above
