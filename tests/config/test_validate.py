"""``excavsim validate``: every file of configs/ passes, a bad file of each kind is refused naming file and field.

Each kind's bad files are a shipped file (or, for an episode specification, of which configs/ holds
none, a small one) with one change: a field that does not exist, a value out of its range, a value of
the wrong type. Each lies where its kind lives (configs/trenches/, configs/regress/, ...) or carries its
kind's stem, so the kind is told as it is for the shipped files.
"""

from __future__ import annotations

import copy
import json
import pathlib

import pytest
import yaml

from excavsim import constants
from excavsim.cli import main
from excavsim.config import ConfigError, parse_yaml
from excavsim.tasks.pile_loading.config_planar import LOADING_MACHINES
from excavsim.validate import infer_kind, kinds, validate_file, validate_paths

CONFIG_FILES = sorted(p for p in constants.CONFIGS_DIR.rglob("*") if p.is_file())
SPEC = {"name": "one", "goal": "small", "soil": "testbed_sand", "seed": 0, "dig_budget": 2}

# kind: (a good file, where a bad one lies, (field out of range, value), (field of the wrong type, value))
CASES = {
    "robot": ("robot.yaml", "robot.yaml", ("control_rate_hz", -5.0), ("joints.waist.torque_limit_nm", "strong")),
    "scene": ("scene.yaml", "scene.yaml", ("initial_soil_height_m", -1.0), ("settle.max_iterations", "many")),
    "soils": ("soils.yaml", "soils.yaml", ("soils.testbed_sand.friction_angle_deg", 95.0),
              ("soils.testbed_sand.density_kg_m3", "heavy")),
    "sensing": ("sensing.yaml", "sensing.yaml", ("scanner.n_azimuth", 1), ("scanner.range_noise_m", "big")),
    "planner": ("planner.yaml", "planner.yaml", ("fill_fraction", 5.0), ("min_volume_fraction", "some")),
    "executor": ("executor.yaml", "executor.yaml", ("touch_force_n", -1.0), ("dig_timeout_moves", "many")),
    "goal": ("trenches/small.yaml", "trenches/bad.yaml", ("depth_m", -0.1), ("near_x_m", "near")),
    "spec": (None, "episode.yaml", ("dig_budget", 0), ("seed", "zero")),
    "regress": ("regress/small_sand.yaml", "regress/bad.yaml", ("dig_budget", 0), ("seeds", "eight")),
    "baseline": ("regress/baseline.json", "regress/baseline.json", ("scenarios.small_sand.metrics.digs.n", 0),
                 ("format", "2")),
    "campaign": ("campaigns/tiny.yaml", "campaigns/bad.yaml", ("base.dig_budget", 0), ("record", "yes")),
    "experiment": ("experiments/fig113.yaml", "experiments/bad.yaml", ("runs.0.dig_budget", 0), ("title", 5)),
    "pile_loading_planar": ("pile_loading_planar.yaml", "pile_loading_planar.yaml", ("pile.height", -1.0), ("units_m2", "tiny")),
    "pile_loading": ("pile_loading.yaml", "pile_loading.yaml", ("n_scans", 0), ("script.tip_speed", "fast")),
    "pile_loading_campaign": ("campaigns/pile_loading_machines.yaml", "campaigns/bad.yaml", ("seeds", [-1]),
                         ("machines", "loader")),
    "dump_trial": ("dump_trial.yaml", "dump_trial.yaml", ("target.r_m", -1.0), ("learning.expected_cost", "maybe")),
    "machine": ("machines/tb035.yaml", "machines/bad.yaml", ("executor.touch_force_n", -1.0),
                ("planner.d2_max_m", "long")),
    "truck_loading": ("truck_loading.yaml", "truck_loading.yaml", ("truck.payload_t", -1.0),
                      ("tuning.tune", "maybe")),
}


def _good(kind: str) -> dict:
    """The document of the kind's good file, as the loader reads it."""
    name = CASES[kind][0]
    if name is None:
        return copy.deepcopy(SPEC)
    path = constants.CONFIGS_DIR / name
    text = path.read_text()
    return json.loads(text) if path.suffix == ".json" else parse_yaml(text, source=name)


def _set(doc: dict, dotted: str, value) -> dict:
    """``doc`` with the field at ``dotted`` (list indices as numbers) set to ``value``."""
    doc = copy.deepcopy(doc)
    *parents, last = dotted.split(".")
    node = doc
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node[part]
    node[last] = value
    return doc


def _write(tmp_path: pathlib.Path, kind: str, doc: dict) -> pathlib.Path:
    path = tmp_path / "configs" / CASES[kind][1]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc) if path.suffix == ".json" else yaml.safe_dump(doc, sort_keys=False))
    return path


def test_every_kind_has_a_case_and_the_cases_cover_every_kind():
    assert set(CASES) == set(kinds())


@pytest.mark.parametrize("path", CONFIG_FILES, ids=lambda p: str(p.relative_to(constants.CONFIGS_DIR)))
def test_every_file_of_configs_is_valid(path):
    kind, what = validate_file(path)
    assert kind in kinds() and what


def test_the_files_of_configs_hold_every_kind_but_the_bare_specification():
    found = {infer_kind(p) for p in CONFIG_FILES}
    assert found >= set(kinds()), set(kinds()) - found


@pytest.mark.parametrize("path", [p for p in CONFIG_FILES if p.suffix == ".yaml"],
                         ids=lambda p: str(p.relative_to(constants.CONFIGS_DIR)))
def test_a_file_away_from_configs_is_told_by_its_fields(tmp_path, path):
    moved = tmp_path / "some_name.yaml"
    moved.write_text(path.read_text())
    assert infer_kind(moved) == infer_kind(path)


@pytest.mark.parametrize("kind", sorted(CASES))
def test_the_good_document_of_each_case_passes_where_the_bad_ones_lie(tmp_path, kind):
    assert validate_file(_write(tmp_path, kind, _good(kind)))[0] == kind


@pytest.mark.parametrize("how", ["unknown field", "out of range", "wrong type"])
@pytest.mark.parametrize("kind", sorted(CASES))
def test_a_bad_file_of_each_kind_is_refused_naming_file_and_field(tmp_path, kind, how):
    good = _good(kind)
    if how == "unknown field":
        field, doc = "bogus_field", {**good, "bogus_field": 1}
    else:
        field, value = CASES[kind][2] if how == "out of range" else CASES[kind][3]
        doc = _set(good, field, value)
    path = _write(tmp_path, kind, doc)
    with pytest.raises(ConfigError) as err:
        validate_file(path)
    text = str(err.value)
    assert text.startswith(str(path)), text
    assert f"{field}:" in text, text
    if how == "unknown field":
        assert "unknown field" in text and "allowed:" in text, text
    if how == "out of range":
        assert "allowed" in text, text


@pytest.mark.parametrize("kind", ["dump_trial", "pile_loading_planar", "goal", "baseline"])
def test_the_cli_refuses_a_bad_file_with_status_2_and_one_message(tmp_path, capsys, kind):
    field, value = CASES[kind][2]
    path = _write(tmp_path, kind, _set(_good(kind), field, value))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"excavsim: error: {path}") and field in err and "Traceback" not in err, err


def test_the_cli_checks_every_file_and_reports_the_refused_ones_together(tmp_path, capsys):
    bad = _write(tmp_path, "dump_trial", _set(_good("dump_trial"), "target.r_m", -1.0))
    assert main(["validate", str(constants.ROBOT_YAML), str(bad), str(constants.TRENCHES_DIR)]) == 2
    out, err = capsys.readouterr()
    goals = len(list(constants.TRENCHES_DIR.rglob("*.yaml")))  # the T3's and each machine's (trenches/<machine>/)
    assert "robot.yaml: valid RobotConfig; kind robot" in out and out.count("kind goal") == goals, out
    assert err.startswith(f"excavsim: error: {bad}") and "target.r_m" in err, err
    assert main(["validate", str(constants.CONFIGS_DIR)]) == 0
    assert capsys.readouterr().out.count(": valid ") == len(CONFIG_FILES)


def test_a_kind_given_overrides_the_place_and_the_older_form_still_works(capsys):
    assert main(["validate", "--kind", "goal", str(constants.ROBOT_YAML)]) == 2
    assert "unknown field" in capsys.readouterr().err
    assert main(["validate", "dump_trial", str(constants.CONFIGS_DIR / "dump_trial.yaml")]) == 0
    assert "valid TruckFile; kind dump_trial" in capsys.readouterr().out
    assert main(["validate", "--kind", "trench", str(constants.ROBOT_YAML)]) == 2
    assert "invalid choice: 'trench'" in capsys.readouterr().err


def test_a_file_of_no_known_kind_is_refused_with_the_kinds_listed(tmp_path):
    path = tmp_path / "mystery.yaml"
    path.write_text("colour: blue\n")
    with pytest.raises(ConfigError, match="cannot tell what the file configures.*allowed kinds: scene, soils"):
        validate_file(path)
    with pytest.raises(ConfigError, match="unknown kind of configuration file 'trench'; allowed: scene"):
        validate_file(constants.ROBOT_YAML, "trench")


def test_a_loading_campaign_checks_the_configuration_it_names(tmp_path):
    bad = tmp_path / "pile_loading.yaml"
    bad.write_text((constants.CONFIGS_DIR / "pile_loading.yaml").read_text().replace("n_scans: 10", "n_scans: 0"))
    camp = tmp_path / "campaigns" / "mine.yaml"
    camp.parent.mkdir()
    camp.write_text(f"machines: [loader]\nseeds: [0]\nmujoco_config: {bad}\n")
    with pytest.raises(ConfigError, match=r"(?s)mine.yaml: mujoco_config: .*pile_loading.yaml: invalid LoadingMujocoConfig:.*n_scans: .*allowed: >= 1"):
        validate_file(camp)


def test_the_loading_machines_of_the_configuration_are_the_worlds():
    from excavsim.tasks.pile_loading.world.scene import MACHINES

    assert tuple(LOADING_MACHINES) == tuple(MACHINES)
