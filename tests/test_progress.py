"""Progress: the flight fraction, the ETA, in-place and plain lines; the CLI's quick answers."""

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from eaplan_drake.cli import main as cli_main
from eaplan_drake.output.progress import FlightFraction, FlightProgress, FormatDuration, ProgressBar
from eaplan_drake.output.summary_text import FormatSummary as _FormatSummary
from eaplan_drake.params import Scenario

ROOT = Path(__file__).resolve().parents[1]


def test_flight_fraction_is_the_nearest_of_survey_reserve_and_time_limit():
    assert FlightFraction(0.25, 1.0, 1.0, 0.3) == 0.25
    assert FlightFraction(0.25, 0.65, 1.0, 0.3) == pytest.approx(0.5)  # half the usable charge
    assert FlightFraction(1.2, 1.0, 1.0, 0.3) == 1.0
    assert FlightFraction(0.0, 0.2, 1.0, 0.3) == 1.0
    assert FlightFraction(float("nan"), float("nan"), 1.0, 0.3) == 0.0
    assert FlightFraction(0.1, 1.0, 1.0, 0.3, t=30.0, time_limit=40.0) == pytest.approx(0.75)


def test_format_duration():
    assert FormatDuration(0.4) == "0:00"
    assert FormatDuration(75.0) == "1:15"
    assert FormatDuration(3725.0) == "1:02:05"
    assert FormatDuration(None) == FormatDuration(float("inf")) == FormatDuration(-1) == "--:--"


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_plain_lines_when_not_a_tty_one_per_tenth_with_eta():
    stream, clock = io.StringIO(), _Clock()
    bar = ProgressBar("plan_i", stream=stream, clock=clock, tty=False)
    assert bar.Eta() is None
    for k in range(1, 101):
        clock.now += 0.5
        bar.Update(k / 100, f"step {k}")
        if k == 25:
            # 12.5 s for a quarter: three quarters take 37.5 s more.
            assert bar.Eta() == pytest.approx(37.5)
    bar.Close("done")
    lines = stream.getvalue().splitlines()
    assert len(lines) == 10  # 10 %, 20 %, …, 90 % and the closing line at 100 %
    assert "\r" not in stream.getvalue()
    assert lines[0].startswith("plan_i  [##..................]  10 %  step 10")
    assert "ETA 0:45" in lines[0]  # 5 s for 10 %: 45 s to go
    assert lines[-1].endswith("ETA 0:00") and "done" in lines[-1] and "100 %" in lines[-1]


def test_in_place_line_on_a_tty_is_rate_limited():
    stream, clock = io.StringIO(), _Clock()
    bar = ProgressBar("x", stream=stream, clock=clock, tty=True, refresh=1.0)
    for k in range(10):
        clock.now += 0.25
        bar.Update(k / 10)
    bar.Close()
    text = stream.getvalue()
    assert text.count("\r") == 4  # at 0, 1 and 2 s of wall time, and the final line
    assert text.endswith("\x1b[K\n") and text.count("\n") == 1


def test_flight_progress_shares_one_bar_between_flights():
    stream, clock = io.StringIO(), _Clock()
    bar = ProgressBar(stream=stream, clock=clock, tty=False)
    scenario = Scenario()
    scenario.name = "second"
    FlightProgress(scenario, bar, index=1, count=4)(120.0, 0.9, 0.5)
    assert bar.fraction == pytest.approx(1.5 / 4)
    assert "second (2/4) t =  120 s, survey  50 % covered, SoC 0.900" in bar.text


def test_summary_names_policy_end_reason_and_infeasible_steps():
    summary = {
        "scenario": "plan_i",
        "policy": "paper",
        "status": "reserve_reached",
        "end_reason": "battery reached the reserve SoC 0.3 at 394.6 s, 41 % of the survey left",
        "quality": 0.5,
        "mean_path_parameter_normalised": 0.5,
        "mean_computation_parameter_normalised": 0.5,
        "final_margin": 0.0,
        "final_soc": 0.3,
        "reserve_soc": 0.3,
        "duration": 394.6,
        "metric": None,
        "first_infeasible_time": 173.1,
        "planner": {"solves": 315, "failures": 2, "infeasible": 183, "median_solve_time": 0.02},
        "wall_time": 40.0,
        "realtime_factor": 9.9,
    }
    text = _FormatSummary(summary)
    assert "policy          paper" in text
    assert "reserve_reached: battery reached the reserve SoC 0.3 at 394.6 s, 41 %" in text
    assert "315 steps: 183 infeasible (first at 173.1 s), 2 solver fallbacks" in text


def _Run(*args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "eaplan_drake", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=120,
    )


def _ImportsPydrake(stderr: str) -> bool:
    return any(line.rstrip().endswith("| pydrake") for line in stderr.splitlines())


def test_help_and_an_unknown_scenario_answer_without_importing_pydrake():
    r = _Run("--help")
    assert r.returncode == 0 and "simulate" in r.stdout
    assert not _ImportsPydrake(r.stderr)
    r = _Run("simulate", "no_such_plan")
    assert r.returncode == 2
    last = [line for line in r.stderr.splitlines() if not line.startswith("import time:")][-1]
    assert last.startswith("eaplan-drake: scenario error: no_such_plan: not a YAML file")
    assert not _ImportsPydrake(r.stderr)


def test_cli_simulate_with_replay_writes_the_html_and_a_progress_bar(tmp_path, capsys):
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nsimulation: {time_limit: 8.0}\n")
    assert cli_main(["simulate", str(scenario), "--out", str(tmp_path), "--replay"]) == 0
    captured = capsys.readouterr()
    assert sorted(p.name for p in (tmp_path / "short").iterdir()) == [
        "flight.png",
        "log.npz",
        "replay.html",
        "summary.json",
    ]
    assert "time limit 8 s reached" in captured.out
    assert captured.err.count("[####################] 100 %") == 1
    assert "ETA 0:00" in captured.err
    summary = json.loads((tmp_path / "short" / "summary.json").read_text())
    assert summary["end_reason"].startswith("time limit 8 s reached, ")
    assert 0.9 < summary["coverage_remaining"] <= 1.0


@pytest.mark.slow
def test_compare_shows_one_bar_and_draws_the_policies_of_a_world(tmp_path, monkeypatch, capsys):
    import eaplan_drake.output.reference as reference

    monkeypatch.setattr(reference, "COMPARE_FLIGHTS", (("plan_i", None), ("plan_i", "mpc")))
    args = ["compare", "--out", str(tmp_path), "--set", "simulation.time_limit=6"]
    assert cli_main(args) == 0
    captured = capsys.readouterr()
    assert captured.err.count("2/2 flights done") == 1
    assert "compare: 2 flights  [" in captured.err
    assert (tmp_path / "plan_i_policies.png").read_bytes()[:4] == b"\x89PNG"
    assert "| plan_i_mpc | mpc | time_limit |" in captured.out
