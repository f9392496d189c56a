"""A 3-D replay of a flight in Meshcat, saved as one self-contained HTML file.

:func:`SaveFlightReplay` draws a flight log into a Drake ``Meshcat`` recording and writes its
``StaticHtml()``: the page needs no server and no network, and has Meshcat's animation controls
(play, pause, a scrubbable time slider). The scene is drawn in **hectometres** (1 unit = 100 m)
and seen from above: at the survey's scale of a few hundred metres, metres would put everything
beyond the far plane of Meshcat's default camera.

What the scene shows (x, y as in the plots; z up):

- the survey polygon (grey) and the lines of the plan at the initial c1 (thin, dark grey);
- the flown path, revealed as time passes, coloured by the quality ½c̃1 + ½c̃2 on the colour map
  of ``flight.png`` (:data:`~eaplan_drake.output.plot_style.QUALITY_COLORMAP`, viridis: purple = 0,
  yellow = 1);
- the aircraft as a small body and wing, turned to its heading ψ;
- the wind as a dark grey arrow beside the area (length ∝ speed: 1 hm per 10 m/s);
- three bars to the right of the area that follow time: SoC b (green, with the reserve as a cyan
  tick), c̃1 (blue) and c̃2 (orange), each full length at 1 (the colours of ``flight.png``,
  :data:`~eaplan_drake.output.plot_style.COLORS`); and a text line at the top of the page with t, b,
  c̃1 (c1 [m²]) and c̃2 (c2 [table units]) at the slider's time.

The parameters are normalised as in the figures, c̃ = (c − c̲)/(c̄ − c̲) ∈ [0, 1]; the path
parameter c1 = r2² − r² [m²] ≤ 0 (c1 = 0 flies the densest lines).

Drake's Meshcat logs the address it listens on when it is constructed; a replay written to a
file does not need it, so :func:`SaveFlightReplay` lowers the ``drake`` logger to warnings while
it makes its own Meshcat.

``replay.html#t=200`` opens the replay paused at t = 200 s.

The geometry (:func:`ReplayFrames`, :func:`PathChunks`, :func:`ArrowOutline`) is plain numpy
and tested on its own; only :func:`SaveFlightReplay` touches Meshcat.
"""

import contextlib
import json
import logging
from pathlib import Path

import numpy as np

from eaplan_drake.files import AtomicWrite
from eaplan_drake.flightlog import FlightLog, NormalisedParameters, SampleQuality
from eaplan_drake.params import Scenario

__all__ = [
    "ArrowOutline",
    "PathChunks",
    "ReplayFrames",
    "Ribbon",
    "SaveFlightReplay",
    "UNIT",
]

UNIT = 100.0
"""Metres per scene unit (hectometres)."""

_ALTITUDE = 0.05  # [hm] height of the flown path and the aircraft above the ground plane
_BAR_LENGTH = 1.5  # [hm] length of a bar at value 1
_BAR_WIDTH = 0.12  # [hm]


def ReplayFrames(times, frame_rate: float) -> np.ndarray:
    """Indices of the log samples shown at ``frame_rate`` [Hz]: for each frame time
    k / frame_rate in [t_0, t_f], the last sample at or before it (always the first and the
    last sample)."""
    t = np.asarray(times, dtype=float)
    if frame_rate <= 0.0 or not np.isfinite(frame_rate):
        raise ValueError(f"frame_rate: must be > 0 [Hz], got {frame_rate}")
    if t.size == 0:
        return np.zeros(0, dtype=int)
    frames = np.arange(t[0], t[-1] + 1e-9, 1.0 / frame_rate)
    idx = np.clip(np.searchsorted(t, frames + 1e-9, side="right") - 1, 0, t.size - 1)
    return np.unique(np.r_[idx, t.size - 1])


def PathChunks(values, num_colours: int = 8, max_samples: int = 50) -> list[tuple[int, int, int]]:
    """Splits a path into consecutive chunks ``(start, stop, colour)`` (samples start..stop,
    inclusive, so neighbours share a point) over which ``values`` in [0, 1] fall into one of
    ``num_colours`` equal bins, each at most ``max_samples`` samples long."""
    v = np.clip(np.asarray(values, dtype=float), 0.0, 1.0)
    if v.size < 2:
        return []
    bins = np.minimum((v * num_colours).astype(int), num_colours - 1)
    chunks, start = [], 0
    for i in range(1, v.size):
        if bins[i] != bins[start] or i - start >= max_samples or i == v.size - 1:
            chunks.append((start, i, int(bins[start])))
            start = i
    return chunks


def ArrowOutline(length: float, width: float) -> np.ndarray:
    """The 7 corners (7 × 2) of a flat arrow along +x from the origin to ``length``, shaft
    ``width`` wide and head twice as wide and ``2 width`` long (counter-clockwise)."""
    head = min(2.0 * width, 0.6 * length)
    s = length - head
    return np.array(
        [
            [0.0, -width / 2],
            [s, -width / 2],
            [s, -width],
            [length, 0.0],
            [s, width],
            [s, width / 2],
            [0.0, width / 2],
        ]
    )


def Ribbon(points, width: float) -> tuple[np.ndarray, np.ndarray]:
    """A flat strip ``width`` wide along the polyline ``points`` (k × 2, k ≥ 2): vertices
    (2k × 2, left and right of each point along the local normal) and triangles (2(k−1) × 3).
    Lines in WebGL are one pixel wide whatever their width; a strip is not."""
    p = np.asarray(points, dtype=float)
    tangent = np.gradient(p, axis=0)
    norm = np.linalg.norm(tangent, axis=1, keepdims=True)
    tangent = np.divide(tangent, norm, out=np.tile([1.0, 0.0], (len(p), 1)), where=norm > 0)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    vertices = np.empty((2 * len(p), 2))
    vertices[0::2] = p + 0.5 * width * normal
    vertices[1::2] = p - 0.5 * width * normal
    i = 2 * np.arange(len(p) - 1)
    faces = np.vstack([np.column_stack([i, i + 1, i + 2]), np.column_stack([i + 1, i + 3, i + 2])])
    return vertices, faces


def _Rgba(rgb, a=1.0):
    from pydrake.geometry import Rgba

    return Rgba(float(rgb[0]), float(rgb[1]), float(rgb[2]), a)


def _Color(name, a=1.0):
    """The Drake ``Rgba`` of a matplotlib colour name."""
    from matplotlib.colors import to_rgb

    return _Rgba(to_rgb(name), a)


def _Flat(meshcat, path, outline_xy, z, rgba):
    """A flat convex polygon (fan triangulation) at height z."""
    pts = np.asarray(outline_xy, dtype=float)
    vertices = np.vstack([pts.T, np.full(len(pts), z)])
    faces = np.array([[0, i, i + 1] for i in range(1, len(pts) - 1)], dtype=np.int32).T
    meshcat.SetTriangleMesh(path, vertices, faces, rgba)


def _Planned(scenario: Scenario):
    from eaplan_drake.flight.stages import StagePoints
    from eaplan_drake.resolve import MakePlanSource

    c1 = scenario.planner.initial_path_parameters[0]
    plan = MakePlanSource(scenario, initial_c1=c1)
    return [StagePoints(s) for s in plan.Stages(c1)]


@contextlib.contextmanager
def _QuietDrakeLog(level=logging.WARNING):
    """Drake's log messages below ``level`` are dropped inside the block (pydrake routes Drake's
    log through the Python logger ``drake``; setting its level sets Drake's)."""
    logger = logging.getLogger("drake")
    previous = logger.level
    logger.setLevel(max(level, previous))
    try:
        yield
    finally:
        logger.setLevel(previous)


def _OverlayHtml(times, soc, c1, c2, c1n, c2n) -> str:
    """A text line (t, b, c̃1 (c1), c̃2 (c2)) that follows the animation's time, and the
    legend."""
    data = json.dumps(
        {
            "t": [round(float(v), 3) for v in times],
            "b": [round(float(v), 4) for v in soc],
            "c1": [round(float(v), 1) for v in c1],
            "c2": [[round(float(x), 2) for x in row] for row in c2],
            "c1n": [round(float(v), 3) for v in c1n],
            "c2n": [round(float(v), 3) for v in c2n],
        }
    )
    return f"""
<div id="eaplan-overlay" style="position:fixed;top:8px;left:8px;z-index:10;
 font:14px monospace;background:rgba(255,255,255,0.85);padding:6px 10px;border-radius:4px;
 pointer-events:none">
 <div id="eaplan-readout">t = 0.0 s</div>
 <div style="font-size:12px;color:#444">bars: <span style="color:#2ca02c">SoC b</span>
 (cyan tick: reserve), <span style="color:#1f77b4">c&#771;1</span>,
 <span style="color:#ff7f0e">c&#771;2</span> (normalised, 0 lowest, 1 highest; c1 = r2&#178;
 &minus; r&#178; &le; 0 m&#178;); path colour: quality &frac12;c&#771;1 + &frac12;c&#771;2 as in
 flight.png (purple 0, yellow 1); dark grey arrow: wind; 1 grid cell = 100 m</div>
</div>
<script>
(function() {{
  var d = {data};
  function find(t) {{
    var lo = 0, hi = d.t.length - 1;
    while (lo < hi) {{ var m = (lo + hi + 1) >> 1; if (d.t[m] <= t) lo = m; else hi = m - 1; }}
    return lo;
  }}
  var seek = /t=([0-9.]+)/.exec(location.hash);
  function tick() {{
    var a = null;
    try {{ a = viewer.animator; }} catch (e) {{}}
    if (seek && a && a.actions.length) {{
      a.pause();
      a.seek(parseFloat(seek[1]));
      a.display_progress(parseFloat(seek[1]));
      seek = null;
    }}
    var t = a ? a.time : 0;
    var i = find(d.t[0] + t);
    document.getElementById("eaplan-readout").textContent =
      "t = " + d.t[i].toFixed(1) + " s   b = " + d.b[i].toFixed(3) + "   c\\u03031 = " +
      d.c1n[i].toFixed(2) + " (c1 = " + d.c1[i].toFixed(0) + " m\\u00b2)   c\\u03032 = " +
      d.c2n[i].toFixed(2) + " (c2 = " + d.c2[i].join(", ") + ")";
  }}
  tick();
  setInterval(tick, 100);
}})();
</script>
"""


def _DrawArea(meshcat, scenario: Scenario, poly) -> None:
    """The survey area (grey, ``poly`` in scene units) and the initial plan's stages."""
    from pydrake.geometry import Rgba

    _Flat(meshcat, "/eaplan/survey_area", poly, 0.0, Rgba(0.8, 0.8, 0.8, 1.0))
    for i, pts in enumerate(_Planned(scenario)):
        v = np.vstack([pts.T / UNIT, np.full(len(pts), 0.01)])
        meshcat.SetLine(f"/eaplan/plan/{i}", v, 1.0, Rgba(0.75, 0.8, 0.9, 1.0))


def _DrawFlown(meshcat, p, quality) -> list[tuple[int, int, int]]:
    """The flown path ``p`` [scene units] as ribbons coloured by the quality on
    :data:`~eaplan_drake.output.plot_style.QUALITY_COLORMAP`; returns its :func:`PathChunks`."""
    import matplotlib

    from eaplan_drake.output.plot_style import QUALITY_COLORMAP

    cmap = matplotlib.colormaps[QUALITY_COLORMAP]
    num_colours = 8
    chunks = PathChunks(quality, num_colours=num_colours)
    for k, (a, b, colour) in enumerate(chunks):
        xy, faces = Ribbon(p[a : b + 1], 0.025)
        v = np.vstack([xy.T, np.full(len(xy), _ALTITUDE)])
        rgb = cmap((colour + 0.5) / num_colours)
        meshcat.SetTriangleMesh(f"/eaplan/flown/{k}", v, faces.T.astype(np.int32), _Rgba(rgb))
    return chunks


def _DrawWind(meshcat, scenario: Scenario, lo_xy, hi_xy) -> None:
    """The wind arrow above the top-left corner of the area (none without wind)."""
    from eaplan_drake.output.plot_style import COLORS

    w = scenario.wind.Vector()
    speed = float(np.linalg.norm(w))
    if speed > 0.0:
        outline = ArrowOutline(speed / 10.0, 0.06)
        angle = np.arctan2(w[1], w[0])
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        base = np.array([lo_xy[0], hi_xy[1] + 0.3])
        _Flat(meshcat, "/eaplan/wind", outline @ rot.T + base, 0.02, _Color(COLORS["wind"]))


def _DrawBars(meshcat, scenario: Scenario, bars: dict, lo_xy, hi_xy) -> None:
    """The bars (``bars``: name → (values, rgb)) to the right of the area, growing along +y from
    their base, each in a white frame, and the reserve's tick on the SoC bar."""
    from pydrake.geometry import Box, Rgba
    from pydrake.math import RigidTransform

    from eaplan_drake.output.plot_style import COLORS

    x_bar = hi_xy[0] + 0.4
    for j, (name, (_, rgb)) in enumerate(bars.items()):
        x = x_bar + 0.3 * j
        frame = np.array(
            [[x - 0.08, lo_xy[1] - 0.03], [x + 0.08, lo_xy[1] - 0.03]]
            + [
                [x + 0.08, lo_xy[1] + _BAR_LENGTH + 0.03],
                [x - 0.08, lo_xy[1] + _BAR_LENGTH + 0.03],
            ]
        )
        _Flat(meshcat, f"/eaplan/bars/{name}_frame", frame, 0.005, Rgba(1.0, 1.0, 1.0, 1.0))
        meshcat.SetObject(f"/eaplan/bars/{name}/value/box", Box(_BAR_WIDTH, 1.0, 0.02), _Rgba(rgb))
        meshcat.SetTransform(f"/eaplan/bars/{name}/value/box", RigidTransform([0.0, 0.5, 0.0]))
        meshcat.SetTransform(f"/eaplan/bars/{name}", RigidTransform([x, lo_xy[1], 0.02]))
    reserve_y = lo_xy[1] + _BAR_LENGTH * scenario.battery.reserve_soc
    meshcat.SetObject("/eaplan/bars/reserve", Box(0.22, 0.02, 0.03), _Color(COLORS["reserve"]))
    meshcat.SetTransform("/eaplan/bars/reserve", RigidTransform([x_bar, reserve_y, 0.03]))


def _DrawAircraft(meshcat, lo_xy, hi_xy) -> None:
    """The aircraft (a body along +x and a wing along y) and the camera over the scene."""
    from pydrake.geometry import Box, Rgba
    from pydrake.math import RigidTransform

    meshcat.SetObject("/eaplan/aircraft/body", Box(0.12, 0.025, 0.02), Rgba(0.1, 0.1, 0.1, 1))
    meshcat.SetObject("/eaplan/aircraft/wing", Box(0.03, 0.16, 0.008), Rgba(0.8, 0.1, 0.1, 1))
    meshcat.SetTransform("/eaplan/aircraft/wing", RigidTransform([0.01, 0.0, 0.0]))
    centre = 0.5 * (lo_xy + hi_xy) + np.array([0.3, 0.0])
    extent = float(np.max(hi_xy - lo_xy)) + 1.0
    meshcat.SetCameraPose(
        [centre[0], centre[1] - 0.35 * extent, 1.1 * extent], [centre[0], centre[1], 0.0]
    )


def _Record(meshcat, log: FlightLog, frames, p, heading, bars: dict, chunks, frame_rate) -> None:
    """Records the animation at ``frames``: the aircraft's pose, the bars' lengths and the
    flown ribbons shown up to each frame's time."""
    from pydrake.math import RigidTransform, RotationMatrix

    t0 = float(log.times[0])
    meshcat.StartRecording(frames_per_second=frame_rate, set_visualizations_while_recording=False)
    chunk_start = np.array([log.times[a] for a, _, _ in chunks])
    shown = np.zeros(len(chunks), dtype=bool)
    for i in frames:
        t = float(log.times[i]) - t0
        pose = RigidTransform(
            RotationMatrix.MakeZRotation(float(heading[i])), [p[i, 0], p[i, 1], _ALTITUDE]
        )
        meshcat.SetTransform("/eaplan/aircraft", pose, t)
        for name, (values, _) in bars.items():
            scale = [1.0, _BAR_LENGTH * max(float(values[i]), 1e-3), 1.0]
            meshcat.SetProperty(f"/eaplan/bars/{name}/value", "scale", scale, t)
        visible = chunk_start <= log.times[i] + 1e-9
        for k in np.flatnonzero(visible != shown):
            meshcat.SetProperty(f"/eaplan/flown/{k}", "visible", bool(visible[k]), t)
        if i == frames[0]:
            for k in np.flatnonzero(~visible):
                meshcat.SetProperty(f"/eaplan/flown/{k}", "visible", False, t)
        shown = visible
    meshcat.StopRecording()


def SaveFlightReplay(
    log: FlightLog,
    scenario: Scenario,
    path: str | Path,
    frame_rate: float = 5.0,
    meshcat=None,
) -> Path:
    """Writes the Meshcat replay of ``log`` (a flight of ``scenario``) as a self-contained HTML
    file at ``path`` (whole or not at all); returns the path.

    ``frame_rate`` [Hz] sets the animation's frames (file size grows with it: ≈ 1 MB per 100 s
    of flight at 5 Hz). ``meshcat`` is a ``pydrake.geometry.Meshcat`` to draw into (it is
    cleared); by default a new one is made and closed again.
    """
    from matplotlib.colors import to_rgb
    from pydrake.geometry import Meshcat

    from eaplan_drake.output.plot_style import COLORS

    path = Path(path)
    frames = ReplayFrames(log.times, frame_rate)
    own = meshcat is None
    if own:
        with _QuietDrakeLog():  # not "Meshcat listening for connections at http://…"
            meshcat = Meshcat()
    try:
        meshcat.Delete()
        meshcat.DeleteRecording()
        meshcat.SetProperty("/Axes", "visible", False)
        p = np.asarray(log["position"], dtype=float) / UNIT
        heading = np.asarray(log["heading"], dtype=float)[:, 0]
        soc = np.asarray(log["soc"], dtype=float)[:, 0]
        c1 = np.asarray(log["path_parameters"], dtype=float)[:, 0]
        c2 = np.asarray(log["computation_parameters"], dtype=float).reshape(len(log.times), -1)
        c1n, c2n = NormalisedParameters(log)
        from eaplan_drake.output.path_plot import SurveyShapes

        poly = SurveyShapes(scenario)["outline"] / UNIT  # a field's outline, not the polygon
        _DrawArea(meshcat, scenario, poly)
        chunks = _DrawFlown(meshcat, p, SampleQuality(log))
        lo_xy, hi_xy = np.min(np.vstack([p, poly]), axis=0), np.max(np.vstack([p, poly]), axis=0)
        _DrawWind(meshcat, scenario, lo_xy, hi_xy)
        bars = {
            name: (values, to_rgb(COLORS[name]))
            for name, values in zip(("soc", "c1", "c2"), (soc, c1n, c2n), strict=True)
        }
        _DrawBars(meshcat, scenario, bars, lo_xy, hi_xy)
        _DrawAircraft(meshcat, lo_xy, hi_xy)
        _Record(meshcat, log, frames, p, heading, bars, chunks, frame_rate)
        meshcat.PublishRecording()
        html = meshcat.StaticHtml()
    finally:
        if own:
            del meshcat
    overlay = _OverlayHtml(log.times, soc, c1, c2, c1n, c2n)
    html = html.replace("</body>", overlay + "</body>", 1) if "</body>" in html else html + overlay
    path.parent.mkdir(parents=True, exist_ok=True)
    AtomicWrite(path, lambda f: f.write(html), binary=False)
    return path
