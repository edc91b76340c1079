"""``task: truck`` in the episode specification: one truck-loading trial through the platform's episode."""

from __future__ import annotations

import pytest

from excavsim.errors import ConfigError
from excavsim.loop.scenario import EpisodeSpec, resolve, dig_rows, episode_summary, run_spec


def test_a_truck_spec_runs_the_computed_trial_and_gives_a_summary_row():
    from excavsim.tasks.dump_trial.trial import load_truck_config, nominal_params, run_trial

    spec = EpisodeSpec(task="dump_trial", seed=0)
    assert spec.machine_name == "t3"
    trial = run_spec(spec)
    cfg = load_truck_config()
    alone = run_trial(nominal_params(cfg), cfg)  # the computed parameters on a world of their own
    assert trial.params == alone.params and trial.time_s == alone.time_s and trial.dumped_m3 == alone.dumped_m3
    s = episode_summary(trial)
    assert s["task"] == "dump_trial" and s["digs"] == 1 and s["end"] == "done" and s["failed"] == 0
    assert s["loaded_l"] > 5 and s["dumped_fraction"] > 0.9 and 0 <= s["missed_l"] < s["dumped_l"]
    assert 1.0 < s["cycle_s"] < 20.0 and 0 < s["placement_error_cm"] < 50 and s["cost"] > 5 * s["cycle_s"]
    assert dig_rows(trial)[0]["cycle_s"] == s["cycle_s"]


def test_truck_overrides_are_validated_by_the_truck_model_and_other_tasks_fields_refused():
    r = resolve(EpisodeSpec(task="dump_trial", dump_trial={"target": {"r_m": 1.6}, "cost": {"w1_per_s": 2.0}}))
    assert r.target.r_m == 1.6 and r.cost.w1_per_s == 2.0 and r.target.theta_deg == 35.0
    with pytest.raises(ConfigError, match="r_m"):
        resolve(EpisodeSpec(task="dump_trial", dump_trial={"target": {"r_m": -1.0}}))
    with pytest.raises(ConfigError, match="task dump_trial does not use goal .a field of task trench"):
        EpisodeSpec(task="dump_trial", goal="small")
    with pytest.raises(ConfigError, match="dig_budget: task dump_trial has no budget of digs"):
        EpisodeSpec(task="dump_trial", dig_budget=3)
    with pytest.raises(ConfigError, match="task pile_loading does not use dump_trial .a field of task dump_trial"):
        EpisodeSpec(task="pile_loading", dump_trial={"latency_s": 0.2})
    with pytest.raises(ConfigError, match="truck: task dump_trial calls it dump_trial now"):
        EpisodeSpec(task="dump_trial", truck={"latency_s": 0.2})
    with pytest.raises(ConfigError, match="machine 'loader' does not do task dump_trial; allowed: t3"):
        EpisodeSpec(task="dump_trial", machine="loader")


def test_trench_spec_runs_a_truck_spec(tmp_path, capsys):
    from excavsim.cli import main

    path = tmp_path / "dump_trial.yaml"
    path.write_text("name: t\ntask: dump_trial\nsoil: testbed_sand\ndump_trial: {target: {theta_deg: 30.0}}\n")
    assert main(["trench", "--spec", str(path)]) == 0
    out = capsys.readouterr().out
    assert "task dump_trial, machine t3, one trial" in out and "truck-loading trial (Rowe 1997 §6.2)" in out
    assert "theta = 30.0 deg" in out
    assert main(["trench", "--spec", str(path), "--save-maps", str(tmp_path / "maps")]) == 2
    assert "--save-maps: task dump_trial does not take it; it takes --record" in capsys.readouterr().err


def test_run_records_a_truck_trial_that_replays(tmp_path, capsys):
    """``excavsim run SPEC --record`` records the trial as ``tune --record`` records each of its trials:
    the recording passes ``rerun rrd verify`` and holds the site, the pile, the script's phases and joints."""
    from excavsim.cli import main
    from excavsim.record.replay import check_recording
    from tests.tasks.dump_trial.test_truck_tuning import _entities

    path = tmp_path / "dump_trial.yaml"
    path.write_text("name: t\ntask: dump_trial\nseed: 1\n")
    rrd = tmp_path / "t.rrd"
    assert main(["run", str(path), "--record", str(rrd)]) == 0
    out = capsys.readouterr().out
    assert "excavsim run: task dump_trial, machine t3, one trial, seed 1" in out and f"recorded to {rrd}" in out
    check_recording(str(rrd))  # a recording the installed Rerun loads (rerun rrd verify)
    tree = _entities(rrd)
    for per_trial in ("/world/pile/measured", "/world/pile/true", "/world/soil/scan", "/world/exec/path",
                      "/world/target", "/metrics/cost", "/summary"):
        assert tree[per_trial]["trial"] == 1, per_trial
    assert tree["/config"]["static"] == 1 and tree["/joint_deg/swing"]["sim_time"] > 10
    for sub in ("swing", "boom", "stick", "bucket"):
        assert tree[f"/script/{sub}"]["sim_time"] >= 4, sub
    trial = run_spec(EpisodeSpec(task="dump_trial", seed=1))  # recorded or not, the same trial
    assert f"cycle {trial.time_s:.2f} s" in out
