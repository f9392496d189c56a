"""Instructions per simulation step of a flight, counted by valgrind's callgrind: a speed measure
that does not depend on the machine's load (a busy 2-core machine moves CPU times by ±20 %).

Each count runs with ``PYTHONHASHSEED=0``, one BLAS thread and, where ``setarch`` is installed
(util-linux), with address-space randomisation off (``setarch -R``): the instance maps of
pybind11 hash pointers, so with randomised addresses the count of one tree moved by ±1.5 % from
run to run; without randomisation two runs of one tree agreed within 0.2 % (plan i, 85–89 s:
478.6k and 479.4k instructions per step).

    python3 benchmarks/count_instructions.py [--baseline-tree DIR] [--window 10 40] [FLIGHT ...]

Each FLIGHT (a shipped scenario name, default ``plan_i plan_ii``) is built with
``MakeEaplanDiagram`` (loggers at the scenario's ``log_period``, integrator as ``Simulate`` sets
it) and advanced to t0 and, in a second process, to t1 (``--window t0 t1`` [s], default 10 40):
the difference of the two counts, divided by the base ticks in between ((t1 − t0) /
``simulation.max_step``), is the loop's cost per step without the start-up (imports, table and
plan loading). ``--baseline-tree DIR`` counts the package found in DIR too (another checkout,
e.g. ``git worktree add /tmp/baseline <revision>``) and prints the ratio. Needs ``valgrind`` on
the PATH (Debian package ``valgrind``); without it the script says so and exits with status 2. A
window of 30 s costs about a minute per flight and tree (callgrind runs ≈ 50× slower than the
flight).

The count is a proxy, not the speed: cache misses and branch mispredictions are not counted, and
they differ between trees (on plan i, 10–40 s, one tree against an older one: 2.74× fewer
instructions but 3.06× less CPU time in the same bench_flights run). Use it to compare changes of
one tree on a busy machine; the speed-up that counts is ``bench_flights.py``'s.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = """
import sys
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from eaplan_drake.diagram import MakeEaplanDiagram
try:
    from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
except ImportError:  # a baseline tree from before the package layout
    from eaplan_drake.params import LayerScenario, OverrideFromAssignment
    from eaplan_drake.simulation import LoadNamedScenario
scenario = LoadNamedScenario(sys.argv[1])
simulator = Simulator(MakeEaplanDiagram(scenario))
ResetIntegratorFromFlags(
    simulator, scenario.simulation.integrator, scenario.simulation.max_step
)
simulator.Initialize()
simulator.AdvanceTo(float(sys.argv[2]))
print(scenario.simulation.max_step)
"""


def Instructions(tree: Path, child: str, args: list[str], what: str) -> tuple[int, str]:
    """(instructions, standard output) of ``python -c child *args`` with the package in ``tree``
    under callgrind (``PYTHONHASHSEED=0``, address randomisation off where ``setarch`` is)."""
    tree = Path(tree).resolve()  # the child runs in a temporary folder
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1")
    fixed_addresses = ["setarch", "-R"] if shutil.which("setarch") else []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        result = subprocess.run(
            [
                *fixed_addresses,
                "valgrind",
                "--tool=callgrind",
                f"--callgrind-out-file={out}",
                sys.executable,
                "-c",
                child,
                *args,
            ],
            env=env,
            cwd=tmp,
            capture_output=True,
            text=True,
        )
    if result.returncode != 0:
        raise SystemExit(f"{what} with {tree}: the flight failed:\n{result.stderr[-2000:]}")
    match = re.search(r"Collected : ([\d,]+)", result.stderr)
    if match is None:
        raise SystemExit(f"{what} with {tree}: no callgrind count in valgrind's output")
    return int(match.group(1).replace(",", "")), result.stdout


def Count(tree: Path, flight: str, until: float) -> tuple[int, float]:
    """(instructions of a process that flies ``flight`` to ``until`` [s], the base step [s])."""
    count, stdout = Instructions(tree, CHILD, [flight, str(until)], flight)
    return count, float(stdout.split()[-1])


def PerStep(tree: Path, flight: str, window: tuple[float, float]) -> float:
    """Instructions per base step between the window's two times."""
    t0, t1 = window
    start, step = Count(tree, flight, t0)
    end, _ = Count(tree, flight, t1)
    return (end - start) / ((t1 - t0) / step)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("flights", nargs="*", default=["plan_i", "plan_ii"], metavar="FLIGHT")
    parser.add_argument("--baseline-tree", type=Path, default=None)
    parser.add_argument("--window", type=float, nargs=2, default=(10.0, 40.0), metavar=("T0", "T1"))
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("count_instructions: valgrind is not on the PATH (Debian package valgrind)")
        return 2
    t0, t1 = args.window
    if not (0.0 < t0 < t1):
        print(f"--window: need 0 < T0 < T1 [s], got {t0:g} {t1:g}")
        return 2
    this = HERE.parent
    trees = [("this", this)] + ([("baseline", args.baseline_tree)] if args.baseline_tree else [])
    print(f"instructions per base step, flown from {t0:g} s to {t1:g} s (callgrind)\n")
    print(
        "| flight | "
        + " | ".join(name for name, _ in trees)
        + (" | ratio |" if len(trees) > 1 else " |")
    )
    print("| --- " * (len(trees) + 1 + (len(trees) > 1)) + "|")
    for flight in args.flights:
        counts = [PerStep(tree, flight, (t0, t1)) for _, tree in trees]
        cells = [f"{c / 1e3:.0f}k" for c in counts]
        if len(counts) > 1:
            cells.append(f"{counts[1] / counts[0]:.2f}x")
        print(f"| {flight} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
