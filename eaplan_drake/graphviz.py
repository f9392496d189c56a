"""Graphviz DOT (and SVG via ``dot``) of the closed-loop diagram and of each of its systems.

Drake numbers the nodes of ``GetGraphvizString`` by global system ids, which depend on how many
systems the process created before; :func:`CanonicalDot` renumbers them in order of appearance so
the committed files in ``diagrams/`` are reproducible.
"""

import re
import shutil
import subprocess
from pathlib import Path

from eaplan_drake.diagram import MakeEaplanDiagram
from eaplan_drake.params import Scenario

__all__ = ["CanonicalDot", "DiagramDots", "WriteDiagrams"]

_ID = re.compile(r"(digraph _|clusters|cluster|\bs)(\d+)")


def CanonicalDot(dot: str) -> str:
    """Renumbers Drake's system ids in a DOT string 0, 1, 2, … in order of first appearance and
    sorts each run of edge lines."""
    ids: dict[str, int] = {}

    def renumber(m: re.Match) -> str:
        return m.group(1) + str(ids.setdefault(m.group(2), len(ids)))

    lines = _ID.sub(renumber, dot).split("\n")
    # Drake emits the edges of a diagram in an order that varies between processes: sort each
    # run of consecutive edge lines.
    out, edges = [], []
    for line in lines:
        if " -> " in line:
            edges.append(line)
            continue
        out.extend(sorted(edges))
        edges = []
        out.append(line)
    out.extend(sorted(edges))
    return "\n".join(out)


def DiagramDots(scenario: Scenario | None = None) -> dict[str, str]:
    """``{"eaplan": closed loop, "<system>": each subsystem}`` as canonical DOT strings."""
    diagram = MakeEaplanDiagram(scenario or Scenario(), log_period=0.0)
    dots = {"eaplan": CanonicalDot(diagram.GetGraphvizString(max_depth=1))}
    for system in diagram.GetSystems():
        dots[system.get_name()] = CanonicalDot(system.GetGraphvizString())
    return dots


def WriteDiagrams(directory: str | Path, scenario: Scenario | None = None, svg: bool = True):
    """Writes ``<name>.dot`` (and ``<name>.svg`` when Graphviz's ``dot`` is installed) for the
    closed loop and each subsystem. Returns the list of written paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    dot_exe = shutil.which("dot") if svg else None
    written = []
    for name, dot in DiagramDots(scenario).items():
        path = directory / f"{name}.dot"
        path.write_text(dot)
        written.append(path)
        if dot_exe:
            svg_path = directory / f"{name}.svg"
            subprocess.run([dot_exe, "-Tsvg", str(path), "-o", str(svg_path)], check=True)
            written.append(svg_path)
    return written
