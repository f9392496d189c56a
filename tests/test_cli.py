"""What the command line prints: --version, the scenarios simulate --help lists, the summary's
planner lines, and no Meshcat address while a replay is written to a file."""

import logging

import pytest

from eaplan_drake import __version__
from eaplan_drake.cli import main as cli_main
from eaplan_drake.loading import ShippedNames
from eaplan_drake.output.summary_text import FormatSummary as _FormatSummary


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli_main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out == f"eaplan-drake {__version__}\n"


def test_simulate_help_lists_every_shipped_scenario(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli_main(["simulate", "--help"])
    assert exit_.value.code == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    names = ShippedNames("scenarios")
    assert "survey" in names and "plan_i" in names
    assert f"shipped name ({', '.join(names)}) or YAML path" in text


def _Summary(policy, **planner):
    return {
        "scenario": "plan_i",
        "policy": policy,
        "status": "complete",
        "end_reason": "survey complete at 394.7 s",
        "quality": 0.475,
        "mean_path_parameter_normalised": 0.578,
        "mean_computation_parameter_normalised": 0.372,
        "final_margin": 0.046,
        "final_soc": 0.346,
        "reserve_soc": 0.3,
        "duration": 394.7,
        "metric": 10.311,
        "first_infeasible_time": 173.1 if planner.get("infeasible") else None,
        "planner": planner,
        "wall_time": 9.9,
        "realtime_factor": 40.0,
    }


def test_summary_says_why_steps_were_infeasible_and_that_the_paper_solves_no_nlp():
    text = _FormatSummary(
        _Summary("paper", solves=315, infeasible=183, failures=0, solve_times=[0.0] * 315)
    )
    lines = text.splitlines()
    assert (
        "planner         315 steps: 183 infeasible (first at 173.1 s), 0 solver fallbacks" in lines
    )
    assert (
        "                183 steps where the paper's output constraint y ≤ b·Q_c·V cannot hold; "
        "flew the lowest c2 there"
    ) in lines
    assert (
        "                no NLP solved: with integer parameters the paper's planner searches the "
        "table's c2 grid exactly"
    ) in lines
    assert "median solve" not in text and "0.0 ms" not in text
    text = _FormatSummary(
        _Summary("greedy_authors", solves=10, infeasible=0, failures=0, solve_times=[0.0] * 10)
    )
    assert "no NLP solved: the authors' rule tries every c2 of the table" in text
    assert "steps where" not in text  # no infeasible step, no cause


def test_summary_of_the_mpc_gives_the_median_of_the_steps_that_solved():
    times = [0.010, 0.020, 0.0, 0.015]
    text = _FormatSummary(_Summary("mpc", solves=4, infeasible=1, failures=0, solve_times=times))
    assert "NLP solved at 3 of 4 steps, median 15.0 ms" in text
    assert "flown unsolved" not in text  # without the kinds, nothing is claimed of the others
    kinds = {"solved": 3, "lowest": 1}
    text = _FormatSummary(
        _Summary("mpc", solves=4, infeasible=1, failures=0, solve_times=times, kinds=kinds)
    )
    assert (
        "NLP solved at 3 of 4 steps, median 15.0 ms; the lowest plan at 1 (its margin not met "
        "yet, infeasible, or after a drop)"
    ) in text
    assert (
        "1 steps where even the lowest plan ends below reserve + margin; flew the lowest plan"
        in (text)
    )


def test_summary_of_a_flight_decided_on_the_grid_says_so_and_counts_unpriced_steps():
    """A fault-free flight whose steps were decided exactly on the grid says so (it never claims
    the lowest plan was flown), and the steps the risk could not be priced are said apart."""
    kinds = {"solved": 25, "determined": 330}
    text = _FormatSummary(
        _Summary("mpc", solves=355, infeasible=0, failures=0, solve_times=[0.005] * 25, kinds=kinds)
    )
    assert "decided exactly on the table's grid without a solve at 330" in text
    assert "lowest plan" not in text
    kinds = {"determined": 47, "lowest": 3, "unpriced": 110}
    summary = _Summary("mpc", solves=160, infeasible=113, failures=0, solve_times=[], kinds=kinds)
    summary["planner"]["first_status"] = {
        "unpriced": "unpriced: the lowest plan's predicted margin is not finite; the lowest plan"
    }
    text = _FormatSummary(summary)
    assert (
        "110 steps whose fault risk could not be priced (first: the lowest plan's predicted "
        "margin is not finite); flew the lowest plan there, flagged infeasible"
    ) in text
    assert "3 steps where even the lowest plan ends below reserve + margin" in text


def test_summary_of_a_flight_that_ended_before_the_first_planner_step():
    text = _FormatSummary(_Summary("mpc", solves=0, infeasible=0, failures=0, solve_times=[]))
    assert "no planner step: the flight ended before the first one" in text
    assert "NLP" not in text


def test_summary_of_a_static_flight_has_no_planner_steps():
    text = _FormatSummary(_Summary("static", solves=0, infeasible=0, failures=0, solve_times=[]))
    assert "planner         none: the static policy holds the initial parameters" in text
    assert "0 steps" not in text and "NLP" not in text


def test_simulate_replay_prints_no_meshcat_address(tmp_path, caplog, capfd):
    from pydrake.geometry import Meshcat

    caplog.set_level(logging.INFO, logger="drake")
    probe = Meshcat()  # what the check would see: Drake logs the address at INFO
    del probe
    seen = caplog.text + "".join(capfd.readouterr())
    assert "Meshcat listening" in seen
    caplog.clear()
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nsimulation: {time_limit: 3.0}\n")
    assert cli_main(["simulate", str(scenario), "--out", str(tmp_path), "--replay"]) == 0
    out, err = capfd.readouterr()
    assert (tmp_path / "short" / "replay.html").is_file()
    for text in (out, err, caplog.text):
        assert "Meshcat listening" not in text and "localhost:7" not in text
    assert logging.getLogger("drake").level == logging.INFO  # restored after the replay
