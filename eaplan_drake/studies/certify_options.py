"""The ``eaplan-drake certify`` command's options (argparse only: ``--help`` imports nothing
heavy); the run itself is :func:`eaplan_drake.studies.certify.RunCertify`."""

from eaplan_drake.rates import RATE_PRESETS

__all__ = ["SAMPLING_MODES", "AddCertifyArguments", "CERTIFY_DESCRIPTION"]

SAMPLING_MODES = ("plain", "stratified", "importance")
"""How certify draws the battery faults of its worlds."""

CERTIFY_DESCRIPTION = (
    "Draw --worlds random worlds (wind, sensor noise and dropouts in the benchmark's ranges, "
    "battery faults from the scenario's planner.fault_model), fly the static lowest plan and the "
    "scenario's policy on each, and print the excess-failure rate (lost where the lowest plan "
    "completes) with a one-sided 95 % upper bound; 'certified at ε' (planner.risk) only when "
    "that bound is at most ε. The report also says how likely this many worlds are to certify "
    "at the rate measured so far, and how many worlds a claim is likely to need. "
    "Sampling: 'plain' draws the faults as declared and bounds the rate exactly "
    "(Clopper–Pearson). 'stratified' and 'importance' fly --pilot worlds as declared, then "
    "draw the faults inside the flights (the window: the longest pilot flight) more often "
    "where the pilot lost (with fewer than 3 losses: where its drops were largest): "
    "'stratified' chooses how many drops a world gets "
    "(Neyman allocation over the pilot's strata), 'importance' also tilts the drop rate and "
    "sizes (one cross-entropy step). Half of those worlds are still drawn as declared, so every "
    "world's exact weight (its likelihood ratio, in its row with its stratum) is at most 2 and "
    "no stratum is left out. Weighted worlds, and --until-decided, use an anytime-valid bound "
    "(a betting confidence sequence): it stays valid however the run is stopped or extended, "
    "and costs more worlds than counting when the weights do not help. --until-decided flies "
    "--batch worlds at a time and stops once the claim is certified or can no longer pass "
    "(at most --worlds). All modes assume independent worlds from the stated distribution; "
    "a certificate is about that distribution only. Resumes like sweep. "
    "Exit status 2: bad input or missing extra; 3: the Dask cluster did not fly it."
)


def AddCertifyArguments(p) -> None:
    """The ``certify`` subcommand's own arguments (the backend's are added beside them)."""
    p.add_argument("scenario", help="shipped name (plan_i, survey, …) or YAML path")
    p.add_argument("--out", required=True, help="output directory (rows.jsonl, certify.md)")
    p.add_argument(
        "--worlds",
        type=int,
        default=300,
        help="number of worlds (default 300; with --until-decided, the most)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the world draws (default 0)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override a key of the scenario (repeatable), e.g. planner.risk=0.01",
    )
    p.add_argument(
        "--rates",
        choices=(*RATE_PRESETS, "scenario"),
        default="fast",
        help="rates of every flight (default fast; paper = 100 Hz; scenario = its own)",
    )
    p.add_argument(
        "--world-fault-model",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="the faults the worlds draw, apart from the planner's belief (planner.fault_model): "
        "a key of the fault model on a copy of the belief, repeatable, e.g. rate=0.006 "
        "size_bounds=[0.05,0.25]",
    )
    worlds = p.add_mutually_exclusive_group()
    worlds.add_argument(
        "--changing-worlds",
        dest="changing_worlds",
        action="store_true",
        help="worlds that change in flight (the default): gusts, a drifting wind, a pack below "
        "its label and a payload off its table (ranges in the docs); the staircase in the "
        "estimated wind",
    )
    worlds.add_argument(
        "--steady-worlds",
        dest="changing_worlds",
        action="store_false",
        help="worlds that do not change in flight: a constant wind, the nominal pack, the payload "
        "on its table (the worlds of earlier versions)",
    )
    p.set_defaults(changing_worlds=True)
    p.add_argument(
        "--sampling",
        choices=SAMPLING_MODES,
        default="plain",
        help="how the faults are drawn (default plain; see above)",
    )
    p.add_argument(
        "--until-decided",
        action="store_true",
        help="fly --batch worlds at a time, stop once certified or refuted (anytime-valid)",
    )
    p.add_argument(
        "--batch", type=int, default=50, help="worlds per batch with --until-decided (50)"
    )
    p.add_argument(
        "--expect",
        type=float,
        default=None,
        metavar="RATE",
        help="before flying, print how likely --worlds worlds are to certify if the excess-"
        "failure rate is RATE, and how many worlds the claim is likely to need",
    )
    p.add_argument(
        "--pilot",
        type=int,
        default=30,
        help="worlds drawn as declared before a stratified or importance proposal (30)",
    )
