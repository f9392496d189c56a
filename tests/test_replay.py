"""The Meshcat replay: its geometry, the HTML file, and a look at it in a headless browser."""

import re
import shutil
import subprocess

import numpy as np
import pytest

from eaplan_drake.flightlog import FlightLog
from eaplan_drake.output.replay import (
    ArrowOutline,
    PathChunks,
    ReplayFrames,
    Ribbon,
    SaveFlightReplay,
)
from eaplan_drake.params import Scenario

pytestmark = pytest.mark.slow


def test_replay_frames_take_the_last_sample_at_or_before_each_frame_time():
    t = np.arange(0.0, 10.01, 0.1)  # 10 Hz log
    idx = ReplayFrames(t, 2.0)
    np.testing.assert_allclose(t[idx], np.arange(0.0, 10.01, 0.5), atol=1e-9)
    assert ReplayFrames(t, 1000.0).tolist() == list(range(len(t)))
    assert ReplayFrames([0.0, 0.3], 1.0).tolist() == [0, 1]  # the last sample always
    with pytest.raises(ValueError, match="frame_rate"):
        ReplayFrames(t, 0.0)


def test_path_chunks_cover_the_path_in_colour_bins():
    values = np.r_[np.zeros(10), np.full(10, 0.99), np.full(5, 0.5)]
    chunks = PathChunks(values, num_colours=4, max_samples=50)
    assert chunks == [(0, 10, 0), (10, 20, 3), (20, 24, 2)]
    long = PathChunks(np.zeros(101), max_samples=50)
    assert long == [(0, 50, 0), (50, 100, 0)]
    assert PathChunks([0.5]) == []


def test_arrow_outline_and_ribbon_geometry():
    a = ArrowOutline(1.0, 0.1)
    assert a[:, 0].max() == 1.0 and a[3].tolist() == [1.0, 0.0]
    assert np.ptp(a[:, 1]) == pytest.approx(0.2)  # the head is twice the shaft
    pts = np.column_stack([np.linspace(0.0, 1.0, 5), np.zeros(5)])
    v, f = Ribbon(pts, 0.2)
    assert v.shape == (10, 2) and f.shape == (8, 3)
    np.testing.assert_allclose(np.abs(v[:, 1]), 0.1)
    np.testing.assert_allclose(v[0::2, 0], pts[:, 0])
    assert f.max() == 9


def _Log():
    """A 60 s flight once around a 60 m circle over the reference area, SoC falling, at the
    lowest quality for 30 s and at the highest then."""
    t = np.linspace(0.0, 60.0, 601)
    angle = 2.0 * np.pi * t / 60.0
    return FlightLog(
        times=t,
        signals={
            "position": np.column_stack([30.0 + 60.0 * np.cos(angle), 80.0 + 60.0 * np.sin(angle)]),
            "heading": (angle + np.pi / 2)[:, None],
            "soc": (1.0 - 0.008 * t)[:, None],
            "path_parameters": np.where(t < 30.0, -1000.0, 0.0)[:, None],
            "computation_parameters": np.where(t < 30.0, 2.0, 10.0)[:, None],
        },
        summary={
            "status": "time_limit",
            "completed": False,
            "duration": 60.0,
            "path_parameter_bounds": [-1000.0, 0.0],
            "computation_parameter_bounds": [[2.0], [10.0]],
        },
    )


def test_replay_is_one_self_contained_html_file(tmp_path):
    path = SaveFlightReplay(_Log(), Scenario(), tmp_path / "run" / "replay.html", frame_rate=2.0)
    assert sorted(p.name for p in path.parent.iterdir()) == ["replay.html"]
    html = path.read_text()
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:200].lower()
    assert not re.search(r"<script[^>]+src=", html)  # everything inline
    assert not re.search(r"<link[^>]+href=\"?https?:", html)
    assert 'id="eaplan-readout"' in html
    assert '"c1": [-1000.0' in html
    # The readout gives the normalised parameters of the figures, with c1 in m² beside.
    assert '"c1n": [0.0' in html and '"c2n": [0.0' in html and "(c1 = " in html
    assert "path colour: quality &frac12;c&#771;1 + &frac12;c&#771;2 as in" in html


def _Chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe:
            return exe
    return None


def _Screenshot(exe, url, png):
    flags = [
        "--headless",
        "--no-sandbox",
        "--use-gl=angle",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--window-size=1000,700",
        "--hide-scrollbars",
        # No network: every host name fails, and no proxy is reachable.
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--proxy-server=127.0.0.1:9",
        f"--screenshot={png}",
        url,
    ]
    command = [exe, *flags]
    unshare = shutil.which("unshare")
    if unshare and subprocess.run([unshare, "-n", "true"], capture_output=True).returncode == 0:
        command = [unshare, "-n", *command]  # a network namespace with no interfaces up
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


def test_replay_renders_in_a_headless_browser_with_the_network_off(tmp_path):
    exe = _Chromium()
    if exe is None:
        pytest.skip("no Chromium found (Debian: apt-get install chromium); .ci/run installs it")
    path = SaveFlightReplay(_Log(), Scenario(), tmp_path / "replay.html", frame_rate=2.0)
    png = tmp_path / "shot.png"
    result = _Screenshot(exe, f"file://{path}#t=59", png)
    assert png.is_file(), f"no screenshot: {result.stderr[-2000:]}"
    import matplotlib.image

    image = matplotlib.image.imread(png)[..., :3]
    # The scene is not blank: saturated pixels (the coloured path, bars, wind arrow and the
    # aircraft; Meshcat's background and grid are grey) cover a visible part of the picture.
    saturation = image.max(axis=2) - image.min(axis=2)
    assert np.mean(saturation > 0.3) > 0.005
    # The flown path is drawn from purple-blue (low quality) to yellow (high): both are there.
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    yellow = (r > 0.7) & (g > 0.7) & (b < r - 0.2)
    purple = (b > 0.3) & (b > r + 0.1) & (b > g + 0.1) & (r > 0.2)
    green_bar = (g > 0.55) & (r < 0.45) & (b < 0.35)
    assert yellow.sum() > 50, "no yellow (high quality) path"
    assert purple.sum() > 50, "no purple (low quality) path"
    assert green_bar.sum() > 200, "no SoC bar"
