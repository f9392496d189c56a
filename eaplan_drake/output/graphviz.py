"""Graphviz DOT (and SVG via ``dot``) of the closed loop and of each of its systems.

``loop`` is the top-level picture: the systems and the signals between them, without the loggers
and the exported ports (:func:`LoopDot`). ``eaplan`` is Drake's own picture of the whole diagram
(every port), and ``<system>`` each system's ports.

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

__all__ = ["CanonicalDot", "DiagramDots", "LoopConnections", "LoopDot", "WriteDiagrams"]

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


def LoopConnections(diagram) -> list[tuple[str, str, str, str]]:
    """The connections of ``diagram`` between its subsystems as sorted
    ``(source system, output port, destination system, input port)`` name tuples."""
    connections = []
    for (dst, dst_port), (src, src_port) in diagram.connection_map().items():
        connections.append(
            (
                src.get_name(),
                src.get_output_port(src_port).get_name(),
                dst.get_name(),
                dst.get_input_port(dst_port).get_name(),
            )
        )
    return sorted(connections)


def LoopDot(connections, kinds: dict[str, str] | None = None, title: str = "") -> str:
    """A DOT picture of systems (boxes: name and, from ``kinds``, the class) and the signals
    between them: one edge per pair of systems, labelled with each signal (``out → in`` where the
    port names differ). Deterministic: systems and labels in sorted order."""
    kinds = kinds or {}
    names = sorted({c[0] for c in connections} | {c[2] for c in connections})
    labels: dict[tuple[str, str], list[str]] = {}
    for src, out, dst, inp in connections:
        labels.setdefault((src, dst), []).append(out if out == inp else f"{out} → {inp}")
    lines = [
        "digraph loop {",
        "rankdir=TB",
        'graph [fontname="Helvetica", nodesep=0.5, ranksep=0.9'
        + (f', label="{title}", labelloc=t' if title else "")
        + "]",
        'node [shape=box, style="rounded,filled", fillcolor="#eef3fb", fontname="Helvetica"]',
        'edge [fontname="Helvetica", fontsize=10, color="#555555"]',
    ]
    for name in names:
        kind = kinds.get(name, "")
        sub = f'<BR/><FONT POINT-SIZE="10">{kind}</FONT>' if kind else ""
        lines.append(f'"{name}" [label=<<B>{name}</B>{sub}>]')
    for (src, dst), signals in sorted(labels.items()):
        text = "\\n".join(sorted(signals))
        lines.append(f'"{src}" -> "{dst}" [label="{text}"]')
    lines.append("}")
    return "\n".join(lines) + "\n"


def _Kind(system) -> str:
    return re.sub(r"_𝓣.*𝓤$", "", type(system).__name__)


def DiagramDots(scenario: Scenario | None = None) -> dict[str, str]:
    """``{"loop": the top-level picture, "eaplan": the whole diagram with every port,
    "<system>": each subsystem}`` as canonical DOT strings."""
    diagram = MakeEaplanDiagram(scenario or Scenario(), log_period=0.0)
    kinds = {s.get_name(): _Kind(s) for s in diagram.GetSystems()}
    dots = {
        "loop": LoopDot(
            LoopConnections(diagram),
            kinds,
            title="eaplan closed loop: systems and the signals between them",
        ),
        "eaplan": CanonicalDot(diagram.GetGraphvizString(max_depth=1)),
    }
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
