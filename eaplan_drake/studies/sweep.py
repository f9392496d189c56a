"""Studies: parameter sweeps and Monte Carlo over many flights, on joblib locally or on a Dask
cluster.

A *study* (YAML, :class:`~eaplan_drake.studies.study.Study`) names a base scenario, fixed
overrides, a grid over named keys, random draws from named distributions (uniform, normal, choice;
battery faults as a random count with random times and sizes), the policies to compare and a study
seed. :func:`StudyFlights` expands it into flights: every (grid point, draw) is a *world*, flown
once per policy (and, with ``lowest_reference``, once with the static lowest-quality plan, so that
completion can be reported on the worlds that plan completes). Draw d of a study with seed s uses
``numpy.random.default_rng([s, d])`` at every grid point (common random numbers: grid points are
compared on the same random worlds), so the same study file gives the same flights on any machine,
in any order and with any number of workers.

:func:`RunStudy` flies them with joblib (``loky`` by default: worker processes are reused, so
pydrake is imported once per worker; BLAS threads capped at one; a worker whose parent process is
gone, killed even, stops within a second) or, with ``backend="dask"``, on a Dask cluster through
its own futures (:mod:`eaplan_drake.studies.cluster`; ``scheduler`` = the address of a
``distributed.Scheduler``, or a running ``distributed.Client``): the flights run on the cluster's
workers, whatever their number of threads, and a flight the cluster cannot fly (its worker died
more often than the scheduler allows) is an error row saying why. A worker builds its own diagram
from the scenario (scenarios pickle; diagrams do not). Each flight returns one small row
(:func:`FlyRow`); one flight's exception becomes its error row. Rows are the same, bit for bit (but
for ``wall_time``), on either backend and with any number of workers. Rows are appended to
``rows.jsonl`` in the output directory as they finish, one line each, flushed and fsynced; a re-run
of the same study on the same directory skips the flights already there (keyed by a hash of the
resolved scenario), so a study killed at any moment resumes and loses at most the flights in
flight. A line cut by a kill (the last one, without its newline) is moved to ``rows.jsonl.torn``
before anything is appended, and its flight is flown again; when every flight has its row,
``rows.jsonl`` is rewritten in flight order (so it, and the report, do not depend on the order in
which flights finished). :func:`StudyReport` writes ``report.md`` and figures from the rows.

On a cluster: start a scheduler and workers with this package installed (e.g. with
``dask-jobqueue``'s ``SLURMCluster(...)`` or ``PBSCluster(...)``, ``cluster.scale(jobs=n)``) and
pass ``--backend dask --scheduler tcp://host:8786`` (or the ``Client`` in Python).
``--wait-for-workers`` bounds the wait for the scheduler and for a connected worker
(:class:`~eaplan_drake.studies.cluster.ClusterError` after it).
"""

import hashlib
import itertools
import json
import math
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

from eaplan_drake.errors import ScenarioError
from eaplan_drake.files import JsonSafe
from eaplan_drake.loading import (
    LayerScenario,
    OverrideFromAssignment,
)
from eaplan_drake.params import MAX_FAULTS, BatteryFault, FaultModelParams, Scenario
from eaplan_drake.rates import WithRates
from eaplan_drake.studies.cluster import WAIT_FOR_WORKERS, ClusterError, MapOnDask, Wait
from eaplan_drake.studies.study import (  # noqa: F401 (the study's schema, importable from here)
    KEEP_RATES,
    FaultDistribution,
    LoadStudy,
    Study,
    StudyFlightCount,
)

__all__ = [
    "CheckJobs",
    "DrawFaults",
    "ClusterError",
    "FlyRow",
    "InFlightFaults",
    "MAX_JOBS",
    "RunStudy",
    "StudyFlights",
    "StudyReport",
    "WilsonInterval",
]

ROWS_FILE = "rows.jsonl"
TORN_FILE = "rows.jsonl.torn"
"""Where lines of ``rows.jsonl`` that are not whole rows (cut by a kill) are set aside."""
MAX_JOBS = 1024
"""Largest ``n_jobs`` (loky worker processes)."""
LOWEST = "lowest"
"""Pseudo-policy of the static lowest-quality reference flight."""


def _Value(v) -> str:
    return v if isinstance(v, str) else json.dumps(v)


def StudyFlights(study: Study, directory: Path | str = ".") -> list[tuple[dict, Scenario]]:
    """Every flight of the study as (row keys, scenario): row keys are ``world`` (index),
    ``policy``, ``draw`` and the varied values by key path. Scenarios are validated, and the
    study first (:meth:`~eaplan_drake.studies.study.Study.Validate`: its ranges and its number of
    flights)."""
    study.Validate()
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.studies.worlds import LowestPlan, WithPolicy

    base_path = Path(directory) / study.base
    base_name = str(base_path) if base_path.suffix in (".yaml", ".yml") else study.base
    fixed = [OverrideFromAssignment(f"{k}={_Value(v)}") for k, v in study.set.items()]
    loaded = LoadNamedScenario(base_name)
    if study.rates != KEEP_RATES:
        loaded = WithRates(loaded, study.rates)
    base = LayerScenario(loaded, fixed)
    grid_keys = list(study.grid)
    grid_points = list(itertools.product(*(study.grid[k] for k in grid_keys))) or [()]
    flights = []
    world = 0
    for point in grid_points:
        pairs = list(zip(grid_keys, point, strict=True))
        layers = [OverrideFromAssignment(f"{k}={_Value(v)}") for k, v in pairs]
        grid_base = LayerScenario(loaded, fixed + layers) if layers else base
        for draw in range(study.draws):
            rng = np.random.default_rng([int(study.seed), draw])
            varied = dict(pairs)
            draw_layers = []
            for k, (lo, hi) in study.uniform.items():
                varied[k] = float(rng.uniform(lo, hi))
            for k, (mu, sd) in study.normal.items():
                varied[k] = float(rng.normal(mu, sd))
            for k, values in study.choice.items():
                varied[k] = values[int(rng.integers(0, len(values)))]
            for k in itertools.chain(study.uniform, study.normal, study.choice):
                draw_layers.append(OverrideFromAssignment(f"{k}={_Value(varied[k])}"))
            s = LayerScenario(grid_base, draw_layers)
            if study.faults is not None:
                f = study.faults
                n = int(rng.integers(f.count[0], f.count[1] + 1))
                times = np.sort(rng.uniform(f.time[0], f.time[1], size=n))
                drops = rng.uniform(f.soc_drop[0], f.soc_drop[1], size=n)
                s.battery.faults = [
                    BatteryFault(time=float(t), soc_drop=float(max(d, 1e-6)))
                    for t, d in zip(times, drops, strict=True)
                ]
                varied["faults.drawn_count"] = n
                varied["faults.drawn_total_drop"] = float(np.sum(drops))
            elif study.fault_proposal is not None and draw >= study.proposal_from:
                from eaplan_drake.studies.sampling import DrawProposedFaults

                proposal = study.fault_proposal
                s.battery.faults, weight, stratum = DrawProposedFaults(
                    rng, study.fault_model, s.simulation.time_limit, proposal
                )
                varied.update(weight=weight, weight_bound=proposal.weight_bound, stratum=stratum)
                varied["faults.drawn_count"] = len(s.battery.faults)
                varied["faults.drawn_total_drop"] = float(sum(f.soc_drop for f in s.battery.faults))
            elif study.fault_model is not None:
                s.battery.faults = DrawFaults(rng, study.fault_model, s.simulation.time_limit)
                varied["faults.drawn_count"] = len(s.battery.faults)
                varied["faults.drawn_total_drop"] = float(sum(f.soc_drop for f in s.battery.faults))
            s.random_seed = int(rng.integers(0, 2**31 - 1))
            s.name = f"{study.name}_w{world}"
            for policy in ([LOWEST] if study.lowest_reference else []) + list(study.policies):
                flight = LowestPlan(s) if policy == LOWEST else WithPolicy(s, policy)
                keys = {"world": world, "draw": draw, "policy": policy, **varied}
                flights.append((keys, flight))
            world += 1
    return flights


def DrawFaults(rng: np.random.Generator, model: FaultModelParams, horizon: float) -> list:
    """Battery faults drawn from ``model`` over [0, ``horizon``] [s]: a Poisson number of drops
    at uniform times (the arrivals of a Poisson process of rate λ), sizes from the model's
    distribution, at most :data:`~eaplan_drake.params.bounds.MAX_FAULTS` (the earliest)."""
    n = min(int(rng.poisson(model.rate * horizon)), MAX_FAULTS)
    times = np.sort(rng.uniform(0.0, horizon, size=n))
    if model.sizes == "uniform":
        sizes = rng.uniform(*model.size_bounds, size=n)
    elif model.sizes == "exponential":
        sizes = np.minimum(rng.exponential(model.size_mean, size=n), 1.0)
    else:
        sizes = rng.choice(np.asarray(model.size_values, dtype=float), size=n)
    return [
        BatteryFault(time=float(t), soc_drop=float(max(x, 1e-6)))
        for t, x in zip(times, sizes, strict=True)
    ]


def ScenarioHash(scenario: Scenario) -> str:
    """A hash of the resolved scenario (its typed YAML dump): the key of a flight's row."""
    from pydrake.common.yaml import yaml_dump_typed

    return hashlib.sha256(yaml_dump_typed(scenario).encode()).hexdigest()[:16]


def FlyRow(keys: dict, scenario: Scenario, save_logs: str = "") -> dict:
    """Flies one scenario (in a worker) and returns its row; an exception becomes the row's
    ``error`` (status ``error``). With ``save_logs`` a directory, the full log is saved there."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from eaplan_drake.simulation import Simulate

    row = dict(keys, id=ScenarioHash(scenario), error=None)
    t0 = time.perf_counter()
    try:
        log = Simulate(scenario)
        s = log.summary
        row.update(
            status=s["status"],
            completed=bool(s["completed"]),
            duration=s["duration"],
            final_soc=s["final_soc"],
            final_margin=s["final_margin"],
            quality=s["quality"],
            metric=s["metric"],
            solves=s["planner"].get("solves", 0),
            failures=s["planner"].get("failures", 0),
            infeasible=s["planner"].get("infeasible", 0),
            wind_speed=scenario.wind.speed,
            **InFlightFaults(scenario, s["duration"]),
        )
        figures = s["planner"].get("policy_figures") or {}
        if "quality" in figures:  # what the policy predicted of the mission (mdp)
            row.update(predicted_quality=figures["quality"], predicted_excess=figures["excess"])
        if save_logs:
            log.Save(Path(save_logs) / f"{row['id']}")
    except Exception as e:  # one flight's error is its row, never the study's end
        row.update(status="error", completed=False, error=f"{type(e).__name__}: {e}")
    row["wall_time"] = time.perf_counter() - t0
    return row


def InFlightFaults(scenario: Scenario, duration: float) -> dict:
    """The faults of ``scenario`` that fell inside its flight of ``duration`` [s]: their count
    and total drop [-] (``faults.in_flight_count``, ``faults.in_flight_total_drop``). A study
    draws faults over the whole ``simulation.time_limit`` (``faults.drawn_count``,
    ``faults.drawn_total_drop``); a flight that ends earlier meets only these."""
    inside = [f for f in scenario.battery.faults if f.time <= duration]
    return {
        "faults.in_flight_count": len(inside),
        "faults.in_flight_total_drop": float(sum(f.soc_drop for f in inside)),
    }


def _RowOf(line: bytes) -> dict | None:
    """The row of one line of ``rows.jsonl``, or None when it is not a whole row."""
    try:
        row = json.loads(line)
    except ValueError:  # also UnicodeDecodeError: a cut line
        return None
    return row if isinstance(row, dict) and isinstance(row.get("id"), str) else None


def _SplitRows(data: bytes) -> tuple[list[tuple[bytes, dict]], list[bytes]]:
    """(whole rows as (line, row), the other lines) of the bytes of ``rows.jsonl``.

    A kill while a row is written leaves a cut last line without its newline. Files written
    before the cut line was set aside may hold one with a whole row glued after it (the next
    row was appended to it): that row is kept (the longest suffix of the line that is a whole
    row), the cut part is not.
    """
    rows, other = [], []
    for line in data.split(b"\n"):
        if not line.strip():
            continue
        row = _RowOf(line)
        if row is not None:
            rows.append((line, row))
            continue
        start = line.find(b"{", 1)
        while start > 0 and (row := _RowOf(line[start:])) is None:
            start = line.find(b"{", start + 1)
        if row is None:
            other.append(line)
        else:
            rows.append((line[start:], row))
            other.append(line[:start])
    return rows, other


def _ReadRows(path: Path) -> list[dict]:
    """The whole rows of ``path`` (none if it does not exist), one per flight id (the last)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return []
    latest = {row["id"]: row for _, row in _SplitRows(data)[0]}
    return list(latest.values())


def _RepairRows(path: Path) -> None:
    """Before rows are appended: moves the lines of ``path`` that are not whole rows (a line cut
    by a kill) to :data:`TORN_FILE` beside it (appended) and rewrites ``path`` with its whole
    rows, each ending in a newline, so that no row is ever glued onto a cut line."""
    from eaplan_drake.files import AtomicWrite

    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return
    rows, other = _SplitRows(data)
    if not other and (not data or data.endswith(b"\n")):
        return
    if other:
        with (path.parent / TORN_FILE).open("ab") as f:
            f.write(b"".join(line + b"\n" for line in other))
            f.flush()
            os.fsync(f.fileno())
    AtomicWrite(path, lambda f: f.write(b"".join(line + b"\n" for line, _ in rows)), binary=True)


def _SortRows(path: Path, ids: list[str]) -> None:
    """Rewrites ``path`` with one row per flight, in flight order (``ids``), then any rows of
    other flights in file order; only when that changes it."""
    from eaplan_drake.files import AtomicWrite

    data = path.read_bytes()
    rows, other = _SplitRows(data)
    if other:  # not expected after _RepairRows; leave the file as it is
        return
    latest = {row["id"]: line for line, row in rows}
    known = [i for i in dict.fromkeys(ids) if i in latest]
    order = known + [i for i in latest if i not in set(known)]
    text = b"".join(latest[i] + b"\n" for i in order)
    if text != data:
        AtomicWrite(path, lambda f: f.write(text), binary=True)


_WATCHED_PARENT = None


def _WatchParent(parent: int) -> None:
    """In a worker process (not ``parent`` itself): a daemon thread that ends the process within
    a quarter second once its parent ``parent`` is gone (it is then re-parented), so that a
    killed study leaves no worker flying. Started once per process."""
    global _WATCHED_PARENT
    if os.getpid() == parent or _WATCHED_PARENT == parent:
        return
    _WATCHED_PARENT = parent

    def watch():
        while os.getppid() == parent:
            time.sleep(0.25)
        os._exit(1)

    threading.Thread(target=watch, name="eaplan-watch-parent", daemon=True).start()


def _FlyInWorker(keys: dict, scenario: Scenario, save_logs: str, parent: int) -> dict:
    """:func:`FlyRow` in a loky worker process, watching its parent (:func:`_WatchParent`)."""
    _WatchParent(parent)
    return FlyRow(keys, scenario, save_logs)


def _FailedRow(keys: dict, scenario: Scenario, why: str) -> dict:
    """The error row of a flight the cluster could not fly (``why``: one line)."""
    row = dict(keys, id=ScenarioHash(scenario), error=why)
    row.update(status="error", completed=False, wall_time=None)
    return row


def CheckJobs(n_jobs, name: str = "n_jobs") -> int:
    """``n_jobs`` if it is an integer in [1, :data:`MAX_JOBS`] or -1 (one per core); else
    ValueError naming ``name`` and the range."""
    ok = isinstance(n_jobs, int) and not isinstance(n_jobs, bool)
    if not (ok and (1 <= n_jobs <= MAX_JOBS or n_jobs == -1)):
        raise ValueError(
            f"{name}: must be an integer in [1, {MAX_JOBS}] or -1 (one per core), got {n_jobs!r}"
        )
    return n_jobs


def _CheckBackend(backend: str, n_jobs, wait_for_workers) -> tuple[int | None, float | None]:
    """(n_jobs, wait [s]) of :func:`RunStudy`'s arguments: n_jobs checked for ``loky`` (default
    1), the wait for ``dask`` (where n_jobs must not be given)."""
    if backend not in ("loky", "dask"):
        raise ScenarioError(f"backend: must be loky or dask, got {backend!r}")
    if backend == "dask":
        if n_jobs is not None:
            raise ValueError(
                "n_jobs: not used with backend dask (the cluster's workers and their threads "
                "set how many flights fly at once)"
            )
        return None, Wait(wait_for_workers)
    return CheckJobs(1 if n_jobs is None else n_jobs), None


def _ProgressBar(total: int, initial: int):
    """A tqdm progress bar over ``total`` flights, ``initial`` of them flown (None without
    tqdm)."""
    try:
        from tqdm import tqdm

        return tqdm(total=total, initial=initial, unit="flight")
    except ImportError:
        return None


def _FlyOnDask(scheduler, todo: list, logs: str, write, *, wait: float, say) -> None:
    """Flies the ``todo`` (keys, scenario) pairs on the Dask cluster (:func:`MapOnDask`),
    ``write`` called with each row (a flight the cluster could not fly: its error row)."""
    MapOnDask(
        scheduler,
        FlyRow,
        [(k, s, logs) for k, s in todo],
        names=[f"w{k['world']}-{k['policy']}" for k, _ in todo],
        on_result=lambda i, row: write(row),
        on_failure=lambda i, why: write(_FailedRow(*todo[i], why)),
        wait=wait,
        say=say,
    )


def _FlyOnLoky(todo: list, logs: str, write, *, n_jobs: int) -> None:
    """Flies the ``todo`` (keys, scenario) pairs in ``n_jobs`` loky worker processes,
    ``write`` called with each row as it ends."""
    import joblib

    parent = os.getpid()
    with joblib.parallel_config(backend="loky", n_jobs=n_jobs, inner_max_num_threads=1):
        results = joblib.Parallel(return_as="generator_unordered")(
            joblib.delayed(_FlyInWorker)(k, s, logs, parent) for k, s in todo
        )
        for row in results:
            write(row)


def RunStudy(
    study: Study,
    out: str | Path,
    *,
    directory: str | Path = ".",
    n_jobs: int | None = None,
    backend: str = "loky",
    scheduler=None,
    save_logs: bool = False,
    progress: bool = True,
    wait_for_workers: float = WAIT_FOR_WORKERS,
) -> list[dict]:
    """Flies every flight of ``study`` not yet in ``out``/rows.jsonl and returns all rows (in
    flight order). See the module docstring for backends and resuming.

    Args:
        n_jobs: loky worker processes (default 1: in this process; -1: one per core); not
            used with ``backend="dask"``, where the workers and their threads set how many
            flights fly at once (ValueError if given).
        backend: ``loky`` or ``dask``.
        scheduler: with ``dask``, a scheduler address (``tcp://host:8786``) or a
            ``distributed.Client``.
        progress: a progress bar and the waiting lines on stderr.
        wait_for_workers: [s] with ``dask``: how long to wait for the scheduler to answer and,
            at the start or later, for a worker to be connected;
            :class:`~eaplan_drake.studies.cluster.ClusterError` after it.
    """
    n_jobs, wait = _CheckBackend(backend, n_jobs, wait_for_workers)
    total = StudyFlightCount(study.Validate())
    if progress:  # within a second, before the worlds are built
        print(f"preparing {total} flights of {study.name} …", file=sys.stderr, flush=True)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows_path = out / ROWS_FILE
    flights = StudyFlights(study, directory)
    ids = [ScenarioHash(s) for _, s in flights]
    _RepairRows(rows_path)
    done = {r["id"]: r for r in _ReadRows(rows_path)}
    todo = [(k, s) for (k, s), i in zip(flights, ids, strict=True) if i not in done]
    logs = str(out / "logs") if save_logs else ""
    bar = _ProgressBar(len(flights), len(flights) - len(todo)) if progress else None

    def say(text: str) -> None:
        if bar is not None:
            bar.write(text, file=sys.stderr)
        elif progress:
            print(text, file=sys.stderr, flush=True)

    with rows_path.open("a") as f:

        def write(row: dict) -> None:
            row = JsonSafe(row)
            f.write(json.dumps(row, allow_nan=False) + "\n")
            f.flush()
            os.fsync(f.fileno())
            done[row["id"]] = row
            if bar is not None:
                bar.update(1)

        try:
            if todo and backend == "dask":
                _FlyOnDask(scheduler, todo, logs, write, wait=wait, say=say)
            elif todo:
                _FlyOnLoky(todo, logs, write, n_jobs=n_jobs)
        finally:
            if bar is not None:
                bar.close()
    if all(i in done for i in ids):
        _SortRows(rows_path, ids)
    return [done[i] for i in ids if i in done]


def WilsonInterval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a proportion (0, 1 for n = 0)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    d = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / d
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, centre - half), min(1.0, centre + half)


def SummaryTable(rows: list[dict]) -> str:
    """The Markdown table per policy (see :func:`StudyReport`)."""
    by: dict[str, dict[int, dict]] = {}
    for r in rows:
        by.setdefault(r["policy"], {})[r["world"]] = r
    feasible = {w for w, r in by.get(LOWEST, {}).items() if r.get("completed")}
    lines = [
        "| policy | flights | completed [95 % CI] | completed where lowest does | quality mean "
        "(q10, q50, q90) | final margin (median) | P (median) | errors |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for policy, runs in by.items():
        n = len(runs)
        done = [r for r in runs.values() if r.get("completed")]
        lo, hi = WilsonInterval(len(done), n)
        on_feasible = [runs[w] for w in feasible if w in runs]
        nf = sum(r.get("completed", False) for r in on_feasible)
        q = np.array([r["quality"] for r in runs.values() if r.get("quality") is not None])
        margins = [r["final_margin"] for r in done]
        metrics = [r["metric"] for r in done if r.get("metric") is not None]
        errors = sum(r["status"] == "error" for r in runs.values())
        quality = (
            f"{q.mean():.3f} ({np.quantile(q, 0.1):.2f}, {np.quantile(q, 0.5):.2f}, "
            f"{np.quantile(q, 0.9):.2f})"
            if q.size
            else "–"
        )
        lines.append(
            f"| {policy} | {n} | {len(done)} ({100 * len(done) / n:.0f} %) "
            f"[{100 * lo:.0f}, {100 * hi:.0f}] % | {nf}/{len(on_feasible)} | {quality} | "
            f"{np.median(margins):.3f} | "
            f"{np.median(metrics) if metrics else float('nan'):.2f} | {errors} |"
            if margins
            else f"| {policy} | {n} | 0 | {nf}/{len(on_feasible)} | {quality} | – | – | {errors} |"
        )
    return "\n".join(lines)


def StudyReport(out: str | Path) -> Path:
    """Writes ``report.md`` (the table per policy) and ``quality.png``, ``completion.png``
    (completion against wind speed and against total fault size), ``margin.png`` (quality
    against final margin) into ``out`` from its rows; returns the report's path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from eaplan_drake.files import AtomicWrite

    out = Path(out)
    rows = _ReadRows(out / ROWS_FILE)
    if not rows:
        raise ScenarioError(f"{out / ROWS_FILE}: no rows (run the study first)")
    policies = list(dict.fromkeys(r["policy"] for r in rows))
    ok = [r for r in rows if r["status"] != "error"]

    def save(fig, name):
        AtomicWrite(out / name, lambda f: fig.savefig(f, format="png", dpi=110), binary=True)
        plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    data = [[r["quality"] for r in ok if r["policy"] == p] or [0.0] for p in policies]
    ax.boxplot(data, tick_labels=policies)
    ax.set_ylabel("quality mean(½c̃1 + ½c̃2) [-]")
    ax.set_title("quality per policy (all flights)")
    save(fig, "quality.png")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, key, label in (
        (axes[0], "wind_speed", "wind speed [m/s]"),
        (axes[1], "faults.in_flight_total_drop", "total size of the faults met in flight [SoC]"),
    ):
        # rows written before the in-flight count carry the drawn total under its old name
        values = np.array([r.get(key, r.get("total_fault_drop", 0.0)) for r in ok])
        edges = np.unique(np.quantile(values, np.linspace(0, 1, 6))) if values.size else [0, 1]
        centres = 0.5 * (np.asarray(edges[1:]) + np.asarray(edges[:-1]))
        for p in policies:
            rp = [r for r in ok if r["policy"] == p]
            rate = []
            for a, b in itertools.pairwise(edges):
                sel = [r for r in rp if a <= r.get(key, r.get("total_fault_drop", 0.0)) <= b]
                rate.append(np.mean([r["completed"] for r in sel]) if sel else np.nan)
            ax.plot(centres, rate, "o-", label=p)
        ax.set_xlabel(label)
        ax.set_ylabel("completion rate [-]")
        ax.set_ylim(-0.05, 1.05)
        ax.legend()
    save(fig, "completion.png")

    fig, ax = plt.subplots(figsize=(7, 4))
    for p in policies:
        rp = [r for r in ok if r["policy"] == p and r["completed"]]
        ax.plot([r["final_margin"] for r in rp], [r["quality"] for r in rp], ".", label=p)
    ax.set_xlabel("final margin b(t_f) − reserve [-]")
    ax.set_ylabel("quality [-]")
    ax.legend()
    save(fig, "margin.png")

    text = (
        f"# Study report: {len(rows)} flights\n\n{SummaryTable(rows)}\n\n"
        "![quality](quality.png)\n\n![completion](completion.png)\n\n![margin](margin.png)\n"
    )
    report = out / "report.md"
    AtomicWrite(report, lambda f: f.write(text), binary=False)
    return report
