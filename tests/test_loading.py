"""Loading scenarios: YAML 1.2 booleans, unknown keys, and loads equal to pydrake's
``yaml_load_typed`` (the type walker itself: tests/test_params_walk.py)."""

import dataclasses as dc

import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import (
    LayerScenario,
    LoadNamedScenario,
    LoadScenario,
    OverrideFromAssignment,
    ShippedFile,
    ShippedNames,
)
from eaplan_drake.params import Scenario

NOT_BOOLEANS = ["yes", "no", "on", "off", "y", "n", "Yes", "NO", "On", "OFF", "Y", "N", "tRuE"]
BOOLEANS = {
    "true": True,
    "True": True,
    "TRUE": True,
    "false": False,
    "False": False,
    "FALSE": False,
}


# -- YAML booleans: true and false only (the YAML 1.2 core schema) -----------------------------


@pytest.mark.parametrize("word", NOT_BOOLEANS)
def test_yes_no_on_off_are_strings(word):
    s = LoadScenario(data=f"name: {word}\ndescription: {word}\ncomputation: {{table: {word}}}\n")
    assert (s.name, s.description, s.computation.table) == (word, word, word)


@pytest.mark.parametrize("word", NOT_BOOLEANS)
def test_a_string_where_a_boolean_belongs_names_the_key(word):
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data=f"sensor: {{averaging: {word}}}\n")
    assert str(e.value) == f"sensor.averaging: expected true or false, got {word!r}"


@pytest.mark.parametrize("word, value", BOOLEANS.items())
def test_true_and_false_are_booleans(word, value):
    s = LoadScenario(data=f"computation: {{integer: {word}}}\nsensor: {{averaging: {word}}}\n")
    assert s.computation.integer is value and s.sensor.averaging is value
    with pytest.raises(ScenarioError, match=rf"^name: expected a string, got {value}$"):
        LoadScenario(data=f"name: {word}\n")


def test_a_table_named_on_is_a_missing_table():
    from eaplan_drake.resolve import ResolveScenario

    s = LoadScenario(data="computation: {table: on}\n")
    assert s.computation.table == "on"
    with pytest.raises(ScenarioError) as e:
        ResolveScenario(s)
    assert str(e.value).startswith("computation.table: computation table 'on': no such file")


def test_keys_and_dates_follow_the_core_schema_too():
    with pytest.raises(ScenarioError, match=r"^on: unknown key \(known keys here: battery, "):
        LoadScenario(data="on: 1\n")
    s = LoadScenario(data="description: 2024-01-01\n")  # YAML 1.1 made it a date
    assert s.description == "2024-01-01"


def test_set_with_yes_no_on_off():
    s = LoadScenario(
        data="",
        overrides=[
            OverrideFromAssignment("name=no"),
            OverrideFromAssignment("computation.table=off"),
            OverrideFromAssignment("sensor.averaging=false"),
        ],
    )
    assert (s.name, s.computation.table, s.sensor.averaging) == ("no", "off", False)
    with pytest.raises(ScenarioError) as e:
        LayerScenario(s, [OverrideFromAssignment("computation.integer=yes")])
    assert str(e.value) == "computation.integer: expected true or false, got 'yes'"


@pytest.mark.parametrize(
    "assignment, expected",
    [
        ("computation.integer=no", "computation.integer: expected true or false, got 'no'"),
        ("computation.table=on", "computation.table: computation table 'on': no such file"),
        ("planner.enabled=false", "planner.enabled: unknown key"),
    ],
)
def test_cli_set_with_such_values_is_one_line(assignment, expected, tmp_path, capsys):
    from eaplan_drake.cli import main

    out = tmp_path / "out"
    status = main(
        ["simulate", "plan_i", "--set", "name=no", "--set", assignment, "--out", str(out)]
    )
    err = capsys.readouterr().err
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("eaplan-drake: scenario error: " + expected)
    assert not out.exists()


def test_unknown_keys_suggest_the_nearest_and_name_the_removed_switch():
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data="battery: {capcity: 2}\n")
    assert str(e.value).startswith("battery.capcity: unknown key (known keys here: capacity, ")
    assert str(e.value).endswith("; did you mean 'capacity'?")
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data="planner: {enabled: false}\n")
    assert str(e.value).startswith("planner.enabled: unknown key (known keys here: ")
    assert "the planner's switch is 'policy'" in str(e.value) and "\n" not in str(e.value)


# -- the loads are those of pydrake's yaml_load_typed, bit for bit ----------------------------


def _Typed(obj):
    """Every leaf of a params tree as (type, repr): equal only when bit for bit equal."""
    if dc.is_dataclass(obj):
        return {f.name: _Typed(getattr(obj, f.name)) for f in dc.fields(obj)}
    if isinstance(obj, list):
        return [_Typed(v) for v in obj]
    return type(obj).__name__, repr(obj)


@pytest.mark.parametrize("name", ShippedNames())
def test_shipped_scenarios_load_as_yaml_load_typed_does(name):
    from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

    text = ShippedFile(name)[0].read_text()
    ours = LoadNamedScenario(name)
    theirs = yaml_load_typed(schema=Scenario, data=text, defaults=Scenario()).Validate()
    assert _Typed(ours) == _Typed(theirs)
    assert yaml_dump_typed(ours) == yaml_dump_typed(theirs)  # the sweep's cache key
    layer = (
        "battery: {capacity: 3, faults: [{time: 93, soc_drop: 0.06}]}\n"
        "vehicle: {initial_heading_deg: 1e3, motion_power: {level_power: 24}}\n"
        "planner: {path_parameter_bounds: [-900, -0.0], initial_path_parameters: [-1]}\n"
    )
    layered = LayerScenario(ours, [layer])
    expected = yaml_load_typed(schema=Scenario, data=layer, defaults=theirs).Validate()
    assert _Typed(layered) == _Typed(expected)
    assert _Typed(ours) == _Typed(theirs)  # the layer did not touch what it layered over


# -- the one type walker ----------------------------------------------------------------------
