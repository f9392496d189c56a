"""Reading fields: GeoJSON, KML and QGroundControl plans into the local east-north frame, against
squares of known size built with geodesics, and one line for every bad file."""

import json

import numpy as np
import pytest

pytest.importorskip("shapely")
pyproj = pytest.importorskip("pyproj")

from eaplan_drake.field.geodesy import LocalFrame  # noqa: E402
from eaplan_drake.field.readers import FieldError, ReadField  # noqa: E402

GEOD = pyproj.Geod(ellps="WGS84")
LON0, LAT0 = 10.3250, 55.4720  # a farm area on Funen (illustrative)


def Offset(lon, lat, east, north):
    """(λ, φ) [deg] reached from (lon, lat) by ``north`` m due north then ``east`` m due east."""
    lon1, lat1, _ = GEOD.fwd(lon, lat, 0.0, north)
    lon2, lat2, _ = GEOD.fwd(lon1, lat1, 90.0, east)
    return [lon2, lat2]


def Square(side, lon=LON0, lat=LAT0):
    """Corners (λ, φ) of a square of geodesic ``side`` [m], counter-clockwise from SW."""
    return [[lon, lat], Offset(lon, lat, side, 0), Offset(lon, lat, side, side),
            Offset(lon, lat, 0, side)]  # fmt: skip


def Closed(ring):
    return [*ring, ring[0]]


def SideLengths(ring):
    return np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)


def WriteGeoJson(tmp_path, obj, name="field.geojson"):
    path = tmp_path / name
    path.write_text(json.dumps(obj))
    return path


def test_local_frame_round_trips_and_puts_the_origin_at_zero():
    frame = LocalFrame(LON0, LAT0)
    ll = np.array([[LON0, LAT0], Offset(LON0, LAT0, 300.0, -150.0)])
    xy = frame.ToLocal(ll)
    np.testing.assert_allclose(xy[0], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(xy[1], [300.0, -150.0], atol=0.05)
    np.testing.assert_allclose(frame.ToLonLat(xy), ll, atol=1e-10)


def test_a_geojson_square_has_its_geodesic_side_lengths_and_area(tmp_path):
    data = {"type": "Polygon", "coordinates": [Closed(Square(200.0))]}
    field = ReadField(WriteGeoJson(tmp_path, data))
    np.testing.assert_allclose(field.exterior[0], [0.0, 0.0], atol=1e-9)  # origin: vertex 0
    np.testing.assert_allclose(SideLengths(field.exterior), 200.0, atol=0.1)
    assert field.area == pytest.approx(200.0 * 200.0, rel=1e-3)
    assert field.notes == ()


def test_a_hole_survives_with_its_winding_and_area(tmp_path):
    outer = Square(300.0)
    hole = Square(50.0, *Offset(LON0, LAT0, 100.0, 100.0))
    data = {
        "type": "Feature",
        "properties": {},
        "geometry": {"type": "Polygon", "coordinates": [Closed(outer), Closed(hole[::-1])]},
    }
    field = ReadField(WriteGeoJson(tmp_path, data))
    assert len(field.holes) == 1
    np.testing.assert_allclose(SideLengths(field.holes[0]), 50.0, atol=0.1)
    assert field.area == pytest.approx(300.0**2 - 50.0**2, rel=1e-3)
    assert field.Polygon().is_valid


def test_the_origin_can_be_stated(tmp_path):
    ring = Square(100.0)
    origin = Offset(LON0, LAT0, -40.0, -60.0)
    path = WriteGeoJson(tmp_path, {"type": "Polygon", "coordinates": [Closed(ring)]})
    field = ReadField(path, origin=origin)
    np.testing.assert_allclose(field.exterior[0], [40.0, 60.0], atol=0.05)


def test_clockwise_rings_are_reversed_and_said(tmp_path):
    ring = Square(100.0)[::-1]
    path = WriteGeoJson(tmp_path, {"type": "Polygon", "coordinates": [Closed(ring)]})
    field = ReadField(path)
    assert "exterior ring was clockwise: reversed" in field.notes
    x, y = field.exterior[:, 0], field.exterior[:, 1]
    assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0.0  # counter-clockwise


def test_a_multipolygon_needs_an_index_and_then_picks_it(tmp_path):
    small, big = Square(100.0), Square(250.0, *Offset(LON0, LAT0, 500.0, 0.0))
    data = {"type": "MultiPolygon", "coordinates": [[Closed(small)], [Closed(big)]]}
    path = WriteGeoJson(tmp_path, data)
    with pytest.raises(FieldError, match=r"2 polygons .*choose one .*0\.\.1") as e:
        ReadField(path)
    assert str(path) in str(e.value) and "\n" not in str(e.value)
    np.testing.assert_allclose(SideLengths(ReadField(path, index=1).exterior), 250.0, atol=0.1)
    with pytest.raises(FieldError, match=r"index must be in 0\.\.1, got 2"):
        ReadField(path, index=2)


def test_a_feature_collection_skips_points_and_reads_its_polygon(tmp_path):
    data = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": [LON0, LAT0]}},
            {"type": "Feature", "geometry": json.loads(Poly(Closed(Square(80.0))))},
        ],
    }
    field = ReadField(WriteGeoJson(tmp_path, data))
    assert "features[1].geometry" in field.source
    np.testing.assert_allclose(SideLengths(field.exterior), 80.0, atol=0.1)


KML = """<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2">
  <Document><Placemark><name>field</name>
    <Polygon>
      <outerBoundaryIs><LinearRing><coordinates>{outer}</coordinates></LinearRing></outerBoundaryIs>
      <innerBoundaryIs><LinearRing><coordinates>{inner}</coordinates></LinearRing></innerBoundaryIs>
    </Polygon>
  </Placemark></Document>
</kml>
"""


def KmlRing(ring):
    return " ".join(f"{lon:.10f},{lat:.10f},0" for lon, lat in Closed(ring))


def test_a_kml_polygon_with_an_inner_boundary(tmp_path):
    outer, hole = Square(300.0), Square(40.0, *Offset(LON0, LAT0, 150.0, 150.0))
    path = tmp_path / "field.kml"
    path.write_text(KML.format(outer=KmlRing(outer), inner=KmlRing(hole)))
    field = ReadField(path)
    np.testing.assert_allclose(SideLengths(field.exterior), 300.0, atol=0.1)
    np.testing.assert_allclose(SideLengths(field.holes[0]), 40.0, atol=0.1)
    assert "line 4" in field.source


def Plan(survey=None, fences=()):
    items = [{"type": "SimpleItem", "command": 22, "params": [0] * 7, "frame": 3}]
    if survey is not None:
        items.append({"type": "ComplexItem", "complexItemType": "survey", "version": 5,
                      "polygon": [[lat, lon] for lon, lat in survey]})  # fmt: skip
    return {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {"items": items, "version": 2},
        "geoFence": {
            "version": 2,
            "circles": [],
            "polygons": [
                {"inclusion": inc, "polygon": [[lat, lon] for lon, lat in ring], "version": 1}
                for inc, ring in fences
            ],
        },
        "rallyPoints": {"points": [], "version": 2},
    }


def test_a_qgc_plan_survey_polygon_in_latitude_longitude_order(tmp_path):
    path = tmp_path / "survey.plan"
    path.write_text(json.dumps(Plan(survey=Square(150.0))))
    field = ReadField(path)
    np.testing.assert_allclose(SideLengths(field.exterior), 150.0, atol=0.1)
    assert "mission.items[1].polygon (survey)" in field.source


def test_a_qgc_plan_geofence_with_an_exclusion_hole(tmp_path):
    outer, hole = Square(300.0), Square(60.0, *Offset(LON0, LAT0, 100.0, 100.0))
    path = tmp_path / "fence.plan"
    path.write_text(json.dumps(Plan(fences=[(True, outer), (False, hole)])))
    field = ReadField(path)
    assert len(field.holes) == 1
    assert field.area == pytest.approx(300.0**2 - 60.0**2, rel=1e-3)


def Poly(coordinates, **extra):
    return json.dumps({"type": "Polygon", "coordinates": [coordinates], **extra})


BOWTIE = [[LON0, LAT0], [LON0 + 0.01, LAT0 + 0.01], [LON0 + 0.01, LAT0], [LON0, LAT0 + 0.01]]
UTM = [[590000, 6150000], [590100, 6150000], [590100, 6150100]]
CRS = {"crs": {"type": "name", "properties": {"name": "EPSG:25832"}}}
BAD_FILES = [
    ("a.geojson", '{"type": "Polygon",\n "coordinates": [[[1, 2]]', r"a\.geojson:2:\d+: not JSON"),
    ("b.geojson", json.dumps({"type": "LineString", "coordinates": [[0, 0]]}), "not a polygon"),
    ("c.geojson", Poly(Closed(BOWTIE)), "not a valid polygon: Self-intersection near lon"),
    ("d.geojson", Poly([[0, 0], [1, 0], [1, 1]], **CRS), "crs: 'EPSG:25832' is not WGS84"),
    ("e.geojson", Poly(UTM), "not WGS84 lon/lat"),
    ("f.geojson", Poly([[LON0, LAT0], [LON0, LAT0], [LON0 + 1e-3, LAT0]]), "2 distinct vertices"),
    ("g.kml", "<kml><Polygon><outerBoundaryIs></Polygon></kml>", r"g\.kml:1:\d+: not XML"),
    ("h.kml", "<kml>\n<a>\n<Polygon><innerBoundaryIs/></Polygon></a></kml>", r"h\.kml:3:1: Poly"),
    ("i.plan", json.dumps({"fileType": "Plan", "mission": {"items": []}}), "no survey polygon"),
    ("j.plan", json.dumps({"fileType": "Mission"}), "not a QGroundControl plan"),
    ("k.shp", "", r"unknown field format '\.shp'"),
    (
        "l.geojson",
        Poly([[str(LON0), str(LAT0)], [LON0 + 1e-3, LAT0], [LON0, LAT0 + 1e-3]]),
        r"position 0: needs two numbers, got \['",
    ),
]


@pytest.mark.parametrize(("name", "text", "message"), BAD_FILES)
def test_a_bad_file_is_one_line_naming_it(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(FieldError, match=message) as e:
        ReadField(path)
    assert str(e.value).startswith(str(path)) and "\n" not in str(e.value)


def test_a_field_narrower_than_one_line_is_refused(tmp_path):
    ring = [[LON0, LAT0], Offset(LON0, LAT0, 500.0, 0.0), Offset(LON0, LAT0, 500.0, 4.0),
            Offset(LON0, LAT0, 0.0, 4.0)]  # fmt: skip
    path = WriteGeoJson(tmp_path, {"type": "Polygon", "coordinates": [Closed(ring)]})
    with pytest.raises(FieldError, match=r"too small for one survey line: 4\.00 m .* 10 m"):
        ReadField(path, min_width=10.0)


def test_without_the_field_extra_reading_is_one_line_naming_it(tmp_path, monkeypatch, capsys):
    import sys

    from eaplan_drake.cli import main
    from eaplan_drake.errors import MissingExtraError

    path = WriteGeoJson(tmp_path, {"type": "Polygon", "coordinates": [Closed(Square(100.0))]})
    monkeypatch.setitem(sys.modules, "shapely", None)  # import shapely now raises ImportError
    with pytest.raises(MissingExtraError, match=r"fields need shapely, from the \[field\] extra"):
        ReadField(path)
    assert main(["plan", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith("eaplan-drake: missing extra: fields need shapely") and err.count("\n") == 1
    )
