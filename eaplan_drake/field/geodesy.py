"""WGS84 longitude/latitude ↔ a local east-north frame [m] about a stated origin.

The local frame is the azimuthal equidistant projection of the WGS84 ellipsoid centred on the
origin (pyproj, ``+proj=aeqd``): x points east and y north at the origin, and the distance and
the azimuth from the origin to every point are the geodesic ones. Over a field of a few
kilometres it differs from the east-north plane of the local tangent frame (ENU) by less than
a millimetre, and unlike ENU it is exactly invertible without a height.

Angles in degrees (longitude λ, latitude φ), distances in metres.
"""

import dataclasses as dc
import functools
import importlib
import math

import numpy as np

from eaplan_drake.errors import MissingExtraError

__all__ = ["FIELD_EXTRA", "LocalFrame", "Require"]

FIELD_EXTRA = "pip install 'eaplan-drake[field]' (shapely, pyproj)"
"""How to install what reading and decomposing fields needs."""


def Require(module: str):
    """``importlib.import_module(module)``, or :class:`~eaplan_drake.errors.MissingExtraError`
    in one line naming the ``[field]`` extra when it is not installed."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(
            f"fields need {module.split('.')[0]}, from the [field] extra: {FIELD_EXTRA}"
        ) from None


@functools.lru_cache(maxsize=16)
def _Transformers(lon0: float, lat0: float):
    pyproj = Require("pyproj")
    local = pyproj.CRS.from_proj4(
        f"+proj=aeqd +lat_0={lat0!r} +lon_0={lon0!r} +x_0=0 +y_0=0 +datum=WGS84 +units=m"
    )
    wgs84 = pyproj.CRS.from_epsg(4326)
    forward = pyproj.Transformer.from_crs(wgs84, local, always_xy=True)
    inverse = pyproj.Transformer.from_crs(local, wgs84, always_xy=True)
    return forward, inverse


@dc.dataclass(frozen=True)
class LocalFrame:
    """The local east-north frame about ``origin`` = (λ0, φ0) [deg]."""

    lon: float
    """λ0, the origin's longitude [deg], in [−180, 180]."""
    lat: float
    """φ0, the origin's latitude [deg], in [−90, 90]."""

    def __post_init__(self):
        for name, value, bound in (("longitude", self.lon, 180.0), ("latitude", self.lat, 90.0)):
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise ValueError(f"origin {name}: must be a finite number [deg], got {value!r}")
            if abs(value) > bound:
                raise ValueError(
                    f"origin {name}: must be in [-{bound:g}, {bound:g}] deg, got {value!r}"
                )

    def ToLocal(self, lonlat) -> np.ndarray:
        """(n, 2) east, north [m] of the (n, 2) points (λ, φ) [deg]."""
        ll = np.atleast_2d(np.asarray(lonlat, dtype=float))
        forward, _ = _Transformers(float(self.lon), float(self.lat))
        x, y = forward.transform(ll[:, 0], ll[:, 1])
        return np.column_stack([x, y])

    def ToLonLat(self, xy) -> np.ndarray:
        """(n, 2) points (λ, φ) [deg] of the (n, 2) east, north [m]."""
        p = np.atleast_2d(np.asarray(xy, dtype=float))
        _, inverse = _Transformers(float(self.lon), float(self.lat))
        lon, lat = inverse.transform(p[:, 0], p[:, 1])
        return np.column_stack([lon, lat])
