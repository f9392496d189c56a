"""The top-level loop picture: systems and the signals between them, nothing else; and the
canonical DOT text the committed diagrams are compared in."""

from eaplan_drake.diagram import LOGGED_SIGNALS
from eaplan_drake.output.graphviz import CanonicalDot, DiagramDots, LoopDot


def test_loop_dot_merges_the_signals_between_two_systems_into_one_edge():
    dot = LoopDot(
        [
            ("a", "y", "b", "u"),
            ("a", "z", "b", "z"),
            ("b", "out", "a", "in"),
        ],
        kinds={"a": "Plant"},
    )
    assert dot.count(" -> ") == 2
    assert '"a" -> "b" [label="y → u\\nz"]' in dot
    assert '"b" -> "a" [label="out → in"]' in dot
    assert "<B>a</B>" in dot and ">Plant</FONT>" in dot
    assert dot.startswith("digraph loop {") and dot.endswith("}\n")


def test_the_loop_picture_shows_the_systems_not_the_loggers_or_exported_ports():
    dot = DiagramDots()["loop"]
    for name in ("wind", "plant", "sequencer", "guidance", "computation", "total_power", "sensor"):
        assert f'"{name}" [label=' in dot
    for name in ("estimator", "battery", "planner"):
        assert f'"{name}" [label=' in dot
    assert "log_" not in dot and "output ports" not in dot
    assert dot.count(" -> ") == 18  # one edge per connected pair of systems
    assert '"kinematics_demux" -> "sequencer" [label="y0 → position"]' in dot
    assert '"planner" -> "sequencer" [label="path_parameters"]' in dot
    assert '"total_power" -> "battery" [label="sum → power"]' in dot
    assert '"total_power" -> "sensor" [label="sum → power"]' in dot
    assert len(LOGGED_SIGNALS) > 10  # the detailed picture still exports every logged signal


def test_canonical_dot_renumbers_ids_in_order():
    a = "digraph _17 {\nsubgraph cluster17diagram {\ns12 -> s13\ns17in:0:e -> s12:u0:w\n}}"
    b = "digraph _4 {\nsubgraph cluster4diagram {\ns2 -> s3\ns4in:0:e -> s2:u0:w\n}}"
    assert CanonicalDot(a) == CanonicalDot(b)
    assert CanonicalDot(a).startswith("digraph _0 {")
