"""The command line refuses bad arguments before any work: paths that cannot be written, numbers out of
range, recordings that are not recordings, every kind of configuration file. Exit status 2, one message
naming the option and the value, no traceback."""

from __future__ import annotations


import pytest

from excavsim import constants
from excavsim.cli import MAX_SEED, main


def _refused(capsys, argv: list[str]) -> str:
    """Run ``excavsim argv``, check it exits with status 2 without a traceback, and return its stderr."""
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2, err
    assert "Traceback" not in err
    return err


@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "a_file"
    path.write_text("not a directory\n")
    return path


@pytest.mark.parametrize("argv", [
    ["trench", "--save-maps", "{file}"],
    ["trench", "--save-maps", "{file}/maps"],
    ["trench", "--record", "{file}/x.rrd"],
    ["plan", "--out", "{file}"],
    ["campaign", str(constants.CONFIGS_DIR / "campaigns" / "tiny.yaml"), "--out", "{file}/sub"],
    ["experiment", "fig113", "--out", "{file}"],
    ["learn", "--out", "{file}"],
    ["learn", "--dataset", "{file}/d.npz"],
])
def test_an_output_path_under_a_file_is_refused_naming_the_option_and_the_path(capsys, a_file, argv):
    argv = [a.replace("{file}", str(a_file)) for a in argv]
    option = next(a for a in argv if a.startswith("--"))
    err = _refused(capsys, argv)
    assert f"argument {option}" in err and str(a_file) in err, err


def test_a_record_path_must_be_an_rrd_file_and_not_a_directory(capsys, tmp_path):
    assert ".rrd" in _refused(capsys, ["trench", "--record", str(tmp_path / "episode.txt")])
    (tmp_path / "d.rrd").mkdir()
    assert "is not a file" in _refused(capsys, ["trench", "--record", str(tmp_path / "d.rrd")])


def test_a_place_nobody_can_write_is_refused(capsys):
    """/proc refuses new files even to root (a read-only directory would not stop root)."""
    err = _refused(capsys, ["plan", "--out", "/proc/excavsim-figures"])
    assert "argument --out" in err and "cannot write in /proc" in err, err


def test_plan_refuses_its_output_before_planning(capsys, a_file):
    err = _refused(capsys, ["plan", "--out", str(a_file)])
    assert "is not a directory" in err
    assert "excavsim plan:" not in capsys.readouterr().out  # the header printed once planning starts


@pytest.mark.parametrize(("argv", "option", "allowed"), [
    (["trench", "--seed", "-1"], "--seed", f"0 to {MAX_SEED}"),
    (["trench", "--seed", str(2**64)], "--seed", f"0 to {MAX_SEED}"),
    (["trench", "--seed", "1.5"], "--seed", "not an integer"),
    (["trench", "--dig-budget", "100000"], "--dig-budget", "1 to 1000"),
    (["trench", "--dig-budget", "0"], "--dig-budget", "1 to 1000"),
    (["demo", "--seed", "-3"], "--seed", "0 to"),
    (["experiment", "fig113", "--seeds", "0"], "--seeds", "1 to 1000"),
    (["experiment", "fig113", "--dig-budget", "-2"], "--dig-budget", "1 to 1000"),
    (["campaign", "x.yaml", "--workers", "0"], "--workers", "1 to 1024"),
    (["plan", "--wrist-limit", "1e-300"], "--wrist-limit", ">= 10"),
    (["plan", "--wrist-limit", "nan"], "--wrist-limit", ">= 10"),
    (["learn", "--folds", "1"], "--folds", "2 to 1000"),
    (["learn", "--forgetting", "0"], "--forgetting", "> 0"),
])
def test_numbers_out_of_range_are_refused_by_the_parser(capsys, argv, option, allowed):
    err = _refused(capsys, argv)
    assert f"argument {option}" in err and allowed in err, err
    assert "ValidationError" not in err


def test_a_goal_given_as_a_huge_string_is_an_unknown_goal(capsys):
    err = _refused(capsys, ["trench", "--goal", "g" * 1_000_000])
    assert "argument --goal" in err and len(err) < 2000
    err = _refused(capsys, ["plan", "--goal", "g" * 2000])
    assert "unknown trench goal" in err and "more characters" in err and len(err) < 2000


def test_replay_refuses_random_bytes_and_an_empty_file(capsys, tmp_path):
    noise = tmp_path / "noise.rrd"
    noise.write_bytes(bytes((i * 7919) % 256 for i in range(4096)))
    assert "not a Rerun recording" in _refused(capsys, ["replay", "--dry-run", str(noise)])
    empty = tmp_path / "empty.rrd"
    empty.write_bytes(b"")
    assert "not a Rerun recording" in _refused(capsys, ["replay", "--dry-run", str(empty)])
    garbled = tmp_path / "garbled.rrd"
    garbled.write_bytes(b"RRF2" + bytes(range(256)) * 8)
    assert "Rerun cannot load this recording" in _refused(capsys, ["replay", "--dry-run", str(garbled)])
    header = tmp_path / "header.rrd"
    header.write_bytes(b"RRF2")
    assert "no recording in it" in _refused(capsys, ["replay", "--dry-run", str(header)])
    assert "no recording at" in _refused(capsys, ["replay", "--dry-run", str(tmp_path / "absent.rrd")])
    assert "no recording at" in _refused(capsys, ["replay", "--dry-run", str(tmp_path)])


@pytest.mark.parametrize(("kind", "path"), [
    ("robot", constants.ROBOT_YAML), ("scene", constants.SCENE_YAML), ("soils", constants.SOILS_YAML),
    ("sensing", constants.SENSING_YAML), ("planner", constants.PLANNER_YAML), ("executor", constants.EXECUTOR_YAML),
    ("goal", constants.TRENCHES_DIR / "sand.yaml"),
    ("campaign", constants.CONFIGS_DIR / "campaigns" / "tiny.yaml"),
    ("experiment", constants.CONFIGS_DIR / "experiments" / "fig114.yaml"),
])
def test_validate_covers_every_kind(capsys, kind, path):
    assert main(["validate", kind, str(path)]) == 0
    assert "valid" in capsys.readouterr().out


@pytest.mark.parametrize(("kind", "text", "match"), [
    ("goal", "near_x_m: 3.6\nfar_x_m: 3.9\ndepth_m: 0.2\n", "outside the soil box"),
    ("spec", "goal: sand\nscene: {initial_soil_height_m: 0.0}\n", "above the initial soil at 0 m"),
    ("spec", "planner: {sample_spacing_m: 1.0e-9}\n", "the search would need"),
    ("spec", "executor: {dump_pose: [-1.0e308, 1.3, 100.0]}\n", "dump_pose"),
    ("campaign", "name: c\ngrid: {goal.surface_z_m: [0.5, 1.4]}\n", "surface_z_m"),
    ("experiment", "name: e\ntitle: t\nthesis: t\nruns: [{goal: {near_x_m: 0.1, far_x_m: 0.3, depth_m: 0.1}}]\n",
     "outside the soil box"),
    ("robot", "a: 1\na: 2\n", "found the key 'a' twice"),
])
def test_validate_refuses_nonsense_of_every_kind(capsys, tmp_path, kind, text, match):
    path = tmp_path / f"{kind}.yaml"
    path.write_text(text)
    err = _refused(capsys, ["validate", kind, str(path)])
    assert err.startswith(f"excavsim: error: {path}") and match in err, err


def test_run_runs_a_spec_of_any_task_through_its_plugin(capsys, monkeypatch):
    """``excavsim run SPEC`` asks the spec's task for its first line and its table, naming itself; a field its
    task does not use is refused."""
    import excavsim.loop.scenario as scenario
    from excavsim.loop import catalog

    seen = []
    monkeypatch.setattr(scenario, "run_spec", lambda spec, **kw: seen.append(spec) or object())
    monkeypatch.setattr(catalog.plugin("dump_trial"), "format_run", lambda result: "the task's table")
    assert main(["run", "configs/specs/dump_trial.yaml", "--seed", "4"]) == 0
    out = capsys.readouterr().out
    assert "excavsim run: task dump_trial, machine t3, one trial, seed 4" in out and "the task's table" in out
    assert seen[0].task == "dump_trial" and seen[0].seed == 4
    assert main(["run", "configs/specs/dump_trial.yaml", "--dig-budget", "3"]) == 2
    assert "dig_budget: task dump_trial has no budget of digs" in capsys.readouterr().err
    assert main(["run"]) == 2  # SPEC is required
