"""Fields from real files: reading WGS84 polygons (GeoJSON, KML, QGroundControl ``.plan``) into a
local east-north frame, decomposing them into convex cells, and writing missions back out.

Needs the ``[field]`` extra (shapely, pyproj); every module imports them lazily through
:func:`eaplan_drake.field.geodesy.Require`.
"""
