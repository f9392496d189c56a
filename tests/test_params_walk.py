"""The one type walker (eaplan_drake.params.walk): YAML data and params objects against the type
hints, with ``X | None`` and a Union of dataclasses."""

import dataclasses as dc
import typing

import numpy as np
import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import (
    LoadScenario,
)
from eaplan_drake.params import Scenario
from eaplan_drake.params.walk import _Walk


@dc.dataclass
class _Gust:
    speed: float = 1.0


@dc.dataclass
class _Shear:
    gradient: float = 0.1
    height: float = 10.0


@dc.dataclass
class _Holder:
    label: str | None = None
    gust: _Gust | None = None
    model: _Gust | _Shear = dc.field(default_factory=_Gust)
    counts: list[int] = dc.field(default_factory=list)


def test_walker_builds_optionals_and_unions_from_yaml_data():
    h = _Walk(_Holder, {"label": "a", "gust": {"speed": 3}}, "", raw=True, current=_Holder())
    assert h.label == "a" and h.gust == _Gust(3.0) and type(h.gust.speed) is float
    h = _Walk(_Holder, {"label": None, "gust": None}, "", raw=True, current=h)
    assert h.label is None and h.gust is None
    h = _Walk(_Holder, {"model": {"height": 20}}, "", raw=True, current=_Holder())
    assert h.model == _Shear(gradient=0.1, height=20.0)  # the member that has the key
    h = _Walk(_Holder, {"model": {"gradient": 0.2}}, "", raw=True, current=h)
    assert h.model == _Shear(gradient=0.2, height=20.0)  # merged into the current one
    h = _Walk(_Holder, {"model": {"speed": 2}}, "", raw=True, current=h)
    assert h.model == _Gust(2.0)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"label": 3}, "label: expected a string or null, got 3"),
        ({"gust": {"sped": 1}}, "gust.sped: unknown key (known keys here: speed)"),
        ({"gust": "calm"}, "gust: expected a mapping of keys or null, got 'calm'"),
        ({"gust": {"speed": "x"}}, "gust.speed: expected a number, got 'x'"),
        ({"model": {"speed": 1, "height": 2}}, "model.height: unknown key"),
        ({"model": [1]}, "model: expected a mapping of keys, got [1]"),
        ({"counts": [1, True]}, "counts[1]: expected an integer, got True"),
    ],
)
def test_walker_names_the_key_in_yaml_data(data, message):
    with pytest.raises(ScenarioError) as e:
        _Walk(_Holder, data, "", raw=True, current=_Holder())
    assert str(e.value).startswith(message), str(e.value)


def test_walker_checks_objects_with_optionals_and_unions():
    h = _Holder(label=None, gust=_Gust(2.0), model=_Shear(), counts=(np.int64(1), 2))
    assert _Walk(_Holder, h, "holder", raw=False) is h
    assert h.counts == [1, 2] and all(type(c) is int for c in h.counts)
    h.model = {"speed": 1.0}
    with pytest.raises(ScenarioError, match=r"^holder.model: expected a _Gust or a _Shear, got"):
        _Walk(_Holder, h, "holder", raw=False)
    h.model, h.gust = _Gust(), _Gust(speed="fast")
    with pytest.raises(ScenarioError, match=r"^holder.gust.speed: expected a number, got 'fast'"):
        _Walk(_Holder, h, "holder", raw=False)
    assert type(_Walk(int | None, np.int32(3), "n", raw=False)) is int
    assert _Walk(typing.Union[_Gust, None], None, "g", raw=True) is None  # noqa: UP007


def test_walker_keeps_the_scenario_messages():
    s = Scenario()
    s.vehicle = None
    with pytest.raises(ScenarioError, match=r"^vehicle: expected a VehicleParams, got NoneType"):
        s.Validate()
    with pytest.raises(ScenarioError, match=r"^the scenario: expected a Scenario, got dict"):
        _Walk(Scenario, {}, "", raw=False)
    with pytest.raises(ScenarioError, match=r"^vehicle: expected a mapping of keys, got 3$"):
        LoadScenario(data="vehicle: 3\n")
    with pytest.raises(ScenarioError, match=r"^vehicle.initial_position: expected a list, got 3$"):
        LoadScenario(data="vehicle: {initial_position: 3}\n")
