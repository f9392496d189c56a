"""The closed-loop diagram: systems, exported ports, no algebraic loop, committed DOT files."""

from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from eaplan_drake.diagram import LOGGED_SIGNALS, MakeEaplanDiagram
from eaplan_drake.graphviz import DiagramDots
from eaplan_drake.params import LoadScenario, Scenario

DIAGRAMS = Path(__file__).resolve().parents[1] / "diagrams"
SYSTEMS = {
    "wind",
    "plant",
    "sequencer",
    "guidance",
    "computation",
    "sensor",
    "estimator",
    "battery",
    "planner",
}


def test_every_system_is_named_and_key_ports_are_exported():
    diagram = MakeEaplanDiagram(Scenario())
    names = {s.get_name() for s in diagram.GetSystems()}
    assert SYSTEMS <= names
    assert {f"log_{n}" for n in LOGGED_SIGNALS} <= names
    for port in [*LOGGED_SIGNALS, "mission_complete"]:
        assert diagram.HasOutputPort(port)


def test_short_closed_loop_run_stays_finite():
    diagram = MakeEaplanDiagram(LoadScenario(data="planner: {warmup: 2.0}"), log_period=0.0)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(5.0)  # crosses the warm-up: the planner solves a few times
    ctx = simulator.get_context()
    for port in [*LOGGED_SIGNALS, "mission_complete"]:
        assert np.all(np.isfinite(diagram.GetOutputPort(port).Eval(ctx))), port
    assert diagram.GetSubsystemByName("planner").statistics()["solves"] >= 3


def test_bad_scenario_is_rejected_before_building():
    s = Scenario()
    s.computation.initial_parameters = [10.0, 2.0]  # the PedNet table has one parameter
    with pytest.raises(ValueError, match="computation.initial_parameters"):
        MakeEaplanDiagram(s)


def test_committed_dot_files_match_the_code():
    dots = DiagramDots()
    committed = {p.stem: p.read_text() for p in DIAGRAMS.glob("*.dot")}
    assert set(committed) == set(dots), "run `eaplan-drake diagram` to regenerate diagrams/"
    for name, dot in dots.items():
        assert committed[name] == dot, f"diagrams/{name}.dot is stale: run `eaplan-drake diagram`"
