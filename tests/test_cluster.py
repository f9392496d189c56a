"""Studies on a real Dask cluster (eaplan_drake.studies.cluster): flights on one-thread workers,
rows equal to the local ones, a flight whose worker keeps dying, no worker at all, a worker lost
for good. Every cluster is bound to 127.0.0.1 and stopped by its test; the sweeps run in a
subprocess with a timeout, so a hang fails the test instead of stalling the suite."""

import json
import os
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import dask
import distributed
import pytest

from eaplan_drake.studies.sweep import LoadStudy, RunStudy, StudyFlights

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CRASH = textwrap.dedent(
    """\
    # Worker preload: the mpc flight ends its worker process (as a crash in a flight would).
    import os

    import eaplan_drake.studies.sweep as sweep

    if not hasattr(sweep, "_RealFlyRow"):
        sweep._RealFlyRow = sweep.FlyRow

        def FlyRow(keys, scenario, save_logs=""):
            if keys.get("policy") == "mpc":
                os._exit(3)
            return sweep._RealFlyRow(keys, scenario, save_logs)

        sweep.FlyRow = FlyRow
    """
)


def _Cluster(n_workers, **kwargs):
    return distributed.LocalCluster(
        n_workers=n_workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        scheduler_kwargs={"dashboard": False},
        **kwargs,
    )


def _Sweep(study, out, *args, timeout=180.0):
    """``eaplan-drake sweep`` in a subprocess (killed after ``timeout`` s)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    command = [sys.executable, "-m", "eaplan_drake", "sweep", str(study), "--out", str(out)]
    return subprocess.run(
        [*command, *args], env=env, capture_output=True, text=True, timeout=timeout
    )


def _Rows(out):
    """The rows of ``out``/rows.jsonl in file order, without the wall time."""
    lines = (Path(out) / "rows.jsonl").read_text().splitlines()
    return [{k: v for k, v in json.loads(x).items() if k != "wall_time"} for x in lines]


def _Local(mini, out, n_jobs=1):
    st, d = LoadStudy(mini)
    RunStudy(st, out, directory=d, n_jobs=n_jobs, progress=False)
    return _Rows(out)


def test_one_thread_workers_fly_every_flight_and_rows_equal_the_local_ones(mini, tmp_path):
    """Two one-thread workers: every flight is a task on a worker (none in the client), and
    rows.jsonl holds, line for line, the rows of the same study on two loky workers."""
    st, d = LoadStudy(mini)
    n = len(StudyFlights(st, d))
    with _Cluster(2) as cluster, distributed.Client(cluster) as client:
        with distributed.get_task_stream(client) as stream:
            done = _Sweep(
                mini,
                tmp_path / "dask",
                "--backend",
                "dask",
                "--scheduler",
                cluster.scheduler_address,
            )
        workers = set(client.nthreads())
    assert done.returncode == 0, done.stderr
    assert f"{n} flights (0 errors)" in done.stdout
    flights = [t for t in stream.data if str(t["key"]).startswith("eaplan-w")]
    assert len({t["key"] for t in flights}) == n
    assert {t["worker"] for t in flights} <= workers
    assert _Rows(tmp_path / "dask") == _Local(mini, tmp_path / "loky", n_jobs=2)


def test_a_flight_whose_worker_keeps_dying_is_an_error_row(mini, tmp_path):
    """The mpc flight kills its worker; the nanny restarts it; after the scheduler's allowed
    failures (1 here) the flight is an error row naming KilledWorker, the other flights' rows
    are the local ones and the study ends."""
    preload = tmp_path / "crash.py"
    preload.write_text(CRASH)
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):
        cluster = _Cluster(1, preload=[str(preload)])
    with cluster, distributed.Client(cluster):
        done = _Sweep(
            mini, tmp_path / "dask", "--backend", "dask", "--scheduler", cluster.scheduler_address
        )
    assert done.returncode == 0, done.stderr
    assert "3 flights (1 errors)" in done.stdout
    rows = _Rows(tmp_path / "dask")
    local = _Local(mini, tmp_path / "local")
    assert [r["policy"] for r in rows] == ["lowest", "mpc", "greedy"]
    assert rows[0] == local[0] and rows[2] == local[2]
    failed = rows[1]
    assert failed["status"] == "error" and failed["completed"] is False
    assert failed["id"] == local[1]["id"]
    assert failed["error"].startswith("KilledWorker: the Dask worker flying it died 2 times")
    assert "\n" not in failed["error"]


def test_no_worker_is_one_line_after_the_stated_wait(mini, tmp_path):
    """A scheduler without workers: a line saying it waits, then one error line, exit 3; an
    address where no scheduler listens: one line, exit 3."""
    with _Cluster(0) as cluster:
        address = cluster.scheduler_address
        t0 = time.monotonic()
        done = _Sweep(
            mini,
            tmp_path / "o",
            "--backend",
            "dask",
            "--scheduler",
            address,
            "--wait-for-workers",
            "1.5",
            timeout=90.0,
        )
        waited = time.monotonic() - t0
    assert done.returncode == 3, done.stderr
    lines = [x for x in done.stderr.splitlines() if x.startswith("eaplan-drake")]
    assert lines == [
        f"eaplan-drake: cluster error: no Dask worker connected to {address} within 1.5 s "
        f"(start one with: dask worker {address})"
    ]
    assert f"waiting up to 1.5 s for a Dask worker at {address} ..." in done.stderr
    assert waited >= 1.5
    with socket.socket() as s:  # a free port: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    nowhere = f"tcp://127.0.0.1:{port}"
    done = _Sweep(
        mini,
        tmp_path / "o",
        "--backend",
        "dask",
        "--scheduler",
        nowhere,
        "--wait-for-workers",
        "1",
        timeout=90.0,
    )
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        f"eaplan-drake: cluster error: no Dask scheduler answered at {nowhere} within 1 s"
    )


def test_a_worker_lost_for_good_ends_the_study(mini, tmp_path):
    """A `dask worker --no-nanny` started here dies in the mpc flight and does not come back:
    after --wait-for-workers the study ends (exit 3) with the rows it has (the flights left have
    none, so a re-run flies them)."""
    preload = tmp_path / "crash.py"
    preload.write_text(CRASH)
    out = tmp_path / "dask"
    with _Cluster(0) as cluster:
        address = cluster.scheduler_address
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        worker = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_worker",
                address,
                "--no-nanny",
                "--nthreads",
                "1",
                "--host",
                "127.0.0.1",
                "--no-dashboard",
                "--preload",
                str(preload),
            ],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            done = _Sweep(
                mini,
                out,
                "--backend",
                "dask",
                "--scheduler",
                address,
                "--wait-for-workers",
                "2",
                timeout=120.0,
            )
            code = worker.wait(timeout=30.0)
        finally:
            if worker.poll() is None:
                worker.kill()
                worker.wait()
    assert code == 3  # the preload's os._exit(3) in the mpc flight
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        f"eaplan-drake: cluster error: no Dask worker connected to {address} for 2 s"
    )
    assert f"no Dask worker connected to {address}; waiting up to 2 s ..." in done.stderr
    assert [r["policy"] for r in _Rows(out)] == ["lowest"]


def test_distributed_prints_only_critical_records_while_a_study_runs(capsys):
    import logging

    from eaplan_drake.studies.cluster import QuietDistributed

    client_logger = logging.getLogger("distributed.client")
    before = (logging.getLogger("distributed").level, client_logger.level)
    with QuietDistributed():
        assert client_logger.level == logging.CRITICAL
        client_logger.error("Failed to reconnect to scheduler")  # what a dead scheduler logs
    assert (logging.getLogger("distributed").level, client_logger.level) == before
    assert "Failed to reconnect" not in capsys.readouterr().err
