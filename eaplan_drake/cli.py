"""Command line: ``eaplan-drake simulate | diagram | compare``.

- ``eaplan-drake simulate SCENARIO [--out DIR] [--replay]``: SCENARIO is a shipped name (plan_I,
  plan_II, plan_i, plan_ii) or a YAML path; prints progress and the summary, writes the log and
  the plots (and with ``--replay`` the Meshcat replay ``replay.html``).
- ``eaplan-drake diagram [--out DIR]``: DOT and SVG of the closed loop and each subsystem.
- ``eaplan-drake compare [--out DIR]``: the four reference flights next to the paper's numbers.
- ``eaplan-drake fit LOG.csv [--period T | --period-log FILE] [--out DIR]``: fit the energy
  model to a power log (first half), print its prediction errors against three baselines (second
  half), write a plot and a scenario fragment with the fitted parameters.

A bad scenario is one line on stderr and exit status 2, never a traceback.

BLAS threads: unless the user has set ``OPENBLAS_NUM_THREADS``, this module sets it to 1 before
numpy is first imported (the console entry point imports it first). Every matrix here is small
(m ≤ 130 states), where OpenBLAS's threads only contend: on a loaded 2-core machine a 98×98
product took 5.6 ms with its default threads and 0.11 ms with one, which made ``fit`` crawl.
The numbers do not depend on it (tested: ``fit`` writes the same fragment with 1 and 2 threads).
"""

import os
import sys

# Before numpy is first imported (see the module docstring); a user's own setting wins.
BLAS_THREADS_SET_BEFORE_NUMPY = "numpy" not in sys.modules
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses as dc  # noqa: E402
import signal  # noqa: E402
import textwrap  # noqa: E402
import threading  # noqa: E402
from pathlib import Path  # noqa: E402

from eaplan_drake import __version__  # noqa: E402
from eaplan_drake.errors import MissingExtraError, ScenarioError  # noqa: E402
from eaplan_drake.field.command import AddPlanParser  # noqa: E402
from eaplan_drake.loading import OverrideFromAssignment, ShippedFile, ShippedNames  # noqa: E402
from eaplan_drake.output.reference import (  # noqa: E402
    PAPER_RESULTS,
    CompareScenarios,
    CompareTable,
)
from eaplan_drake.rates import RATE_PRESETS  # noqa: E402
from eaplan_drake.registry import POLICIES, POWER_LOG_READERS  # noqa: E402

__all__ = ["MakeParser", "main"]


def _Simulate(args) -> int:
    ShippedFile(args.scenario, "scenarios")  # before the slow pydrake import
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.output.progress import FlightProgress, ProgressBar
    from eaplan_drake.output.save import SaveFlight
    from eaplan_drake.output.summary_text import FormatSummary
    from eaplan_drake.resolve import ResolveScenario
    from eaplan_drake.simulation import Simulate

    overrides = [OverrideFromAssignment(a) for a in args.set]
    if args.rates or args.with_files:  # the preset, then the --with files, then --set
        from eaplan_drake.files import ReadTextFile
        from eaplan_drake.loading import MAX_SCENARIO_BYTES, LayerScenario
        from eaplan_drake.rates import WithRates

        scenario = LoadNamedScenario(args.scenario)
        scenario = WithRates(scenario, args.rates) if args.rates else scenario
        for path in args.with_files:  # a scenario fragment (fit's fit.yaml), validated
            try:
                text = ReadTextFile(Path(path), MAX_SCENARIO_BYTES, ScenarioError)
                scenario = LayerScenario(scenario, [text])
            except ScenarioError as e:
                line = _OneLine(e)  # LayerScenario's "override 1" is this file
                line = path + line[10:] if line.startswith("override 1") else line
                where = "" if line.startswith(path) else f"{path}: "
                raise ScenarioError(f"--with {where}{line}") from None
        scenario = LayerScenario(scenario, overrides)
        suffixes = ([args.rates] if args.rates not in ("", "paper") else []) + [
            Path(path).stem for path in args.with_files
        ]
        scenario.name = "_".join([scenario.name, *suffixes])
    else:
        scenario = LoadNamedScenario(args.scenario, overrides)
    if args.policy:
        scenario.planner.policy = args.policy
        scenario.name = f"{scenario.name}_{args.policy}"
        scenario.Validate()
    resolved = ResolveScenario(scenario)  # every scenario error before the flight, resolved once
    out = Path(args.out) / scenario.name
    out.parent.mkdir(parents=True, exist_ok=True)  # and an unusable --out
    print(f"simulating {scenario.name} ...", file=sys.stderr, flush=True)
    bar = ProgressBar(scenario.name)
    log = Simulate(resolved, progress=FlightProgress(scenario, bar), progress_interval=2.0)
    bar.Close(log.summary["end_reason"], fraction=1.0)
    written = [f.name for f in SaveFlight(log, scenario, out, replay=args.replay)]
    print(FormatSummary(log.summary))
    print(f"log and plots in {out} ({', '.join(written)})")
    return 0


def _Diagram(args) -> int:
    from eaplan_drake.output.graphviz import WriteDiagrams

    written = WriteDiagrams(args.out)
    print(f"wrote {len(written)} files to {args.out}")
    if not any(p.suffix == ".svg" for p in written):
        print("note: Graphviz's `dot` was not found, so no SVG was rendered", file=sys.stderr)
    return 0


def _Compare(args) -> int:
    from eaplan_drake.output.progress import FlightProgress, ProgressBar
    from eaplan_drake.output.save import SaveFlight
    from eaplan_drake.simulation import Simulate

    scenarios = CompareScenarios([OverrideFromAssignment(a) for a in args.set])
    n = len(scenarios)
    bar = ProgressBar(f"compare: {n} flights")
    if args.jobs != 1:  # the studies' machinery: joblib's loky workers ([sweep] extra)
        try:
            import joblib
        except ImportError:
            raise MissingExtraError(
                "compare --jobs needs the [sweep] extra: pip install -e '.[sweep]'"
            ) from None
        logs = []
        results = joblib.Parallel(n_jobs=args.jobs, return_as="generator")(
            joblib.delayed(Simulate)(s) for _, s in scenarios
        )
        for i, log in enumerate(results):  # in order: the bar counts finished flights
            logs.append(log)
            bar.Update((i + 1) / n, f"{i + 1}/{n} flights done")
    else:
        logs = []
        for i, (_, s) in enumerate(scenarios):
            logs.append(Simulate(s, FlightProgress(s, bar, i, n), progress_interval=5.0))
    bar.Close(f"{n}/{n} flights done", fraction=1.0)
    rows = []
    for (name, scenario), log in zip(scenarios, logs, strict=True):
        if args.out:
            SaveFlight(log, scenario, Path(args.out) / scenario.name)
        rows.append((scenario.name, log.summary, PAPER_RESULTS[name]))
    if args.out:  # the same world flown by several policies, side by side
        from eaplan_drake.output.plots import SavePolicyComparison

        for base in dict.fromkeys(name for name, _ in scenarios):
            flights = [(s, log) for (n, s), log in zip(scenarios, logs, strict=True) if n == base]
            if len(flights) > 1:
                SavePolicyComparison(
                    {log.summary["policy"]: log for _, log in flights},
                    flights[0][0],
                    Path(args.out) / f"{base}_policies.png",
                )
    print(CompareTable(rows))
    return 0


def _CheckBackend(args, command: str) -> None:
    """The extra and the --backend/--jobs/--scheduler combination of a command that flies a
    study (sweep, certify); raises MissingExtraError or ValueError with one line."""
    import importlib

    needed = "distributed" if args.backend == "dask" else "joblib"
    try:
        importlib.import_module(needed)
    except ImportError:
        raise MissingExtraError(
            f"{command} needs the [sweep] extra: pip install -e '.[sweep]'"
        ) from None
    from eaplan_drake.studies.cluster import Wait
    from eaplan_drake.studies.sweep import CheckJobs

    if args.backend == "dask":
        if not args.scheduler:
            raise ValueError("--backend dask needs --scheduler ADDRESS (tcp://host:8786)")
        if args.jobs is not None:
            raise ValueError(
                "--jobs: not used with --backend dask (the cluster's workers and their threads "
                "set how many flights fly at once)"
            )
        Wait(args.wait_for_workers, "--wait-for-workers")
    elif args.scheduler:
        raise ValueError("--scheduler: only with --backend dask")
    else:
        CheckJobs(1 if args.jobs is None else args.jobs, "--jobs")


def _FlyStudy(study, directory, args, save_logs: bool = False):
    """The rows of ``study`` flown into ``args.out`` on the chosen backend; None (after one
    line) when the cluster did not fly it."""
    from eaplan_drake.studies.cluster import ClusterError
    from eaplan_drake.studies.sweep import RunStudy

    try:
        return RunStudy(
            study,
            args.out,
            directory=directory,
            n_jobs=args.jobs,
            backend=args.backend,
            scheduler=args.scheduler or None,
            save_logs=save_logs,
            wait_for_workers=args.wait_for_workers,
        )
    except ClusterError as e:
        print(f"eaplan-drake: cluster error: {_OneLine(e)}", file=sys.stderr)
        return None


def _Sweep(args) -> int:
    _CheckBackend(args, "sweep")
    from eaplan_drake.studies.study import LoadStudy
    from eaplan_drake.studies.sweep import StudyReport

    study, directory = LoadStudy(ShippedFile(args.study, "studies")[0])
    if args.rates:
        study = dc.replace(study, rates=args.rates)
    rows = _FlyStudy(study, directory, args, save_logs=args.save_logs)
    if rows is None:
        return 3
    report = StudyReport(args.out)
    errors = sum(r["status"] == "error" for r in rows)
    print(f"{len(rows)} flights ({errors} errors); report in {report}")
    print(report.read_text().split("\n\n")[1])
    return 0


def _Certify(args) -> int:
    _CheckBackend(args, "certify")
    from eaplan_drake.studies.certify import RunCertify

    return RunCertify(args, lambda study: _FlyStudy(study, ".", args))


def _StudyReport(args) -> int:
    from eaplan_drake.studies.sweep import StudyReport

    report = StudyReport(args.directory)
    print(report.read_text().split("\n\n")[1])
    print(f"report in {report}")
    return 0


def _Fit(args) -> int:
    from eaplan_drake.files import AtomicWrite
    from eaplan_drake.logfit.fit import FRAGMENT_ORDERS, FitPowerLog, PlotLogFit
    from eaplan_drake.logfit.powerlog import ReadPeriodLog
    from eaplan_drake.logfit.readers import ReadAnyPowerLog
    from eaplan_drake.logfit.result import NOISE_CRITERIA_TEXT, SCENARIO_MAX_ORDER
    from eaplan_drake.logfit.scores import FormatScores

    if args.period is not None and args.period_log:
        raise ValueError("--period, --period-log: give one of them, not both")
    period_log = ReadPeriodLog(args.period_log, args.period_log_step) if args.period_log else None
    log = ReadAnyPowerLog(
        args.log,
        args.reader,
        time_column=args.time_column,
        power_column=args.power_column,
        voltage_column=args.voltage_column,
        current_column=args.current_column,
        time_scale=args.time_scale,
        time_step=args.time_step,
    )
    orders = FRAGMENT_ORDERS
    if args.orders:
        cells = [v.strip() for v in args.orders.split(",")]
        if not all(v.isdigit() and int(v) <= SCENARIO_MAX_ORDER for v in cells):
            raise ValueError(
                f"--orders: comma-separated integers in [0, {SCENARIO_MAX_ORDER}] (the "
                f"largest energy_model.order of a scenario), got {args.orders!r}"
            )
        orders = [int(v) for v in cells]
    result = FitPowerLog(
        log.times,
        log.power,
        args.period,
        orders=orders,
        aperiodic=not args.no_aperiodic,
        period_log=period_log,
    )
    fit = result.fit
    print(f"log             {log.source}")
    print(
        f"samples         {result.power.size} at {fit.time_step:.3g} s ({result.times[-1]:.0f} s)"
    )
    print(f"period          {fit.period:.2f} s ({result.period_source})")
    print(
        f"model           {fit.model_name} (order r = {fit.order}; "
        f"noise by {NOISE_CRITERIA_TEXT[fit.noise_criterion]})"
    )
    cells = [f"{name} (q_0 {lv:.2g}): {v:.3g}" for _, lv, v, name in fit.candidates]
    print("candidates      held-out score [W²] (q_0 [W²/step]):")
    print(textwrap.fill(", ".join(cells), 100, initial_indent=" " * 16, subsequent_indent=" " * 16))
    n = fit.noise
    print(
        f"noise           R = {n.measurement_noise:.3g} W², q_n = {n.process_noise:.3g} W², "
        f"q_0 = {n.mean_process_noise:.3g} W² per {fit.time_step:.3g} s, "
        f"tau = {n.aperiodic_time_constant:.3g} s, q_d = {n.aperiodic_noise:.3g} W²/s"
    )
    print(FormatScores(result.scores))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fragment = fit.ScenarioFragment()
    AtomicWrite(out / "fit.yaml", lambda f: f.write(fragment), binary=False)
    fig = PlotLogFit(result)
    AtomicWrite(out / "fit.png", lambda f: fig.savefig(f, format="png", dpi=110), binary=True)
    print(f"wrote {out / 'fit.yaml'} (for simulate) and {out / 'fit.png'}")
    return 0


def MakeParser() -> argparse.ArgumentParser:
    """The command line's parser: one subcommand per job, each added by its own function."""
    parser = argparse.ArgumentParser(
        prog="eaplan-drake",
        description="Energy-aware planning-scheduling for fixed-wing UAVs (Drake).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    _AddSimulateParser(sub)
    _AddDiagramParser(sub)
    _AddCompareParser(sub)
    _AddSweepParser(sub)
    _AddCertifyParser(sub)
    _AddFitParser(sub)
    _AddStudyReportParser(sub)
    AddPlanParser(sub)
    return parser


def _AddSimulateParser(sub) -> None:
    """The ``simulate`` subcommand's arguments."""
    p = sub.add_parser("simulate", help="fly one scenario; print the summary; write log and plots")
    p.add_argument(
        "scenario",
        help=f"shipped name ({', '.join(ShippedNames('scenarios'))}) or YAML path",
    )
    p.add_argument("--out", default="out", help="output directory (default: out/)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override one scenario key (YAML value, validated like the file); repeatable",
    )
    p.add_argument(
        "--policy",
        choices=POLICIES.Names(),
        default="",
        help="fly with this planner policy instead of the scenario's (name gets a suffix)",
    )
    p.add_argument(
        "--replay",
        action="store_true",
        help="also write replay.html: a 3-D Meshcat replay that opens offline in a browser",
    )
    p.add_argument(
        "--rates",
        choices=tuple(RATE_PRESETS),
        default="",
        help="fly at a rate preset (fast = 20 Hz plant, 10 Hz averaging sensor and filter, the "
        "studies' default; paper = 100 Hz), before --set (name gets a suffix)",
    )
    p.add_argument(
        "--with",
        dest="with_files",
        action="append",
        default=[],
        metavar="FILE",
        help="layer a scenario fragment (YAML, e.g. fit's fit.yaml) over the scenario, validated "
        "like the file; after --rates, before --set; repeatable (name gets the file's stem)",
    )
    p.set_defaults(run=_Simulate)


def _AddDiagramParser(sub) -> None:
    """The ``diagram`` subcommand's arguments."""
    p = sub.add_parser("diagram", help="write DOT and SVG of the closed loop and its systems")
    p.add_argument("--out", default="diagrams", help="output directory (default: diagrams/)")
    p.set_defaults(run=_Diagram)


def _AddCompareParser(sub) -> None:
    """The ``compare`` subcommand's arguments."""
    p = sub.add_parser(
        "compare", help="the four reference flights next to the paper's numbers, and i, ii with mpc"
    )
    p.add_argument("--out", default="", help="also write each flight's log and plots here")
    p.add_argument("--jobs", type=int, default=1, help="parallel flights ([sweep] extra)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override a key of every flight (repeatable), e.g. simulation.time_limit=60",
    )
    p.set_defaults(run=_Compare)


def _AddBackendArguments(p) -> None:
    """Where a study's flights run (sweep, certify): --jobs, --backend, --scheduler and
    --wait-for-workers (checked together by :func:`_CheckBackend`)."""
    p.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="loky worker processes (default 1: flights in this process; -1 = one per core); "
        "not with --backend dask",
    )
    p.add_argument(
        "--backend",
        choices=("loky", "dask"),
        default="loky",
        help="where flights run: loky = --jobs worker processes on this machine (default); "
        "dask = the workers of a running Dask cluster (--scheduler), as many at once as they "
        "have threads",
    )
    p.add_argument("--scheduler", default="", help="Dask scheduler address (backend dask)")
    p.add_argument(
        "--wait-for-workers",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="backend dask: how long to wait for the scheduler and, at the start or later, for "
        "a connected worker before giving up (default 60)",
    )


def _AddSweepParser(sub) -> None:
    """The ``sweep`` subcommand's arguments."""
    p = sub.add_parser(
        "sweep",
        help="fly a study (sweep / Monte Carlo) and write its report",
        description="Fly a study and write rows.jsonl, report.md and figures in --out; running "
        "it again flies only the flights without a row. Exit status 2: bad input or missing "
        "extra; 3: the Dask cluster did not fly the study (no scheduler, no worker for "
        "--wait-for-workers seconds, scheduler lost).",
    )
    p.add_argument("study", help="shipped study (robustness, battery_size) or YAML path")
    p.add_argument("--out", required=True, help="output directory (rows.jsonl, report.md)")
    _AddBackendArguments(p)
    p.add_argument("--save-logs", action="store_true", help="also save every flight's log")
    p.add_argument(
        "--rates",
        choices=(*RATE_PRESETS, "scenario"),
        default="",
        help="rates of every flight (default: the study's, else fast = 20 Hz plant, 10 Hz "
        "averaging sensor and filter; paper = 100 Hz; scenario = the base scenario's own)",
    )
    p.set_defaults(run=_Sweep)


def _AddCertifyParser(sub) -> None:
    """The ``certify`` subcommand's arguments."""
    from eaplan_drake.studies.certify_options import CERTIFY_DESCRIPTION, AddCertifyArguments

    p = sub.add_parser(
        "certify",
        help="measure a scenario's excess-failure rate over random worlds and certify its risk",
        description=CERTIFY_DESCRIPTION,
    )
    AddCertifyArguments(p)
    _AddBackendArguments(p)
    p.set_defaults(run=_Certify)


def _AddFitParser(sub) -> None:
    """The ``fit`` subcommand's arguments."""
    p = sub.add_parser("fit", help="fit the energy model to a power log; score its predictions")
    p.add_argument(
        "log",
        help="CSV (PX4 battery_status, Paparazzi energy log, or t/power columns) or a PX4 ULog "
        "(.ulg: its battery_status topic; [ulog] extra)",
    )
    p.add_argument(
        "--reader",
        choices=POWER_LOG_READERS.Names(),
        default="",
        help="how to read LOG (default: by its suffix, .ulg = ulog, else csv)",
    )
    p.add_argument("--period", type=float, default=None, help="T [s] (default: estimated)")
    p.add_argument(
        "--period-log",
        default="",
        metavar="CSV",
        help="the period in force over the flight: rows (step, T [s]) as the authors' "
        "perioddata.csv; t = step × --period-log-step on the log's clock from its first sample",
    )
    p.add_argument(
        "--period-log-step",
        type=float,
        default=0.01,
        help="seconds per step of --period-log (default 0.01: the authors' control loop)",
    )
    p.add_argument("--out", default="fit", help="output directory (default: fit/)")
    p.add_argument("--time-column", default=None, help="name or 0-based index")
    p.add_argument("--power-column", default=None, help="name or 0-based index")
    p.add_argument("--voltage-column", default=None, help="name or index (power = V × I)")
    p.add_argument("--current-column", default=None, help="name or index (power = V × I)")
    p.add_argument("--time-scale", type=float, default=None, help="seconds per time unit")
    p.add_argument("--time-step", type=float, default=None, help="[s], logs without time")
    p.add_argument(
        "--orders",
        default="",
        help="candidate Fourier orders, e.g. 0,1,2,3 (default 0,1,2,3,4,6,8,12,16; at most 20, "
        "as a scenario's energy_model.order)",
    )
    p.add_argument("--no-aperiodic", action="store_true", help="the paper's model (no AR(1))")
    p.set_defaults(run=_Fit)


def _AddStudyReportParser(sub) -> None:
    """The ``study-report`` subcommand's arguments."""
    p = sub.add_parser("study-report", help="the report of a study directory")
    p.add_argument("directory")
    p.set_defaults(run=_StudyReport)


def main(argv=None) -> int:
    parser = MakeParser()
    args = parser.parse_args(argv)
    previous = _ExitOnSigterm()
    try:
        return args.run(args)
    except MissingExtraError as e:
        print(f"eaplan-drake: missing extra: {_OneLine(e)}", file=sys.stderr)
        return 2
    except ScenarioError as e:
        print(f"eaplan-drake: scenario error: {_OneLine(e)}", file=sys.stderr)
        return 2
    except (ValueError, UnicodeError, RecursionError) as e:  # bad input found by a loader
        print(f"eaplan-drake: input error: {_OneLine(e)}", file=sys.stderr)
        return 2
    except OSError as e:  # a file that cannot be read or written
        where = f"{e.filename}: " if e.filename else ""
        print(f"eaplan-drake: file error: {where}{e.strerror or _OneLine(e)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("eaplan-drake: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # a bug: still one line; EAPLAN_DRAKE_DEBUG=1 shows the traceback
        if os.environ.get("EAPLAN_DRAKE_DEBUG"):
            raise
        print(
            f"eaplan-drake: internal error: {type(e).__name__}: {_OneLine(e)} "
            "(set EAPLAN_DRAKE_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _ExitOnSigterm():
    """SIGTERM becomes SystemExit(143), so that every temporary file is removed on the way out
    (as on Ctrl-C); returns the previous handler (None off the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def terminate(signum, frame):
        raise SystemExit(128 + signum)

    return signal.signal(signal.SIGTERM, terminate)


def _OneLine(e: BaseException) -> str:
    return " ".join(str(e).split()) or type(e).__name__


if __name__ == "__main__":
    sys.exit(main())
