"""Instructions of a policy's flight against the static lowest plan's on the same worlds (the first
worlds that ``eaplan-drake certify`` draws, at the ``fast`` rates), counted by valgrind's
callgrind: :mod:`bench_policy_cpu`'s ratio in a measure that a busy machine does not move.

For each world three processes are counted (:func:`count_instructions.Instructions`): one that
loads the world and flies the lowest plan once (imports, tables and caches), one that then flies
the lowest plan again, and one that then flies the policy; the differences are the two flights'
own instructions. Instructions are a proxy, not the speed (cache misses and branch mispredictions
are not counted): read them beside ``bench_policy_cpu.py``'s CPU ratios. Each process runs ≈ 60×
slower than the flight (a world costs a few minutes). Not a test.

    python3 benchmarks/count_policy_instructions.py [--worlds 0 1 3] [--baseline-tree DIR]
        [--set KEY=VALUE ...]

``--baseline-tree DIR`` counts the package found in DIR too (another checkout, e.g. ``git worktree
add /tmp/baseline <revision>``) and prints both ratios.
"""

import argparse
import json
import shutil
import sys
from pathlib import Path

from count_instructions import Instructions

HERE = Path(__file__).resolve().parent

CHILD = """
import inspect, json, sys
from eaplan_drake.loading import LayerScenario, OverrideFromAssignment
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.certify import CertifyStudy
from eaplan_drake.studies.sweep import StudyFlights
world, mode, settings = int(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])
# certify's steady worlds (a tree from before they were certify's default takes no keyword)
steady = {"changing": False} if "changing" in inspect.signature(CertifyStudy).parameters else {}
flights = StudyFlights(CertifyStudy("survey", world + 1, **steady))
pair = {k["policy"]: s for k, s in flights if k["world"] == world}
policy = next(s for p, s in pair.items() if p != "lowest")
policy = LayerScenario(policy, [OverrideFromAssignment(s) for s in settings])
Simulate(pair["lowest"])
if mode == "lowest":
    Simulate(pair["lowest"])
elif mode == "policy":
    Simulate(policy)
"""


def FlightInstructions(tree: Path, world: int, settings: list[str]) -> tuple[int, int]:
    """(instructions of the lowest plan's flight, of the policy's flight) on ``world``."""
    args = [str(world), "", json.dumps(settings)]
    counts = {}
    for mode in ("warm", "lowest", "policy"):
        args[1] = mode
        counts[mode] = Instructions(tree, CHILD, args, f"world {world} {mode}")[0]
    return counts["lowest"] - counts["warm"], counts["policy"] - counts["warm"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", type=int, nargs="+", default=[0, 1, 3])
    parser.add_argument("--baseline-tree", type=Path, default=None)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("count_policy_instructions: valgrind is not on the PATH (Debian package valgrind)")
        return 2
    trees = [("this", HERE.parent)] + (
        [("baseline", args.baseline_tree)] if args.baseline_tree else []
    )
    print("| world | tree | lowest plan [G instr.] | policy [G instr.] | ratio |")
    print("| --- | --- | --- | --- | --- |")
    for world in args.worlds:
        for name, tree in trees:
            lowest, policy = FlightInstructions(tree, world, args.set)
            print(
                f"| {world} | {name} | {lowest / 1e9:.3f} | {policy / 1e9:.3f} | "
                f"{policy / lowest:.2f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
