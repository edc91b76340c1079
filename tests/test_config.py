"""Configuration: valid files load; every bad file gives the package's ConfigError naming the file
and the field; random mutations of a valid file never raise anything else."""

from __future__ import annotations

import copy
import math

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from excavsim import constants
from excavsim.cli import main
from excavsim.config import RobotConfig, SceneConfig, load_config, load_robot_config, load_scene_config
from excavsim.errors import ConfigError

VALID = yaml.safe_load(constants.ROBOT_YAML.read_text())


def _write(tmp_path, data, name="robot.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return path


def test_shipped_configs_load():
    robot = load_robot_config()
    assert robot.joints.wrist_pitch.torque_limit_nm == 1000.0
    assert robot.joints.shoulder.velocity_limit_rad_s == pytest.approx(math.radians(30.0))
    assert load_scene_config().soil_grid_samples == 121


def test_yaml_1_2_exponent_floats_are_numbers(tmp_path):
    text = constants.ROBOT_YAML.read_text().replace("5.0e5", "5e5")
    assert load_config(_write(tmp_path, text), RobotConfig).joints.waist.kp_nm_per_rad == 5e5


@pytest.mark.parametrize(
    ("mutate", "field", "allowed"),
    [
        (lambda d: d["joints"]["wrist_pitch"].update(torque_limit_nm=-5.0), "joints.wrist_pitch.torque_limit_nm", "> 0"),
        (lambda d: d["joints"]["elbow"].update(kp_nm_per_rad="stiff"), "joints.elbow.kp_nm_per_rad", "number"),
        (lambda d: d["joints"]["waist"].pop("kv_nm_s_per_rad"), "joints.waist.kv_nm_s_per_rad", "missing"),
        (lambda d: d["joints"]["waist"].update(speed=3.0), "joints.waist.speed", "unknown field"),
        (lambda d: d.update(control_rate_hz=float("nan")), "control_rate_hz", "finite"),
        (lambda d: d.update(control_rate_hz=float("inf")), "control_rate_hz", "finite"),
        (lambda d: d.update(control_rate_hz=True), "control_rate_hz", "number"),
        (lambda d: d["joints"].update(gripper={}), "joints.gripper", "unknown field"),
        (lambda d: d["joints"]["wrist_roll"].update(velocity_limit_deg_s=10_000.0),
         "joints.wrist_roll.velocity_limit_deg_s", "<= 720"),
    ],
)
def test_bad_values_name_the_file_the_field_and_what_is_allowed(tmp_path, mutate, field, allowed):
    data = copy.deepcopy(VALID)
    mutate(data)
    path = _write(tmp_path, data)
    with pytest.raises(ConfigError) as info:
        load_robot_config(path)
    msg = str(info.value)
    assert str(path) in msg and field in msg and allowed in msg, msg


@pytest.mark.parametrize("text", ["joints: [1, 2", "- just\n- a list\n", "42", ""])
def test_broken_or_wrongly_shaped_files_give_a_config_error(tmp_path, text):
    with pytest.raises(ConfigError, match="robot.yaml"):
        load_robot_config(_write(tmp_path, text))


def test_missing_file_gives_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        load_robot_config(tmp_path / "absent.yaml")


def test_scene_cell_size_must_divide_the_box(tmp_path):
    with pytest.raises(ConfigError, match="soil_cell_size_m"):
        load_config(_write(tmp_path, {"soil_cell_size_m": 0.07}, "scene.yaml"), SceneConfig)
    assert load_config(_write(tmp_path, {"soil_cell_size_m": 0.05}, "scene.yaml"), SceneConfig).soil_grid_samples == 61


def test_cli_reports_a_bad_config_without_traceback_and_exits_non_zero(tmp_path, capsys):
    data = copy.deepcopy(VALID)
    data["joints"]["wrist_pitch"]["torque_limit_nm"] = 0.0
    path = _write(tmp_path, data)
    status = main(["validate", "robot", str(path)])
    err = capsys.readouterr().err
    assert status == 2
    assert "joints.wrist_pitch.torque_limit_nm" in err and str(path) in err
    assert "Traceback" not in err
    assert main(["demo", "--robot-config", str(path)]) == 2


def test_cli_validates_a_good_config(capsys):
    assert main(["validate", "robot", str(constants.ROBOT_YAML)]) == 0
    assert "valid RobotConfig" in capsys.readouterr().out
    assert main(["validate", "planner", str(constants.PLANNER_YAML)]) == 0
    assert "valid PlannerConfig" in capsys.readouterr().out


def test_cli_names_a_bad_planner_objective_and_what_is_allowed(tmp_path, capsys):
    path = tmp_path / "planner.yaml"
    path.write_text(constants.PLANNER_YAML.read_text().replace("auxiliary: peak_torque", "auxiliary: volume"))
    assert main(["validate", "planner", str(path)]) == 2
    err = capsys.readouterr().err
    assert "auxiliary='volume'" in err and "peak_torque, cumulative_torque" in err and "Traceback" not in err


# ---------------------------------------------------------------- property-based mutation
_LEAF_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10**12, 10**12), st.text(max_size=8),
    st.floats(allow_nan=True, allow_infinity=True), st.lists(st.integers(), max_size=3),
    st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
)


def _paths(d, prefix=()):
    for k, v in d.items():
        yield (*prefix, k)
        if isinstance(v, dict):
            yield from _paths(v, (*prefix, k))


ALL_PATHS = list(_paths(VALID))


@st.composite
def mutated_configs(draw):
    data = copy.deepcopy(VALID)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(ALL_PATHS))
        parent = data
        for key in path[:-1]:
            if not isinstance(parent, dict) or key not in parent:
                break
            parent = parent[key]
        else:
            if not isinstance(parent, dict):
                continue
            action = draw(st.sampled_from(["replace", "delete", "add_unknown", "scale"]))
            if action == "replace":
                parent[path[-1]] = draw(_LEAF_VALUES)
            elif action == "delete":
                parent.pop(path[-1], None)
            elif action == "add_unknown":
                parent[draw(st.text(min_size=1, max_size=6))] = draw(_LEAF_VALUES)
            elif isinstance(parent.get(path[-1]), float):
                parent[path[-1]] *= draw(st.sampled_from([-1.0, 0.0, 1e-9, 1e9, 1e300]))
    return data


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=mutated_configs())
def test_mutated_configs_either_load_or_raise_config_error(tmp_path, data):
    path = _write(tmp_path, data)
    try:
        cfg = load_robot_config(path)
    except ConfigError as exc:
        assert str(path) in str(exc)
    else:
        assert isinstance(cfg, RobotConfig)
        for servo in cfg.joints.by_actuator().values():
            assert math.isfinite(servo.torque_limit_nm) and servo.torque_limit_nm > 0
