"""Bad studies and certify runs: every range error names its key and the allowed values, through
the same checks from a study file, from Python and from ``certify``; a study larger than the
machine can prepare is refused from its keys before any world is built (each case under an
alarm, none asserting a duration)."""

import signal

import pytest

from eaplan_drake.cli import main as cli_main
from eaplan_drake.errors import ScenarioError
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.study import MAX_STUDY_FLIGHTS, LoadStudy, Study, StudyFlightCount

ALARM_SECONDS = 30


def _Bounded(fn, *args):
    def on_alarm(signum, frame):
        raise AssertionError(f"still running after {ALARM_SECONDS} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(ALARM_SECONDS)
    try:
        return fn(*args)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


STUDY_CASES = [
    (
        "uniform reversed",
        "uniform: {wind.speed: [10, 0]}",
        "uniform.wind.speed: must be [low, high]",
    ),
    (
        "uniform infinite",
        "uniform: {wind.speed: [0, .inf]}",
        "uniform.wind.speed: must be [low, high]",
    ),
    (
        "normal sd < 0",
        "normal: {wind.speed: [5, -1]}",
        "normal.wind.speed: must be [mean, standard",
    ),
    (
        "faults count reversed",
        "faults: {count: [3, 0]}",
        "faults.count: must be [low, high] of integers",
    ),
    ("faults count too many", "faults: {count: [0, 1000]}", "faults.count: must be [low, high]"),
    ("faults drop above 1", "faults: {soc_drop: [0, 2]}", "faults.soc_drop: must be [low, high]"),
    ("negative seed", "seed: -5", "seed: must be an integer >= 0, got -5"),
    ("draws too many", "draws: 2000000", "draws: must be an integer in [1, 1000000]"),
    (
        "a 1e10-flight grid",
        "grid: {"
        + ", ".join(f"k{i}: [{', '.join(str(v) for v in range(10))}]" for i in range(10))
        + "}",
        "draws × grid × flights per world: 1 × 10 × 10",
    ),
    ("many draws", "draws: 1000000", f"= 2000000 flights; at most {MAX_STUDY_FLIGHTS}"),
]


@pytest.mark.parametrize("case", STUDY_CASES, ids=[c[0] for c in STUDY_CASES])
def test_a_bad_study_file_is_one_line_naming_its_key(case, tmp_path, capsys):
    _, text, expected = case
    path = tmp_path / "s.yaml"
    path.write_text(f"base: plan_i\n{text}\n")
    with pytest.raises(ScenarioError) as info:
        _Bounded(LoadStudy, path)
    assert expected in str(info.value) and str(info.value).startswith(str(path))
    assert "\n" not in str(info.value)
    status = _Bounded(cli_main, ["sweep", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and expected in err[0], err
    assert not (tmp_path / "out").exists()


def test_the_same_checks_from_python_and_the_flight_count_before_any_world():
    with pytest.raises(ScenarioError, match=r"^uniform\.wind\.speed: must be \[low, high\]"):
        Study(uniform={"wind.speed": [10.0, 0.0]}).Validate()
    huge = Study(grid={f"k{i}": list(range(10)) for i in range(10)})
    assert StudyFlightCount(huge) == 10**10 * 2
    with pytest.raises(ScenarioError, match="flights; at most"):
        _Bounded(huge.Validate)
    assert Study(draws=3, policies=["mpc", "greedy"]).Validate() is not None


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--seed", "-1"], "--seed: must be an integer >= 0, got -1"),
        (["--worlds", "100000"], "--worlds: must be an integer in [1, 20000], got 100000"),
    ],
)
def test_certify_ranges_name_their_option(args, expected, tmp_path, capsys):
    status = _Bounded(cli_main, ["certify", "survey", "--out", str(tmp_path / "c"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and expected in err[0], err
    with pytest.raises(ValueError, match=r"^worlds: must be an integer in \[1, 20000\]"):
        CertifyStudy("survey", 100_000)
