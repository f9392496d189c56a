"""Studies (eaplan_drake.studies.sweep): reproducible flights, serial = parallel, resume after a
kill,
error rows, Dask, the report."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import distributed
import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.studies.sweep import (
    FlyRow,
    LoadStudy,
    RunStudy,
    StudyFlights,
    StudyReport,
    WilsonInterval,
)

pytestmark = pytest.mark.slow

TINY = textwrap.dedent(
    """\
    name: tiny
    base: plan_i
    set: {simulation.time_limit: 12.0, planner.warmup: 4.0}
    grid: {wind.speed: [2.0, 6.0]}
    uniform: {wind.direction_deg: [0.0, 360.0]}
    choice: {sensor.noise_std: [0.2, 1.0]}
    faults: {count: [0, 2], time: [0.0, 12.0], soc_drop: [0.0, 0.1]}
    draws: 2
    seed: 7
    policies: [mpc, greedy]
    """
)


@pytest.fixture
def study(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return LoadStudy(path)


def _Stable(rows):
    return sorted(
        ({k: v for k, v in r.items() if k != "wall_time"} for r in rows), key=lambda r: r["id"]
    )


def test_flights_are_reproducible_and_vary_what_the_study_says(study):
    st, d = study
    flights = StudyFlights(st, d)
    assert len(flights) == 2 * 2 * 3  # grid × draws × (lowest + 2 policies)
    again = StudyFlights(st, d)
    assert [k for k, _ in flights] == [k for k, _ in again]
    keys, s = flights[0]
    assert keys["policy"] == "lowest" and s.planner.policy == "static"
    assert s.planner.initial_path_parameters == [-1000.0]
    assert s.computation.initial_parameters == [2.0]
    assert {k["wind.speed"] for k, _ in flights} == {2.0, 6.0}
    assert all(s.simulation.time_limit == 12.0 for _, s in flights)
    world0 = [s for k, s in flights if k["world"] == 0]
    assert len({s.random_seed for s in world0}) == 1  # one world, every policy
    # Common random numbers: draw d is the same at every grid point.
    assert len({s.random_seed for _, s in flights}) == 2


def test_serial_and_parallel_give_identical_rows(study, tmp_path):
    st, d = study
    serial = RunStudy(st, tmp_path / "serial", directory=d, n_jobs=1, progress=False)
    parallel = RunStudy(st, tmp_path / "parallel", directory=d, n_jobs=2, progress=False)
    assert len(serial) == 12 and all(r["error"] is None for r in serial)
    assert _Stable(serial) == _Stable(parallel)
    # Re-running the finished study flies nothing (no row added) and returns the same rows.
    lines = (tmp_path / "serial" / "rows.jsonl").read_text().splitlines()
    again = RunStudy(st, tmp_path / "serial", directory=d, progress=False)
    assert _Stable(again) == _Stable(serial)
    assert (tmp_path / "serial" / "rows.jsonl").read_text().splitlines() == lines
    report = StudyReport(tmp_path / "serial")
    text = report.read_text()
    assert "| mpc | 4 |" in text and "| lowest | 4 |" in text
    for name in ("quality.png", "completion.png", "margin.png"):
        assert (tmp_path / "serial" / name).stat().st_size > 1000


def test_a_killed_study_resumes_to_the_same_rows(study, tmp_path):
    st, d = study
    reference = RunStudy(st, tmp_path / "ref", directory=d, n_jobs=1, progress=False)
    out = tmp_path / "killed"
    code = (
        "from eaplan_drake.studies.sweep import LoadStudy, RunStudy\n"
        f"st, d = LoadStudy({str(d / 'tiny.yaml')!r})\n"
        f"RunStudy(st, {str(out)!r}, directory=d, n_jobs=1, progress=False)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    rows = out / "rows.jsonl"
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:  # kill once a few rows are written
        if rows.is_file() and len(rows.read_text().splitlines()) >= 3:
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = [json.loads(x) for x in rows.read_text().splitlines() if x.strip().endswith("}")]
    assert 3 <= len(partial) < 12
    resumed = RunStudy(st, out, directory=d, n_jobs=1, progress=False)
    assert _Stable(resumed) == _Stable(reference)


def test_a_flight_that_raises_is_an_error_row(study):
    st, d = study
    keys, scenario = StudyFlights(st, d)[1]
    scenario.computation.table = "no_such_table"
    row = FlyRow(keys, scenario)
    assert row["status"] == "error" and not row["completed"]
    assert "no_such_table" in row["error"]


def test_dask_local_cluster_runs_the_study(study, tmp_path):
    st, d = study
    st.grid = {"wind.speed": [3.0]}
    st.draws = 1
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            scheduler_kwargs={"dashboard": False},
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        rows = []  # RunStudy with the Client, in a thread so that a hang fails the test
        run = threading.Thread(
            target=lambda: rows.extend(
                RunStudy(
                    st,
                    tmp_path / "dask",
                    directory=d,
                    backend="dask",
                    scheduler=client,
                    progress=False,
                )
            ),
            daemon=True,
        )
        run.start()
        run.join(timeout=120.0)
        assert not run.is_alive(), "RunStudy on the LocalCluster did not end within 120 s"
    serial = RunStudy(st, tmp_path / "serial", directory=d, progress=False)
    assert len(rows) == 3 and _Stable(rows) == _Stable(serial)


def test_bad_study_files_are_one_line(tmp_path):
    for text, message in (
        ("draws: 0", "draws"),
        ("grdi: {}", "grdi: unknown key"),
        ("uniform: {wind.speed: [1]}", "uniform.wind.speed"),
        ("a: [", "invalid YAML"),
    ):
        path = tmp_path / "bad.yaml"
        path.write_text(text)
        with pytest.raises(ScenarioError) as e:
            LoadStudy(path)
        assert message in str(e.value) and "\n" not in str(e.value)
    path.write_text("set: {battery.capcity: 2}")
    st, d = LoadStudy(path)
    with pytest.raises(ScenarioError, match="battery.capcity: unknown key"):
        StudyFlights(st, d)


def test_wilson_interval():
    assert WilsonInterval(0, 0) == (0.0, 1.0)
    lo, hi = WilsonInterval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = WilsonInterval(10, 10)
    assert lo == pytest.approx(0.7225, abs=1e-4) and hi == 1.0
    lo, hi = WilsonInterval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-4) and hi == pytest.approx(0.5962, abs=1e-4)


def test_a_torn_last_line_is_set_aside_and_its_flight_flown_again(tmp_path, mini):
    """A kill mid-write leaves the last row cut, without its newline: the next run moves the
    fragment to rows.jsonl.torn (never gluing a row onto it), flies that flight again, and the
    report counts every flight once."""
    st, d = LoadStudy(mini)
    out = tmp_path / "o"
    reference = RunStudy(st, out, directory=d, progress=False)
    rows = out / "rows.jsonl"
    lines = rows.read_text().splitlines()
    assert len(lines) == 3
    fragment = lines[2][: len(lines[2]) // 2]
    rows.write_text("\n".join(lines[:2]) + "\n" + fragment)
    again = RunStudy(st, out, directory=d, progress=False)
    assert _Stable(again) == _Stable(reference)
    assert (out / "rows.jsonl.torn").read_text() == fragment + "\n"
    fixed = rows.read_text().splitlines()
    assert len(fixed) == 3 and [json.loads(x)["id"] for x in fixed] == [r["id"] for r in again]
    assert fixed[:2] == lines[:2]
    text = StudyReport(out).read_text()
    assert text.startswith("# Study report: 3 flights\n")
    assert "| mpc | 1 |" in text and "| lowest | 1 |" in text and "| greedy | 1 |" in text


def test_rows_glued_onto_a_cut_line_are_kept_once(tmp_path):
    """rows.jsonl from before the fix: a cut line with the next row glued after it, and the same
    flight twice. Reading keeps the glued row and one row per flight id (the last)."""
    from eaplan_drake.studies.sweep import _ReadRows, _RepairRows

    a = {"world": 0, "policy": "lowest", "id": "a", "error": None, "note": "{x}"}
    b = {"world": 0, "policy": "mpc", "id": "b", "error": None}
    b2 = dict(b, note="again")
    cut = json.dumps(a)[:30]
    path = tmp_path / "rows.jsonl"
    path.write_text(f"{json.dumps(a)}\n{cut}{json.dumps(b)}\n{json.dumps(b2)}\n{cut}")
    assert _ReadRows(path) == [a, b2]
    _RepairRows(path)
    assert path.read_text() == f"{json.dumps(a)}\n{json.dumps(b)}\n{json.dumps(b2)}\n"
    assert (tmp_path / "rows.jsonl.torn").read_text() == f"{cut}\n{cut}\n"


def _SessionProcesses(session: int) -> list[int]:
    """Live processes of a session (Linux /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = open(f"/proc/{entry}/stat").read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) == session and fields[0] not in ("Z", "X"):
            found.append(int(entry))
    return found


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc")
def test_killing_a_two_job_sweep_leaves_no_worker_running(tmp_path, mini_text):
    """SIGKILL of `sweep --jobs 2` while its loky workers fly: within 10 s no process of the
    sweep's session is left (the workers notice their parent is gone)."""
    path = tmp_path / "long.yaml"
    path.write_text(mini_text.replace("5.0", "400.0").replace("draws: 1", "draws: 3"))
    command = [sys.executable, "-m", "eaplan_drake", "sweep", str(path), "--out"]
    proc = subprocess.Popen(
        [*command, str(tmp_path / "o"), "--jobs", "2"],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120.0
        while len(_SessionProcesses(proc.pid)) < 4 and time.monotonic() < deadline:
            time.sleep(0.1)  # the sweep, two workers and a resource tracker at least
        time.sleep(2.0)  # the workers take their first flights
        assert len(_SessionProcesses(proc.pid)) >= 4
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10.0)
        deadline = time.monotonic() + 10.0
        while _SessionProcesses(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _SessionProcesses(proc.pid) == []
    finally:
        for pid in _SessionProcesses(proc.pid):
            os.kill(pid, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
