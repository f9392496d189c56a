"""Scenario parameters: defaults, YAML loading and the error messages for bad input."""

import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LoadScenario
from eaplan_drake.params import PHYSICAL_K_B, Scenario


def test_defaults_are_the_reference_numbers():
    s = LoadScenario(data="")
    assert s == Scenario().Validate()
    assert s.vehicle.airspeed == 15.0
    assert s.battery.voltage == 14.8
    assert s.battery.internal_resistance == 0.0012
    assert s.battery.capacity == 3.2
    assert s.battery.k_b == PHYSICAL_K_B == 1.0 / 3600.0  # physical; the papers' is AUTHORS_K_B
    assert s.energy_model.order == 3
    assert s.planner.horizon == 6
    assert s.planner.path_parameter_bounds == [-1000.0, 0.0]
    assert s.vehicle.initial_position == [-100.0, 220.0]


def test_partial_yaml_keeps_other_defaults():
    s = LoadScenario(
        data="wind: {direction_deg: 90}\nbattery: {faults: [{time: 93, soc_drop: 0.06}]}"
    )
    assert s.wind.direction_deg == 90.0
    assert s.wind.speed == 5.0
    assert len(s.battery.faults) == 1
    assert s.battery.faults[0].time == 93.0
    assert s.battery.faults[0].soc_drop == pytest.approx(0.06)


def test_file_loading(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text("name: mine\nsensor: {noise_std: 0.1}\n")
    s = LoadScenario(filename=f)
    assert s.name == "mine"
    assert s.sensor.noise_std == 0.1


@pytest.mark.parametrize(
    "yaml, key",
    [
        ("battery: {capcity: 2}", "battery.capcity"),
        ("battery: {faults: [{tim: 1}]}", "battery.faults[0].tim"),
        ("battery: {capacity: -1}", "battery.capacity"),
        ("battery: {internal_resistance: 0}", "battery.internal_resistance"),
        ("battery: {capacity: abc}", "battery.capacity"),
        ("battery: {faults: [{time: 1, soc_drop: 2}]}", "battery.faults[0].soc_drop"),
        ("energy_model: {order: -1}", "energy_model.order"),
        ("energy_model: {order: 2.5}", "energy_model.order"),
        ("planner: {path_parameter_bounds: [0, -1]}", "planner.path_parameter_bounds"),
        ("planner: {path_parameter_bounds: [-5000, 0]}", "planner.path_parameter_bounds"),
        ("planner: {enabled: true}", "planner.enabled"),
        ("planner: {policy: best}", "planner.policy"),
        ("planner: {policy: 1}", "planner.policy"),
        ("planner: {margin_floor: -0.1}", "planner.margin_floor"),
        ("planner: {fault_reserve: 1.5}", "planner.fault_reserve"),
        ("planner: {max_wall_time: -1}", "planner.max_wall_time"),
        ("planner: {path_parameter_grid_size: 1}", "planner.path_parameter_grid_size"),
        ("planner: {hindsight_path_parameters: 500}", "planner.hindsight_path_parameters"),
        ("wind: {speed: 20}", "wind.speed"),
        ("vehicle: 3", "vehicle"),
        ("coverage: {polygon: [[1, x], [2, 3], [4, 5]]}", "coverage.polygon[0][1]"),
        ("coverage: {min_turning_radius: 80}", "coverage.min_turning_radius"),
        ("sensor: {dropout_probability: 1.5}", "sensor.dropout_probability"),
        ("nmae: x", "nmae"),
    ],
)
def test_bad_input_names_the_key(yaml, key):
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data=yaml)
    assert str(e.value).startswith(key + ":"), str(e.value)


def test_invalid_yaml_and_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="invalid YAML"):
        LoadScenario(data="a: [")
    with pytest.raises(ScenarioError, match="no such scenario file"):
        LoadScenario(filename=tmp_path / "missing.yaml")
    with pytest.raises(ScenarioError, match="exactly one"):
        LoadScenario()


def test_overrides_layer_in_order_and_lists_replace():
    from eaplan_drake.loading import OverrideFromAssignment as Set

    base = "name: base\nbattery: {capacity: 3.0, faults: [{time: 10, soc_drop: 0.05}]}"
    s = LoadScenario(
        data=base,
        overrides=[
            "battery: {reserve_soc: 0.25}\nwind: {speed: 2.0}",
            Set("wind.speed=7"),
            Set("battery.faults=[{time: 90, soc_drop: 0.1}]"),
            Set("planner.policy=greedy"),
        ],
    )
    assert s.name == "base" and s.battery.capacity == 3.0 and s.battery.reserve_soc == 0.25
    assert s.wind.speed == 7.0  # the later layer wins
    assert [(f.time, f.soc_drop) for f in s.battery.faults] == [(90.0, 0.1)]
    assert s.planner.policy == "greedy"
    assert Set("planner.initial_path_parameters=[-500]") == (
        "planner:\n  initial_path_parameters: [-500]\n"
    )


@pytest.mark.parametrize(
    "assignment, message",
    [
        ("battery.capcity=3", "battery.capcity: unknown key"),
        ("battery.capacity=abc", "battery.capacity: expected a number"),
        ("battery.capacity=-1", "battery.capacity: must be > 0"),
        ("battery", "--set 'battery': expected KEY.PATH=VALUE"),
        ("wind.speed.x=1", "wind.speed.x: unknown key"),
        ("planner.policy=best", "planner.policy: must be one of"),
    ],
)
def test_bad_override_is_one_line_naming_the_key(assignment, message):
    from eaplan_drake.loading import OverrideFromAssignment

    with pytest.raises(ScenarioError) as e:
        LoadScenario(data="", overrides=[OverrideFromAssignment(assignment)])
    assert str(e.value).startswith(message) and "\n" not in str(e.value), str(e.value)


def test_random_seed_derives_the_sensor_seed():
    s = LoadScenario(data="sensor: {seed: 5}")
    assert s.random_seed == -1 and s.SensorSeed() == 5
    a = LoadScenario(data="random_seed: 1\nsensor: {seed: 5}").SensorSeed()
    b = LoadScenario(data="random_seed: 2\nsensor: {seed: 5}").SensorSeed()
    assert a != b and a == LoadScenario(data="random_seed: 1").SensorSeed()
    with pytest.raises(ScenarioError, match="^random_seed: must be an integer >= -1"):
        LoadScenario(data="random_seed: -2")


# -- the params dataclasses have their fields and nothing else --------------------------------


def _ParamsClasses():
    import dataclasses as dc
    import inspect

    from eaplan_drake import params

    return [
        cls
        for _, cls in inspect.getmembers(params, inspect.isclass)
        if dc.is_dataclass(cls) and cls.__module__.startswith(f"{params.__name__}.")
    ]


def test_every_params_dataclass_refuses_an_unknown_attribute():
    classes = _ParamsClasses()
    assert len(classes) == 18  # every @dc.dataclass of the params package
    for cls in classes:
        obj = cls()
        with pytest.raises(AttributeError) as e:
            obj.not_a_field = 1
        message = str(e.value)
        assert f"{cls.__name__} has no field 'not_a_field'" in message and "\n" not in message
        assert not hasattr(obj, "not_a_field")


def test_unknown_attribute_names_the_full_key_and_the_nearest_field():
    s = Scenario()
    with pytest.raises(AttributeError) as e:
        s.planner.enabled = False  # the old switch, replaced by policy
    message = str(e.value)
    assert message.startswith("planner.enabled: PlannerParams has no field 'enabled'"), message
    assert "the planner's switch is 'policy'" in message and "'static'" in message
    with pytest.raises(AttributeError, match=r"^battery\.capcity: .*did you mean 'capacity'\?"):
        s.battery.capcity = 3.0
    with pytest.raises(AttributeError, match=r"^vehicle\.motion_power\.level_pwr: .*'level_power'"):
        s.vehicle.motion_power.level_pwr = 20.0
    with pytest.raises(AttributeError, match=r"^planner\.fault_model\.rat: .*'rate'"):
        s.planner.fault_model.rat = 0.01
    with pytest.raises(AttributeError, match=r"^nmae: Scenario has no field 'nmae'.*'name'"):
        s.nmae = "x"
    from eaplan_drake.params import BatteryFault

    with pytest.raises(AttributeError, match=r"^battery\.faults\[i\]\.tim: .*'time'"):
        BatteryFault().tim = 1.0
    assert s == Scenario()  # nothing was set


def test_fields_still_set_copy_pickle_replace_and_load():
    import copy
    import dataclasses as dc
    import pickle

    from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.params import BatteryFault, PlannerParams

    s = LoadNamedScenario("plan_i")
    s.planner.policy = "static"
    s.battery.faults = [BatteryFault(time=10.0, soc_drop=0.05)]
    deep = copy.deepcopy(s)
    assert deep == s and deep.battery is not s.battery
    deep.battery.capacity = 1.0
    assert s.battery.capacity != 1.0
    back = pickle.loads(pickle.dumps(s, protocol=pickle.HIGHEST_PROTOCOL))
    assert back == s and yaml_dump_typed(back) == yaml_dump_typed(s)
    with pytest.raises(AttributeError, match="planner.enabled"):
        back.planner.enabled = True  # still guarded after a round trip
    replaced = dc.replace(s.planner, policy="mpc", horizon=4)
    assert isinstance(replaced, PlannerParams) and (replaced.policy, replaced.horizon) == ("mpc", 4)
    with pytest.raises(TypeError):
        dc.replace(s.planner, enabled=False)
    loaded = yaml_load_typed(schema=Scenario, data="planner: {policy: greedy}\n", defaults=s)
    assert loaded.planner.policy == "greedy" and loaded.battery == s.battery
    assert loaded.Validate() is loaded


# -- errors that name the user's key ---------------------------------------------------------


@pytest.mark.parametrize(
    "bounds, shown",
    [
        ([0, 0], "[0, 0]"),
        ([-1000, -1000], "[-1000, -1000]"),
        ([-500, -600], "[-500, -600]"),
        ([-100, 10], "[-100, 10]"),
    ],
)
def test_path_parameter_bounds_need_lo_below_hi_at_most_0(bounds, shown):
    import numpy as np

    text = f"planner: {{path_parameter_bounds: {bounds}, initial_path_parameters: [{bounds[0]}]}}"
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data=text)
    message = str(e.value)
    assert message.startswith(
        "planner.path_parameter_bounds: need c1_min = r_min² − r² <= lo < hi <= 0 [m²]"
    ), message
    assert message.endswith(f"got {shown}") and "array" not in message
    s = Scenario()  # the same from Python, a numpy array as the user may give it
    s.planner.path_parameter_bounds = np.array(bounds, dtype=float)
    s.planner.initial_path_parameters = [float(bounds[0])]
    with pytest.raises(ScenarioError) as e:
        s.Validate()
    assert str(e.value).endswith(f"got {shown}") and "array" not in str(e.value)


def test_path_parameter_bounds_below_r_min_name_c1_min():
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data="planner: {path_parameter_bounds: [-5000, 0]}")
    assert str(e.value) == (
        "planner.path_parameter_bounds: need c1_min = r_min² − r² = -1000 <= lo < hi <= 0 [m²] "
        "(r2 = sqrt(r² + c1) may not exceed r), got [-5000, 0]"
    )
    s = LoadScenario(
        data="planner: {path_parameter_bounds: [-1000, -1e-3], initial_path_parameters: [-1]}"
    )
    assert s.planner.path_parameter_bounds == [-1000.0, -1e-3]  # narrower bounds stay valid


@pytest.mark.parametrize(
    "yaml, message",
    [
        ("guidance: {k_e: 1e300}", "guidance.k_e: must be <= 1000 1/m (numerics), got 1e+300"),
        (
            "vehicle: {initial_position: [0, -1e100]}",
            "vehicle.initial_position[1]: must be in [-1e+07, 1e+07] m (numerics), got -1e+100",
        ),
        (
            "planner: {fault_model: {sizes: exponential, size_mean: 1}}",
            "planner.fault_model.size_mean: must be in [1e-06, 1) [-] (the mean of exponential "
            "sizes), got 1",
        ),
    ],
)
def test_values_that_failed_only_in_flight_are_named_at_validation(yaml, message):
    with pytest.raises(ScenarioError) as e:
        LoadScenario(data=yaml)
    assert str(e.value) == message
