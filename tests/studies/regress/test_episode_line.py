"""The progress lines of regress and campaign speak each task's measures, by the task's own ``progress_text``
(a truck-loading episode has no '% removed')."""

from excavsim.studies.regress.suite import _episode_line


def test_truck_loading_line_names_passes_truck_and_spill():
    r = {"task": "truck_loading", "digs": 7, "truck_t": 11.32, "spill_l": 2.4, "cycle_s": 26.04, "end": "done",
         "wall_s": 4.0}
    line = _episode_line("[1/4] ", "truck_loading_25t", 0, r)
    assert line == ("[1/4] truck_loading_25t seed 0: 7 passes, 11.3 t in the truck, 2 l spilled, 26.0 s a bucket, "
                    "ended done (4.0 s wall)")


def test_trench_line_and_a_missing_key():
    line = _episode_line("", "small_sand", 3, {"digs": 5, "removed_fraction": 0.96, "end": "done", "wall_s": 9.0},
                         "trench")
    assert line == "small_sand seed 3: 5 digs, ? l/dig, 96 % removed, ? stalls, ended done (9.0 s wall)"


def test_the_baseline_schema_takes_every_registered_task_and_validate_refuses_an_unknown_one(tmp_path):
    """A golden scenario of any task can enter the baseline (truck_loading's was refused by validate once); the
    schema names no task, validate asks the catalog."""
    import json

    import pytest

    from excavsim.config.baseline import ScenarioBaseline
    from excavsim.errors import ConfigError
    from excavsim.loop.catalog import names
    from excavsim.validate import validate_file

    for task in names():
        ScenarioBaseline.model_validate({"seeds": [0], "task": task})
    doc = {"format": 2, "scenarios": {"s": {"seeds": [0], "task": "no_such_task", "metrics": {}}}}
    (tmp_path / "b.json").write_text(json.dumps(doc))
    with pytest.raises(ConfigError, match="scenarios.s.task: unknown task 'no_such_task'"):
        validate_file(tmp_path / "b.json")


def test_campaign_and_regress_lines_say_the_same_of_an_episode():
    from excavsim.studies.campaign.runner import _progress_line

    for summary in ({"task": "truck_loading", "end": "done", "digs": 7, "truck_t": 11.3, "spill_l": 2.0, "cycle_s": 26.0},
                    {"task": "pile_loading", "end": "budget", "digs": 2, "removed_fraction": 0.2, "delivered_l": 912.0},
                    {"task": "dump_trial", "end": "done", "dumped_l": 10.0, "missed_l": 0.5, "cycle_s": 3.7},
                    {"task": "dump_trial", "end": "done", "tuning": "learn", "trials": 12, "first_cost": 64.5,
                     "last_cost": 25.7, "cycle_s": 3.7}):
        campaign = _progress_line(1, 1, {"id": "x", "status": "ok", "wall_s": 1.0, "summary": summary}, 0.0)
        regress = _episode_line("", "x", 0, {**summary, "wall_s": 1.0})
        what = campaign.split(": ", 1)[1].removeprefix(summary["end"] + ": ").rsplit(" (", 1)[0]
        assert what and what in regress and "?" not in what, (campaign, regress)
