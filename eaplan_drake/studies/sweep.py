"""Studies: parameter sweeps and Monte Carlo over many flights, on joblib locally or on a Dask
cluster.

A *study* (YAML, :class:`Study`) names a base scenario, fixed overrides, a grid over named keys,
random draws from named distributions (uniform, normal, choice; battery faults as a random count
with random times and sizes), the policies to compare and a study seed. :func:`StudyFlights`
expands it into flights: every (grid point, draw) is a *world*, flown once per policy (and, with
``lowest_reference``, once with the static lowest-quality plan, so that completion can be reported
on the worlds that plan completes). Draw d of a study with seed s uses
``numpy.random.default_rng([s, d])`` at every grid point (common random numbers: grid points are
compared on the same random worlds), so the same study file gives the same flights on any
machine, in any order and with any number of workers.

:func:`RunStudy` flies them with joblib (``loky`` by default: worker processes are reused, so
pydrake is imported once per worker; BLAS threads capped at one) or, with ``backend="dask"``, on a
Dask cluster through joblib's Dask backend (``scheduler`` = the address of a
``distributed.Scheduler``, or a running ``distributed.Client``). A worker builds its own diagram
from the scenario (scenarios pickle; diagrams do not). Each flight returns one small row
(:func:`FlyRow`); one flight's exception becomes its error row. Rows are appended to
``rows.jsonl`` in the output directory as they finish, one line each, flushed and fsynced; a
re-run of the same study on the same directory skips the flights already there (keyed by a hash
of the resolved scenario), so a study killed at any moment resumes and loses at most the flights
in flight. :func:`StudyReport` writes ``report.md`` and figures from the rows.

On a cluster: start a scheduler and workers with this package installed (e.g. with
``dask-jobqueue``'s ``SLURMCluster(...)`` or ``PBSCluster(...)``, ``cluster.scale(jobs=n)``) and
pass ``--backend dask --scheduler tcp://host:8786`` (or the ``Client`` in Python).
"""

import dataclasses as dc
import hashlib
import itertools
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from eaplan_drake.loading import LayerScenario, OverrideFromAssignment
from eaplan_drake.params import BatteryFault, Scenario, ScenarioError
from eaplan_drake.rates import DEFAULT_STUDY_RATES, RATE_PRESETS, WithRates

__all__ = [
    "FaultDistribution",
    "FlyRow",
    "LoadStudy",
    "RunStudy",
    "Study",
    "StudyFlights",
    "StudyReport",
    "WilsonInterval",
]

ROWS_FILE = "rows.jsonl"
KEEP_RATES = "scenario"
"""``Study.rates`` value that keeps the base scenario's own rates."""
LOWEST = "lowest"
"""Pseudo-policy of the static lowest-quality reference flight."""


@dc.dataclass
class FaultDistribution:
    """Random battery faults: a count, and each fault's time and size, all uniform."""

    count: list[int] = dc.field(default_factory=lambda: [0, 3])
    """[min, max] number of faults (integers, inclusive)."""
    time: list[float] = dc.field(default_factory=lambda: [0.0, 500.0])
    """[min, max] time of a fault [s]."""
    soc_drop: list[float] = dc.field(default_factory=lambda: [0.0, 0.15])
    """[min, max] SoC lost per fault [-] (a drop of 0 is stored as 1e-6)."""


@dc.dataclass
class Study:
    """A study file (YAML). Keys are scenario key paths (``wind.speed``)."""

    name: str = "study"
    base: str = "plan_i"
    """Shipped scenario name or YAML path (relative to the study file)."""
    set: dict = dc.field(default_factory=dict)
    """Fixed overrides, key path → YAML value (as ``--set``)."""
    grid: dict = dc.field(default_factory=dict)
    """Key path → list of YAML values; every combination is flown."""
    uniform: dict[str, list[float]] = dc.field(default_factory=dict)
    """Key path → [low, high]."""
    normal: dict[str, list[float]] = dc.field(default_factory=dict)
    """Key path → [mean, standard deviation]."""
    choice: dict = dc.field(default_factory=dict)
    """Key path → list of YAML values, one drawn uniformly."""
    faults: FaultDistribution | None = None
    """Random battery faults (replace the base's), or none."""
    draws: int = 1
    """Number of random draws per grid point."""
    seed: int = 0
    """Study seed; each draw's ``random_seed`` (hence its sensor noise) derives from it."""
    policies: list[str] = dc.field(default_factory=lambda: ["mpc"])
    """Planner policies flown on every world."""
    lowest_reference: bool = True
    """Also fly every world with the static lowest plan (c1 = c̲1, c2 = c̲2)."""
    rates: str = DEFAULT_STUDY_RATES
    """Rates of every flight: a preset of :data:`~eaplan_drake.rates.RATE_PRESETS` applied to the
    base scenario before ``set`` (:func:`~eaplan_drake.rates.WithRates`): ``fast`` (default;
    20 Hz plant, 10 Hz averaging sensor and filter, README "Rates"), ``paper`` (100 Hz, as
    ``simulate``), or ``scenario`` (the base scenario's own rates)."""


def LoadStudy(filename: str | Path) -> tuple[Study, Path]:
    """The :class:`Study` of a YAML file and the file's directory. ScenarioError (one line
    naming the file and the key) on bad input."""
    from pydrake.common.yaml import yaml_load_data

    path = Path(filename)
    if not path.is_file():
        raise ScenarioError(f"{path}: no such study file")
    try:
        raw = yaml_load_data(data=path.read_text())
    except Exception as e:
        raise ScenarioError(f"{path}: invalid YAML: {' '.join(str(e).split())}") from None
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: a study is a mapping of keys")
    fields = {f.name for f in dc.fields(Study)}
    for key in raw:
        if key not in fields:
            raise ScenarioError(f"{path}: {key}: unknown key (known: {', '.join(sorted(fields))})")
    try:
        if raw.get("faults") is not None:
            raw["faults"] = FaultDistribution(**raw["faults"])
        study = Study(**raw)
    except TypeError as e:
        raise ScenarioError(f"{path}: {e}") from None
    for key in ("set", "grid", "uniform", "normal", "choice"):
        if not isinstance(getattr(study, key), dict):
            raise ScenarioError(f"{path}: {key}: expected a mapping of key paths")
    for key in ("uniform", "normal"):
        for k, v in getattr(study, key).items():
            if not (isinstance(v, list) and len(v) == 2):
                raise ScenarioError(f"{path}: {key}.{k}: expected [a, b], got {v!r}")
    for key in ("grid", "choice"):
        for k, v in getattr(study, key).items():
            if not (isinstance(v, list) and v):
                raise ScenarioError(f"{path}: {key}.{k}: expected a non-empty list, got {v!r}")
    if not (isinstance(study.draws, int) and 1 <= study.draws <= 1_000_000):
        raise ScenarioError(f"{path}: draws: must be an integer in [1, 1000000]")
    if not study.policies:
        raise ScenarioError(f"{path}: policies: needs at least one policy")
    if study.rates not in (*RATE_PRESETS, KEEP_RATES):
        raise ScenarioError(
            f"{path}: rates: must be one of {', '.join((*RATE_PRESETS, KEEP_RATES))}, "
            f"got {study.rates!r}"
        )
    return study, path.parent


def _Value(v) -> str:
    return v if isinstance(v, str) else json.dumps(v)


def StudyFlights(study: Study, directory: Path | str = ".") -> list[tuple[dict, Scenario]]:
    """Every flight of the study as (row keys, scenario): row keys are ``world`` (index),
    ``policy``, ``draw`` and the varied values by key path. Scenarios are validated."""
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
                varied["faults.count"] = n
                varied["faults.total_drop"] = float(np.sum(drops))
            s.random_seed = int(rng.integers(0, 2**31 - 1))
            s.name = f"{study.name}_w{world}"
            for policy in ([LOWEST] if study.lowest_reference else []) + list(study.policies):
                flight = LowestPlan(s) if policy == LOWEST else WithPolicy(s, policy)
                keys = {"world": world, "draw": draw, "policy": policy, **varied}
                flights.append((keys, flight))
            world += 1
    return flights


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
            total_fault_drop=float(sum(f.soc_drop for f in scenario.battery.faults)),
        )
        if save_logs:
            log.Save(Path(save_logs) / f"{row['id']}")
    except Exception as e:  # one flight's error is its row, never the study's end
        row.update(status="error", completed=False, error=f"{type(e).__name__}: {e}")
    row["wall_time"] = time.perf_counter() - t0
    return row


def _ReadRows(path: Path) -> list[dict]:
    rows = []
    if path.is_file():
        with path.open() as f:
            for line in f:
                try:
                    rows.append(json.loads(line))
                except json.JSONDecodeError:  # a line cut by a kill: that flight is re-flown
                    continue
    return rows


def RunStudy(
    study: Study,
    out: str | Path,
    *,
    directory: str | Path = ".",
    n_jobs: int = 1,
    backend: str = "loky",
    scheduler=None,
    save_logs: bool = False,
    progress: bool = True,
) -> list[dict]:
    """Flies every flight of ``study`` not yet in ``out``/rows.jsonl and returns all rows (in
    flight order). See the module docstring for backends and resuming."""
    import joblib

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows_path = out / ROWS_FILE
    flights = StudyFlights(study, directory)
    ids = [ScenarioHash(s) for _, s in flights]
    done = {r["id"]: r for r in _ReadRows(rows_path)}
    todo = [(k, s) for (k, s), i in zip(flights, ids, strict=True) if i not in done]
    logs = str(out / "logs") if save_logs else ""
    client = None
    if backend == "dask":
        from distributed import Client

        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    elif backend != "loky":
        raise ScenarioError(f"backend: must be loky or dask, got {backend!r}")
    bar = None
    if progress:
        try:
            from tqdm import tqdm

            bar = tqdm(total=len(flights), initial=len(flights) - len(todo), unit="flight")
        except ImportError:
            bar = None
    try:
        config = {"inner_max_num_threads": 1} if backend == "loky" else {}
        with joblib.parallel_config(backend=backend, n_jobs=n_jobs, **config):
            results = joblib.Parallel(return_as="generator_unordered")(
                joblib.delayed(FlyRow)(k, s, logs) for k, s in todo
            )
            with rows_path.open("a") as f:
                for row in results:
                    f.write(json.dumps(row, allow_nan=False, default=_Json) + "\n")
                    f.flush()
                    os.fsync(f.fileno())
                    done[row["id"]] = row
                    if bar is not None:
                        bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if client is not None and client is not scheduler:
            client.close()
    return [done[i] for i in ids if i in done]


def _Json(v):
    if isinstance(v, np.generic):
        return v.item()
    raise TypeError(f"not JSON: {v!r}")


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
        (axes[1], "total_fault_drop", "total fault size [SoC]"),
    ):
        values = np.array([r[key] for r in ok])
        edges = np.unique(np.quantile(values, np.linspace(0, 1, 6))) if values.size else [0, 1]
        centres = 0.5 * (np.asarray(edges[1:]) + np.asarray(edges[:-1]))
        for p in policies:
            rp = [r for r in ok if r["policy"] == p]
            rate = []
            for a, b in itertools.pairwise(edges):
                sel = [r for r in rp if a <= r[key] <= b]
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
