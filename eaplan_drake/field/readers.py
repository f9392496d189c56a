"""Reading a field (a polygon with holes, WGS84) from GeoJSON, KML or a QGroundControl plan.

:func:`ReadField` picks the reader by the file's suffix:

- ``.geojson``, ``.json``: GeoJSON (RFC 7946) ``Polygon``, ``MultiPolygon``, ``Feature``,
  ``FeatureCollection`` or ``GeometryCollection``; positions are (λ, φ[, h]) [deg, deg, m];
  interior rings are holes. A legacy ``crs`` member must name WGS84 longitude/latitude
  (``urn:ogc:def:crs:OGC:1.3:CRS84``, ``EPSG:4326``); any other CRS is refused.
- ``.kml``: every ``<Polygon>``: ``outerBoundaryIs`` and ``innerBoundaryIs`` ``LinearRing`` s,
  ``<coordinates>`` as ``λ,φ[,h]`` tuples (KML is always WGS84).
- ``.plan``: a QGroundControl plan (JSON, ``"fileType": "Plan"``): the polygon of each survey
  complex item (``mission.items[i]``, ``"complexItemType": "survey"``, ``"polygon": [[φ, λ],
  …]``), else the inclusion polygons of the geofence (``geoFence.polygons[i]``, version 2).
  Exclusion geofence polygons inside the chosen polygon become its holes.

A file with several polygons needs ``index`` (0-based, in file order) to choose one. The chosen
polygon is converted to the local east-north frame [m] of ``origin`` (λ0, φ0) [deg] (default: its
first vertex, :class:`~eaplan_drake.field.geodesy.LocalFrame`) and checked: at least three
distinct vertices, a valid polygon (no self-intersection, holes inside and apart), and at least
``min_width`` [m] wide across its narrowest direction. A ring wound the wrong way is **corrected**
(exterior counter-clockwise, holes clockwise) and said in :attr:`Field.notes`; a closing vertex
that repeats the first, and repeated consecutive vertices, are dropped.

Every problem is one :class:`FieldError` line naming the file (``file:line:col`` where the
parser gives it, else the JSON path or KML element) and the reason.
"""

import dataclasses as dc
import json
import math
import xml.parsers.expat
from pathlib import Path

import numpy as np

from eaplan_drake.field.geodesy import LocalFrame, Require
from eaplan_drake.files import MissingFile, ReadTextFile

__all__ = [
    "FIELD_SUFFIXES",
    "Field",
    "FieldError",
    "FieldGeoJsonText",
    "FieldFromLocal",
    "FieldFromLonLat",
    "MAX_FIELD_BYTES",
    "MAX_FIELD_VERTICES",
    "ReadField",
    "ReadFieldRings",
]

MAX_FIELD_BYTES = 20_000_000
"""Largest field file [bytes]."""
MAX_FIELD_VERTICES = 10_000
"""Most vertices of the chosen polygon, holes included [-]."""
FIELD_SUFFIXES = {".geojson": "geojson", ".json": "geojson", ".kml": "kml", ".plan": "qgc_plan"}
"""File suffix → reader."""

_WGS84_CRS = {
    "urn:ogc:def:crs:ogc:1.3:crs84",
    "urn:ogc:def:crs:ogc::crs84",
    "crs84",
    "ogc:crs84",
    "epsg:4326",
    "urn:ogc:def:crs:epsg::4326",
    "urn:ogc:def:crs:epsg:6.6:4326",
    "http://www.opengis.net/def/crs/ogc/1.3/crs84",
    "http://www.opengis.net/def/crs/epsg/0/4326",
}


class FieldError(ValueError):
    """A field file that cannot be used; the message is one line naming the file and why."""


@dc.dataclass(frozen=True)
class Field:
    """A survey field in the local east-north frame of :attr:`frame`."""

    exterior: np.ndarray
    """(n, 2) vertices of the outer boundary, east, north [m], counter-clockwise, not closed."""
    holes: tuple[np.ndarray, ...]
    """Each (m, 2) vertices of a hole [m], clockwise, not closed."""
    frame: LocalFrame
    """The origin (λ0, φ0) [deg] of the local frame."""
    source: str = ""
    """Where it was read: file and polygon (one line)."""
    notes: tuple[str, ...] = ()
    """What was corrected on reading (winding, repeated vertices), one line each."""

    def Polygon(self):
        """The field as a ``shapely.Polygon`` [m]."""
        shapely = Require("shapely")
        return shapely.Polygon(self.exterior, [h for h in self.holes])

    @property
    def area(self) -> float:
        """Area [m²] (holes excluded)."""
        return float(self.Polygon().area)

    def ExteriorLonLat(self) -> np.ndarray:
        """(n, 2) outer boundary as (λ, φ) [deg]."""
        return self.frame.ToLonLat(self.exterior)

    def HolesLonLat(self) -> list[np.ndarray]:
        """The holes as (λ, φ) [deg]."""
        return [self.frame.ToLonLat(h) for h in self.holes]


def _Err(where: str, message: str) -> FieldError:
    return FieldError(f"{where}: {message}")


def _CleanRing(ring, where: str, what: str) -> tuple[np.ndarray, int]:
    """(k, 2) float ring without the closing vertex and repeated consecutive vertices, and the
    number of vertices dropped."""
    try:
        pairs = [p[:2] for p in ring]
    except (TypeError, IndexError):
        raise _Err(where, f"{what}: every position needs two numbers") from None
    for i, pair in enumerate(pairs):  # RFC 7946: positions are numbers, never strings
        if len(pair) < 2 or not all(
            isinstance(c, int | float) and not isinstance(c, bool) for c in pair
        ):
            raise _Err(where, f"{what}: position {i}: needs two numbers, got {pair!r}")
    points = np.array(pairs, dtype=float).reshape(-1, 2)
    if points.ndim != 2 or points.shape[0] == 0:
        raise _Err(where, f"{what}: no positions")
    if not np.all(np.isfinite(points)):
        raise _Err(where, f"{what}: a coordinate is not a finite number")
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.any(np.diff(points, axis=0) != 0.0, axis=1)
    cleaned = points[keep]
    if len(cleaned) > 1 and np.array_equal(cleaned[0], cleaned[-1]):
        cleaned = cleaned[:-1]
    if len(cleaned) < 3:
        raise _Err(where, f"{what}: {len(cleaned)} distinct vertices, a polygon needs at least 3")
    dropped = len(points) - len(cleaned) - (1 if np.array_equal(points[0], points[-1]) else 0)
    return cleaned, dropped


def _SignedArea(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def FieldFromLocal(
    exterior,
    holes=(),
    frame: LocalFrame | None = None,
    *,
    where: str = "field",
    min_width: float = 0.0,
    source: str = "",
    notes=(),
) -> Field:
    """A checked :class:`Field` from rings already in the local frame [m] (``frame`` default:
    the origin at (0, 0) deg). Winding is corrected (and said in the notes), the polygon must be
    valid and at least ``min_width`` [m] wide; otherwise a :class:`FieldError` naming ``where``."""
    shapely = Require("shapely")
    notes = list(notes)
    ext, dropped = _CleanRing(exterior, where, "exterior ring")
    rings = [ext]
    for j, h in enumerate(holes):
        ring, d = _CleanRing(h, where, f"hole {j}")
        dropped += d
        rings.append(ring)
    if dropped:
        notes.append(f"{dropped} repeated vertices dropped")
    if sum(len(r) for r in rings) > MAX_FIELD_VERTICES:
        raise _Err(where, f"more than {MAX_FIELD_VERTICES} vertices")
    for j, ring in enumerate(rings):
        area = _SignedArea(ring)
        want_ccw = j == 0
        if area == 0.0:
            raise _Err(where, f"{'exterior ring' if j == 0 else f'hole {j - 1}'} has zero area")
        if (area > 0.0) != want_ccw:
            rings[j] = ring[::-1].copy()
            notes.append(
                ("exterior ring was clockwise" if j == 0 else f"hole {j - 1} was counter-clockwise")
                + ": reversed"
            )
    polygon = shapely.Polygon(rings[0], rings[1:])
    if not polygon.is_valid:
        reason = shapely.is_valid_reason(polygon)
        text, _, at = reason.partition("[")
        if at and frame is not None:
            try:
                x, y = (float(v) for v in at.rstrip("]").split())
                lon, lat = frame.ToLonLat([[x, y]])[0]
                text = f"{text.strip()} near lon {lon:.6f}, lat {lat:.6f}"
            except ValueError:
                text = reason
        raise _Err(where, f"not a valid polygon: {text.strip()}")
    if min_width > 0.0:
        width = MinimumWidth(polygon)
        if width < min_width:
            raise _Err(
                where,
                f"too small for one survey line: {width:.2f} m across its narrowest direction, "
                f"needs at least the line spacing {min_width:g} m",
            )
    return Field(
        exterior=rings[0],
        holes=tuple(rings[1:]),
        frame=frame or LocalFrame(0.0, 0.0),
        source=source or where,
        notes=tuple(notes),
    )


def MinimumWidth(polygon) -> float:
    """The polygon's width [m] across its narrowest direction (that of its convex hull: the
    smallest distance between two parallel lines that enclose it)."""
    hull = np.asarray(polygon.convex_hull.exterior.coords)[:-1]
    best = math.inf
    for i in range(len(hull)):
        edge = hull[(i + 1) % len(hull)] - hull[i]
        normal = np.array([-edge[1], edge[0]]) / np.hypot(*edge)
        d = (hull - hull[i]) @ normal
        best = min(best, float(d.max() - d.min()))
    return best


def FieldFromLonLat(
    exterior,
    holes=(),
    origin=None,
    *,
    where: str = "field",
    min_width: float = 0.0,
    source: str = "",
) -> Field:
    """A checked :class:`Field` from rings of (λ, φ) [deg]; ``origin`` (λ0, φ0) [deg] of the local
    frame (default: the first vertex of the exterior)."""
    ext, _ = _CleanRing(exterior, where, "exterior ring")
    rings = [ext] + [_CleanRing(h, where, f"hole {j}")[0] for j, h in enumerate(holes)]
    for j, ring in enumerate(rings):
        if np.any(np.abs(ring[:, 0]) > 180.0) or np.any(np.abs(ring[:, 1]) > 90.0):
            what = "exterior ring" if j == 0 else f"hole {j - 1}"
            raise _Err(
                where,
                f"{what}: coordinates outside longitude [-180, 180], latitude [-90, 90] deg "
                f"(e.g. {ring[0, 0]:g}, {ring[0, 1]:g}): not WGS84 lon/lat (a projected CRS?)",
            )
    frame = LocalFrame(*(float(v) for v in (origin if origin is not None else ext[0])))
    return FieldFromLocal(
        frame.ToLocal(exterior),
        [frame.ToLocal(h) for h in holes],
        frame,
        where=where,
        min_width=min_width,
        source=source or where,
    )


def FieldGeoJsonText(field: Field) -> str:
    """``field`` as a GeoJSON (RFC 7946) ``Polygon`` in WGS84 longitude/latitude, rings closed
    and holes as interior rings: what :func:`ReadField` reads back."""
    rings = [field.ExteriorLonLat(), *field.HolesLonLat()]
    closed = [np.vstack((r, r[:1])).tolist() for r in rings]
    return json.dumps({"type": "Polygon", "coordinates": closed})


def ReadField(path, *, index: int | None = None, origin=None, min_width: float = 0.0) -> Field:
    """The field in ``path`` (GeoJSON, KML or QGroundControl plan, by suffix; see the module
    docstring): polygon ``index`` of several (0-based), in the local frame of ``origin``
    (λ0, φ0) [deg] (default: its first vertex), at least ``min_width`` [m] wide."""
    path = Path(path)
    rings, where = ReadFieldRings(path, index=index)
    exterior, holes = rings
    return FieldFromLonLat(exterior, holes, origin, where=where, min_width=min_width)


def ReadFieldRings(path, *, index: int | None = None):
    """((exterior, holes), where): the chosen polygon's rings as (λ, φ) [deg] lists and the
    one-line name of where it was found, without any check but the format's."""
    path = Path(path)
    kind = FIELD_SUFFIXES.get(path.suffix.lower())
    if kind is None:
        raise FieldError(
            f"{path}: unknown field format {path.suffix!r} (allowed: {', '.join(FIELD_SUFFIXES)})"
        )
    if MissingFile(path):
        raise FieldError(f"{path}: {MissingFile(path)}")
    text = ReadTextFile(path, MAX_FIELD_BYTES, FieldError)
    if kind == "kml":
        polygons = _KmlPolygons(path, text)
    else:
        data = _Json(path, text)
        polygons = _GeoJsonPolygons(path, data) if kind == "geojson" else _PlanPolygons(path, data)
    if not polygons:
        raise FieldError(f"{path}: no polygon in the file")
    if index is None:
        if len(polygons) > 1:
            names = "; ".join(f"{i}: {w}" for i, (_, w) in enumerate(polygons[:5]))
            more = ", …" if len(polygons) > 5 else ""
            raise FieldError(
                f"{path}: {len(polygons)} polygons ({names}{more}): choose one by its index "
                f"(plan --polygon N, or coverage.field_polygon: N, N in 0..{len(polygons) - 1})"
            )
        index = 0
    if not (isinstance(index, int) and 0 <= index < len(polygons)):
        raise FieldError(f"{path}: polygon index must be in 0..{len(polygons) - 1}, got {index!r}")
    rings, what = polygons[index]
    return rings, f"{path}: {what}"


def _Json(path: Path, text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise FieldError(f"{path}:{e.lineno}:{e.colno}: not JSON: {e.msg}") from None
    except RecursionError:
        raise FieldError(f"{path}: JSON nested too deeply") from None


def _Crs(path: Path, data, where: str) -> None:
    crs = data.get("crs") if isinstance(data, dict) else None
    if crs is None:
        return
    name = crs.get("properties", {}).get("name") if isinstance(crs, dict) else None
    if not isinstance(name, str) or name.strip().lower() not in _WGS84_CRS:
        shown = name if isinstance(name, str) else json.dumps(crs)[:60]
        raise FieldError(
            f"{path}: {where}crs: {shown!r} is not WGS84 longitude/latitude (allowed: "
            "urn:ogc:def:crs:OGC:1.3:CRS84, EPSG:4326; reproject the file to WGS84)"
        )


def _GeoJsonPolygons(path: Path, data) -> list:
    """[((exterior, holes), where)] of every polygon in a GeoJSON object, in file order."""
    out = []

    def rings(coords, where):
        if not (isinstance(coords, list) and coords and all(isinstance(r, list) for r in coords)):
            raise FieldError(f"{path}: {where}.coordinates: a polygon needs a list of rings")
        return (coords[0], coords[1:])

    def walk(obj, where):
        if not isinstance(obj, dict) or not isinstance(obj.get("type"), str):
            raise FieldError(f"{path}: {where or 'top level'}: not a GeoJSON object (no 'type')")
        _Crs(path, obj, f"{where}." if where else "")
        kind = obj["type"]
        prefix = f"{where}." if where else ""
        if kind == "FeatureCollection":
            features = obj.get("features")
            if not isinstance(features, list):
                raise FieldError(f"{path}: {prefix}features: must be a list")
            for i, f in enumerate(features):
                walk(f, f"{prefix}features[{i}]")
        elif kind == "Feature":
            if obj.get("geometry") is not None:
                walk(obj["geometry"], f"{prefix}geometry")
        elif kind == "GeometryCollection":
            for i, g in enumerate(obj.get("geometries") or []):
                walk(g, f"{prefix}geometries[{i}]")
        elif kind == "Polygon":
            out.append((rings(obj.get("coordinates"), where or "Polygon"), where or "Polygon"))
        elif kind == "MultiPolygon":
            coords = obj.get("coordinates")
            if not isinstance(coords, list):
                raise FieldError(f"{path}: {prefix}coordinates: a MultiPolygon needs a list")
            for i, c in enumerate(coords):
                w = f"{prefix}coordinates[{i}]" if where else f"MultiPolygon[{i}]"
                out.append((rings(c, w), w))
        elif kind in ("Point", "MultiPoint", "LineString", "MultiLineString"):
            pass  # other geometries beside the field (a home point, a track) are skipped
        else:
            raise FieldError(f"{path}: {prefix}type: unknown GeoJSON type {kind!r}")

    walk(data, "")
    if not out and isinstance(data, dict) and data.get("type") in ("Point", "LineString"):
        raise FieldError(f"{path}: a {data['type']}, not a polygon")
    return out


def _PlanPolygons(path: Path, data) -> list:
    """The polygons of a QGroundControl plan: survey complex items first, else inclusion
    geofence polygons; exclusion fences inside become holes. QGC stores [φ, λ]."""
    if not isinstance(data, dict) or data.get("fileType") != "Plan":
        raise FieldError(f'{path}: not a QGroundControl plan (no "fileType": "Plan")')

    def lonlat(points, where):
        if not isinstance(points, list):
            raise FieldError(f"{path}: {where}: must be a list of [latitude, longitude]")
        out = []
        for j, p in enumerate(points):
            if not (isinstance(p, list) and len(p) >= 2):
                raise FieldError(f"{path}: {where}[{j}]: must be [latitude, longitude]")
            out.append([p[1], p[0]])
        return out

    surveys = []
    items = (data.get("mission") or {}).get("items") or []
    for i, item in enumerate(items if isinstance(items, list) else []):
        if isinstance(item, dict) and item.get("type") == "ComplexItem":
            if item.get("complexItemType") in ("survey", "StructureScan") and "polygon" in item:
                where = f"mission.items[{i}].polygon ({item['complexItemType']})"
                surveys.append((lonlat(item["polygon"], f"mission.items[{i}].polygon"), where))
    fence = data.get("geoFence") or {}
    inclusion, exclusion = [], []
    polygons = (fence.get("polygons") or []) if isinstance(fence, dict) else []
    for i, p in enumerate(polygons if isinstance(polygons, list) else []):
        if not isinstance(p, dict):
            raise FieldError(f"{path}: geoFence.polygons[{i}]: must be an object")
        ring = lonlat(p.get("polygon"), f"geoFence.polygons[{i}].polygon")
        target = inclusion if p.get("inclusion", True) else exclusion
        target.append((ring, f"geoFence.polygons[{i}] (inclusion)"))
    chosen = surveys or inclusion
    if not chosen and not exclusion:
        raise FieldError(
            f"{path}: no survey polygon (mission.items[…].polygon) and no geofence polygon"
        )
    shapely = Require("shapely")
    out = []
    for ring, where in chosen:
        try:
            outer = shapely.Polygon(ring)
            holes = [h for h, _ in exclusion if outer.contains(shapely.Polygon(h))]
        except (ValueError, TypeError):
            holes = []
        out.append(
            ((ring, holes), where + (f" with {len(holes)} exclusion holes" if holes else ""))
        )
    return out


class _Node:
    __slots__ = ("tag", "line", "col", "children", "text")

    def __init__(self, tag, line, col):
        self.tag, self.line, self.col, self.children, self.text = tag, line, col, [], []

    def Find(self, tag):
        return [c for c in self.children if c.tag == tag]

    def Iter(self, tag):
        for c in self.children:
            if c.tag == tag:
                yield c
            yield from c.Iter(tag)


def _ParseXml(path: Path, text: str) -> _Node:
    """A minimal element tree with line and column numbers (expat; namespaces dropped)."""
    parser = xml.parsers.expat.ParserCreate(namespace_separator="}")
    root = _Node("", 1, 1)
    stack = [root]

    def start(name, _attrs):
        node = _Node(
            name.rpartition("}")[2], parser.CurrentLineNumber, parser.CurrentColumnNumber + 1
        )
        stack[-1].children.append(node)
        stack.append(node)

    def end(_name):
        stack.pop()

    def chars(data):
        stack[-1].text.append(data)

    def no_entities(*_args):
        raise FieldError(f"{path}:{parser.CurrentLineNumber}: XML entity declarations are refused")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    parser.EntityDeclHandler = no_entities
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError as e:
        raise FieldError(
            f"{path}:{e.lineno}:{e.offset + 1}: not XML: {xml.parsers.expat.ErrorString(e.code)}"
        ) from None
    return root


def _KmlCoordinates(path: Path, ring: _Node, what: str) -> list:
    coords = [c for c in ring.Iter("coordinates")]
    if not coords:
        raise FieldError(f"{path}:{ring.line}:{ring.col}: {what} has no <coordinates>")
    node = coords[0]
    out = []
    for token in "".join(node.text).split():
        cells = token.split(",")
        try:
            out.append([float(cells[0]), float(cells[1])])
        except (ValueError, IndexError):
            raise FieldError(
                f"{path}:{node.line}:{node.col}: {what}: coordinate {token[:40]!r} is not "
                "longitude,latitude[,altitude]"
            ) from None
    return out


def _KmlPolygons(path: Path, text: str) -> list:
    root = _ParseXml(path, text)
    out = []
    for i, polygon in enumerate(root.Iter("Polygon")):
        outer = [r for b in polygon.Find("outerBoundaryIs") for r in b.Find("LinearRing")]
        if len(outer) != 1:
            raise FieldError(
                f"{path}:{polygon.line}:{polygon.col}: Polygon {i} needs one "
                f"<outerBoundaryIs><LinearRing>, has {len(outer)}"
            )
        inner = [r for b in polygon.Find("innerBoundaryIs") for r in b.Find("LinearRing")]
        exterior = _KmlCoordinates(path, outer[0], f"Polygon {i} outer boundary")
        holes = [
            _KmlCoordinates(path, r, f"Polygon {i} inner boundary {j}") for j, r in enumerate(inner)
        ]
        out.append(((exterior, holes), f"Polygon {i} (line {polygon.line})"))
    return out
