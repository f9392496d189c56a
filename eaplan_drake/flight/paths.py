"""Implicit path functions φ(p) for lines and circles (paper 001 Def. II.1, paper 003 Def. II.3).

Every path is the zero set of one quadratic form over the plane,

    φ(p) = a ‖p‖² + bᵀp + c,      ∇φ(p) = 2a p + b,      ∇²φ = 2a I,

with a = 0 for a line and a ≠ 0 for a circle. We keep φ *normalised* so that ‖∇φ‖ = 1 on the
path, i.e. φ is (to first order) the signed distance [m]:

- line through p0 with unit normal n:  φ = nᵀ(p − p0)                (a = 0, b = n, c = −nᵀp0)
- circle, centre o, radius R:           φ = (‖p − o‖² − R²) / (2R)   (a = 1/(2R), b = −o/R, ...)

Together with the direction of travel s = ±1 and the field gain k_e, the path travels on a
Drake vector port as the fixed-length *descriptor* ``[a, b_x, b_y, c, s, k_e]`` (DESCRIPTOR_SIZE).
The direction of travel is the one of the guiding vector field's tangent s·E∇φ with
E = [[0, 1], [−1, 0]]: for a circle s = +1 is clockwise, s = −1 counter-clockwise; for the line
φ = x − x0 (n = +x), s = +1 travels towards −y.
"""

import dataclasses as dc
import math

import numpy as np

__all__ = [
    "DESCRIPTOR_SIZE",
    "E",
    "PathFunction",
    "Circle",
    "Line",
]

DESCRIPTOR_SIZE = 6
"""Length of a path descriptor ``[a, b_x, b_y, c, s, k_e]``."""

E = np.array([[0.0, 1.0], [-1.0, 0.0]])
"""Rotation by −90° used in the guiding vector field ṗ_d = s E∇φ − k_e φ ∇φ."""


@dc.dataclass(frozen=True)
class PathFunction:
    """φ(p) = a‖p‖² + bᵀp + c with direction s = ±1 and field gain k_e [1/m].

    Use :func:`Line` and :func:`Circle` to build one normalised (‖∇φ‖ = 1 on the path).
    """

    a: float
    b: tuple[float, float]
    c: float
    s: float = 1.0
    k_e: float = dc.field(kw_only=True)
    """Field gain k_e [1/m] (``GuidanceParams.k_e`` of the scenario; no default here)."""

    def __post_init__(self):
        values = [self.a, *self.b, self.c, self.s, self.k_e]
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"PathFunction: coefficients must be finite, got {values}")
        if self.s not in (-1.0, 1.0):
            raise ValueError(f"PathFunction.s (direction) must be +1 or -1, got {self.s}")
        if self.a == 0.0 and math.hypot(*self.b) == 0.0:
            raise ValueError("PathFunction: a line needs a non-zero normal b")

    @property
    def is_circle(self) -> bool:
        return self.a != 0.0

    @property
    def center(self) -> np.ndarray:
        """Centre o = −b / (2a) of a circle [m]."""
        if not self.is_circle:
            raise ValueError("PathFunction.center: a line has no centre")
        return -np.asarray(self.b) / (2.0 * self.a)

    @property
    def radius(self) -> float:
        """Radius R of a circle [m] (φ = a(‖p − o‖² − R²))."""
        o = self.center
        r2 = float(o @ o) - self.c / self.a
        if r2 <= 0.0:
            raise ValueError("PathFunction.radius: the quadratic form has no real circle")
        return float(np.sqrt(r2))

    def value(self, p) -> float:
        """φ(p) [m]."""
        p = np.asarray(p, dtype=float)
        return float(self.a * (p @ p) + np.dot(self.b, p) + self.c)

    def gradient(self, p) -> np.ndarray:
        """∇φ(p) [-]."""
        return 2.0 * self.a * np.asarray(p, dtype=float) + np.asarray(self.b)

    def hessian(self, p=None) -> np.ndarray:
        """∇²φ = 2a I [1/m] (constant)."""
        return 2.0 * self.a * np.eye(2)

    def tangent(self, p) -> np.ndarray:
        """Direction of travel s E∇φ(p) (not normalised)."""
        return self.s * E @ self.gradient(p)

    def descriptor(self) -> np.ndarray:
        """``[a, b_x, b_y, c, s, k_e]`` for a Drake vector port."""
        return np.array([self.a, self.b[0], self.b[1], self.c, self.s, self.k_e])

    @staticmethod
    def FromDescriptor(d) -> "PathFunction":
        d = np.asarray(d, dtype=float).reshape(-1)
        if d.size != DESCRIPTOR_SIZE:
            raise ValueError(f"path descriptor must have {DESCRIPTOR_SIZE} entries, got {d.size}")
        return PathFunction(a=d[0], b=(d[1], d[2]), c=d[3], s=d[4], k_e=d[5])

    def normalised(self) -> "PathFunction":
        """The same zero set and direction with ‖∇φ‖ = 1 on the path (scaling by a positive
        factor keeps the side the field converges from)."""
        if self.is_circle:
            scale = 1.0 / (2.0 * abs(self.a) * self.radius)
        else:
            scale = 1.0 / float(np.hypot(*self.b))
        return dc.replace(
            self,
            a=self.a * scale,
            b=(self.b[0] * scale, self.b[1] * scale),
            c=self.c * scale,
        )


def Line(point, normal, s: float = 1.0, *, k_e: float) -> PathFunction:
    """The line through ``point`` [m] with normal ``normal`` (normalised here): φ = nᵀ(p − p0);
    direction s = ±1, field gain ``k_e`` [1/m]."""
    n = np.asarray(normal, dtype=float)
    norm = float(np.hypot(*n))
    if not np.isfinite(norm) or norm == 0.0:
        raise ValueError(f"Line: normal must be a finite non-zero 2-vector, got {normal}")
    n = n / norm
    p0 = np.asarray(point, dtype=float)
    return PathFunction(a=0.0, b=(float(n[0]), float(n[1])), c=-float(n @ p0), s=s, k_e=k_e)


def Circle(center, radius: float, s: float = 1.0, *, k_e: float) -> PathFunction:
    """The circle of ``radius`` [m] around ``center`` [m]: φ = (‖p − o‖² − R²) / (2R);
    direction s = ±1, field gain ``k_e`` [1/m]."""
    if not np.isfinite(radius) or radius <= 0.0:
        raise ValueError(f"Circle: radius must be > 0 m, got {radius}")
    o = np.asarray(center, dtype=float)
    a = 1.0 / (2.0 * radius)
    return PathFunction(
        a=a,
        b=(float(-2.0 * a * o[0]), float(-2.0 * a * o[1])),
        c=float(a * (o @ o - radius**2)),
        s=s,
        k_e=k_e,
    )
