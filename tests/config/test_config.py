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
        (lambda d: d["joints"]["wrist_pitch"].update(torque_limit_nm=-5.0), "joints.wrist_pitch.torque_limit_nm",
         ">= 10"),
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


# ---------------------------------------------------------------- the reader's limits
def _bomb(levels: int = 9, width: int = 10) -> str:
    """A 'billion laughs' document: each level lists the previous one ``width`` times (width ** levels leaves)."""
    lines = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
    lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


def test_an_alias_bomb_is_refused_before_it_is_built(tmp_path):
    import tracemalloc

    path = _write(tmp_path, _bomb())
    tracemalloc.start()
    try:
        with pytest.raises(ConfigError, match="alias") as info:
            load_robot_config(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert "more than 20000 nodes with its aliases followed" in str(info.value)
    assert peak < 5 * 2**20, f"the refusal itself took {peak / 2**20:.1f} MiB"


def test_a_few_aliases_still_load(tmp_path):
    text = constants.ROBOT_YAML.read_text().replace("wrist_yaw:   {", "wrist_yaw: &yaw {")
    text = "\n".join("  wrist_roll: *yaw" if line.startswith("  wrist_roll:") else line for line in text.splitlines())
    assert "*yaw" in text and "&yaw" in text
    robot = load_config(_write(tmp_path, text), RobotConfig)
    assert robot.joints.wrist_roll == robot.joints.wrist_yaw
    assert robot.joints.wrist_roll.velocity_limit_deg_s == 60.0


def test_a_recursive_alias_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="contains it"):
        load_robot_config(_write(tmp_path, "joints: &j {waist: *j}\n"))


@pytest.mark.parametrize("text", ["joints: " + "[" * 5000 + "]" * 5000,
                                  "".join("  " * i + f"k{i}:\n" for i in range(200)) + "  " * 200 + "v\n"])
def test_deep_nesting_is_refused_without_recursion_error(tmp_path, text):
    with pytest.raises(ConfigError, match="nested deeper than 32 levels"):
        load_robot_config(_write(tmp_path, text))


def test_a_repeated_key_is_refused_naming_it_and_its_lines(tmp_path):
    text = constants.ROBOT_YAML.read_text() + "control_rate_hz: 50.0\n"
    with pytest.raises(ConfigError, match="control_rate_hz") as info:
        load_robot_config(_write(tmp_path, text))
    msg = str(info.value)
    assert "twice (first on line 8)" in msg and f"line {text.count(chr(10))}" in msg, msg


@pytest.mark.parametrize(("data", "what"), [
    ("control_rate_hz: 100.0\n".encode("utf-16"), "UTF-16"),
    ("control_rate_hz: 100.0\n".encode("utf-16-le"), "UTF-16"),
    ("control_rate_hz: 100.0\n".encode("utf-32"), "UTF-32"),
    (bytes(range(256)) * 4, "binary"),
    ("control_rate_hz: 1 # caf\u00e9\n".encode("latin-1"), "not UTF-8"),
])
def test_files_that_are_not_utf8_are_named_as_such(tmp_path, data, what):
    path = tmp_path / "robot.yaml"
    path.write_bytes(data)
    with pytest.raises(ConfigError, match=what) as info:
        load_robot_config(path)
    assert str(path) in str(info.value) and "UTF-8" in str(info.value)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_bytes(b"\xef\xbb\xbf" + constants.ROBOT_YAML.read_bytes())
    assert load_robot_config(path).control_rate_hz == 100.0


def test_a_file_of_too_many_nodes_is_refused_while_it_is_composed(tmp_path):
    path = _write(tmp_path, "joints: [" + ", ".join(["1"] * 300_000) + "]\n")
    with pytest.raises(ConfigError, match="more than 20000 nodes") as info:
        load_robot_config(path)
    assert "line 1" in str(info.value)


def test_a_file_larger_than_the_cap_is_refused_unread(tmp_path):
    from excavsim.config.loader import MAX_FILE_BYTES

    path = tmp_path / "robot.yaml"
    with open(path, "wb") as f:
        f.truncate(MAX_FILE_BYTES + 1)  # sparse: nothing to read, and it is never read
    with pytest.raises(ConfigError, match=f"allowed: at most {MAX_FILE_BYTES} bytes"):
        load_robot_config(path)


@pytest.mark.parametrize("path", ["x" * 1_000_000 + ".yaml", "a\0b.yaml", "/dev/null", "/"])
def test_unreadable_paths_give_a_config_error_with_the_path_cut_short(path):
    with pytest.raises(ConfigError, match="cannot read") as info:
        load_robot_config(path)
    assert len(str(info.value)) < 400


@pytest.mark.parametrize("text", ["control_rate_hz: " + "9" * 5000, "control_rate_hz: 2001-13-45"])
def test_values_yaml_cannot_build_give_a_config_error(tmp_path, text):
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_robot_config(_write(tmp_path, text))


def test_echoed_values_are_cut_to_80_characters(tmp_path):
    data = copy.deepcopy(VALID)
    data["joints"]["waist"]["torque_limit_nm"] = "z" * 500_000
    data["z" * 100_000] = 1
    with pytest.raises(ConfigError) as info:
        load_robot_config(_write(tmp_path, data))
    msg = str(info.value)
    assert len(msg) < 1000 and "more characters" in msg, msg[:2000]


# ---------------------------------------------------------------- physical ranges and memory bounds
@pytest.mark.parametrize(("field", "value"), [("torque_limit_nm", 1e-300), ("velocity_limit_deg_s", 1e-9),
                                              ("kp_nm_per_rad", 1e-300)])
def test_servo_values_below_physical_ranges_are_refused(tmp_path, field, value):
    data = copy.deepcopy(VALID)
    data["joints"]["wrist_pitch"][field] = value
    with pytest.raises(ConfigError, match=f"joints.wrist_pitch.{field}"):
        load_robot_config(_write(tmp_path, data))


def _planner_with(tmp_path, **grid_or_top):
    data = yaml.safe_load(constants.PLANNER_YAML.read_text())
    for key, value in grid_or_top.items():
        (data["grid"] if key in data["grid"] else data)[key] = value
    return _write(tmp_path, data, "planner.yaml")


@pytest.mark.parametrize("change", [{"sample_spacing_m": 1e-9}, {"alpha_step_deg": 1e-300},
                                    {"k_step_m": 1e-6, "d1_step_m": 1e-6}])
def test_a_planner_grid_too_large_for_memory_is_refused_with_its_size(tmp_path, change):
    from excavsim.config import PlannerConfig

    with pytest.raises(ConfigError, match="the search would need") as info:
        load_config(_planner_with(tmp_path, **change), PlannerConfig)
    assert "cells x" in str(info.value) and "allowed: at most 4 GiB" in str(info.value)


def test_the_shipped_planner_needs_little_memory():
    from excavsim.config import load_planner_config

    cfg = load_planner_config()
    assert cfg.grid.shape == (20, 10, 49)
    assert cfg.estimated_bytes() < 2**30


def test_a_dump_pose_out_of_reach_is_refused(tmp_path):
    from excavsim.config import ExecutorConfig

    data = yaml.safe_load(constants.EXECUTOR_YAML.read_text())
    data["dump_pose"] = [-1e308, 1.3, 100.0]
    with pytest.raises(ConfigError, match="dump_pose"):
        load_config(_write(tmp_path, data, "executor.yaml"), ExecutorConfig)


def test_too_many_scanner_rays_are_refused(tmp_path):
    from excavsim.config import SensingConfig

    with pytest.raises(ConfigError, match="rays per image"):
        load_config(_write(tmp_path, {"scanner": {"n_azimuth": 4000, "n_elevation": 4000}}, "sensing.yaml"),
                    SensingConfig)


# ---------------------------------------------------------------- a goal against the scene
def _goal(**fields):
    from excavsim.config import TrenchGoal

    return TrenchGoal.model_validate({"near_x_m": 1.6, "far_x_m": 2.8, "depth_m": 0.25, **fields})


@pytest.mark.parametrize(("fields", "scene", "match"), [
    ({"near_x_m": 3.6, "far_x_m": 3.9}, {}, "near_x_m: .* outside the soil box"),
    ({"near_x_m": 0.2, "far_x_m": 1.0}, {}, "near_x_m: .* outside the soil box"),
    ({"waist_deg": 90.0}, {}, "outside the soil box"),
    ({"surface_z_m": 1.4}, {}, "surface_z_m: 1.4 m lies above the initial soil"),
    ({"surface_z_m": 0.3, "depth_m": 0.5}, {}, "depth_m: .* below the box floor"),
    ({}, {"initial_soil_height_m": 0.0}, "lies above the initial soil at 0 m"),
    ({"near_x_m": 2.0, "far_x_m": 2.0005}, {}, "holds .* m\\^2 of soil"),
])
def test_goals_outside_the_box_or_the_soil_are_refused(fields, scene, match):
    from excavsim.config import check_goal

    base = load_scene_config()
    with pytest.raises(ConfigError, match=match):
        check_goal(_goal(**fields), base.model_copy(update=scene), source="goal.yaml")


def test_shipped_goals_hold_soil_in_the_shipped_scene():
    from excavsim.config import check_goal
    from excavsim.config.semantic import goal_section_m2
    from excavsim.tasks.trench.spec import resolve_goal

    for name in ("sand", "straight", "small"):
        goal = resolve_goal(name)
        check_goal(goal, load_scene_config())
        # a trapezoid: opening minus the two wall run-outs, times the depth, half on the sloped parts
        assert goal_section_m2(goal, goal.surface_z_m) > 0.05


def test_an_episode_spec_with_a_goal_above_the_soil_is_refused_before_it_runs():
    from excavsim.loop.scenario import EpisodeSpec, resolve

    spec = EpisodeSpec(goal=_goal(surface_z_m=1.4, depth_m=0.2))
    with pytest.raises(ConfigError, match="episode: goal: surface_z_m"):
        resolve(spec)


def test_names_checked_inside_a_model_are_echoed_cut_short():
    from excavsim.config import parse_config
    from excavsim.loop.scenario import EpisodeSpec

    for field in ("soil", "predictor"):
        with pytest.raises(ConfigError, match=f"unknown {field}") as info:
            parse_config({field: "p" * 100_000}, EpisodeSpec, source="spec.yaml")
        assert str(info.value).startswith("spec.yaml: invalid EpisodeSpec") and len(str(info.value)) < 1000
