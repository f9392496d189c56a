"""``eaplan-drake sweep``'s own checks, before any flight: a missing extra, options that do not
go together, values out of range. Each is one line on stderr and exit status 2."""

import sys

import pytest

from eaplan_drake.cli import main

MISSING = "eaplan-drake: missing extra: sweep needs the [sweep] extra: pip install -e '.[sweep]'"


def _Err(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize(
    ("module", "backend"), [("joblib", []), ("distributed", ["--backend", "dask"])]
)
def test_sweep_without_its_extra_says_missing_extra(tmp_path, capsys, monkeypatch, module, backend):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    args = ["sweep", "robustness", "--out", str(tmp_path / "o"), *backend]
    assert main([*args, "--scheduler", "tcp://127.0.0.1:1"] if backend else args) == 2
    assert _Err(capsys) == [MISSING]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("extra", "line"),
    [
        (
            ["--backend", "dask", "--scheduler", "tcp://127.0.0.1:1", "--jobs", "2"],
            "eaplan-drake: input error: --jobs: not used with --backend dask (the cluster's "
            "workers and their threads set how many flights fly at once)",
        ),
        (
            ["--backend", "dask"],
            "eaplan-drake: input error: --backend dask needs --scheduler ADDRESS (tcp://host:8786)",
        ),
        (
            ["--scheduler", "tcp://127.0.0.1:1"],
            "eaplan-drake: input error: --scheduler: only with --backend dask",
        ),
        (
            ["--backend", "dask", "--scheduler", "tcp://127.0.0.1:1", "--wait-for-workers", "0"],
            "eaplan-drake: input error: --wait-for-workers: must be a number of seconds in "
            "(0, 86400], got 0.0",
        ),
        (
            ["--backend", "dask", "--scheduler", "tcp://127.0.0.1:1", "--wait-for-workers", "inf"],
            "eaplan-drake: input error: --wait-for-workers: must be a number of seconds in "
            "(0, 86400], got inf",
        ),
        (
            ["--jobs", "0"],
            "eaplan-drake: input error: --jobs: must be an integer in [1, 1024] or -1 (one per "
            "core), got 0",
        ),
    ],
)
def test_sweep_options_that_do_not_fit_are_one_line(tmp_path, capsys, extra, line):
    assert main(["sweep", "robustness", "--out", str(tmp_path / "o"), *extra]) == 2
    assert _Err(capsys) == [line]
    assert not (tmp_path / "o").exists()


def test_sweep_help_names_the_backends_and_the_wait(capsys):
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "dask = the workers of a running Dask cluster" in text
    assert "--wait-for-workers SECONDS" in text and "not with --backend dask" in text
