"""A short trenching episode end to end, with its metrics and stopping rules."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.handoff.episode import format_episode
from excavsim.tasks.trench.task import run_episode
from excavsim.world.simulation import Simulation


def test_a_two_dig_episode_digs_measures_and_conserves():
    sim = Simulation(seed=0)
    res = run_episode(sim, seed=0, dig_budget=2)
    assert len(res.digs) == 2 and res.reason == "dig budget of 2 spent"
    assert 0.2 < res.removed_fraction < 1.0  # two bucketfuls of a ~92 l trench
    assert all(d.bucket_m3 > 0.0 for d in res.digs) and all(d.planning_s > 0 for d in res.digs)
    assert res.overdig_max_m < 0.1 and res.underdig_max_m > 0.05
    assert abs(res.volume_change_m3) < 1e-12 * sim.soil.initial_volume
    assert np.all(np.isfinite([d.cumulative_torque_nm_s for d in res.digs]))
    assert "ended: dig budget" in format_episode(res)


def test_an_episode_stops_when_no_dig_is_useful(tmp_path):
    goal = tmp_path / "far.yaml"
    goal.write_text("near_x_m: 3.6\nfar_x_m: 3.95\ndepth_m: 0.2\n")
    sim = Simulation(seed=1)
    from excavsim.config import load_trench_goal

    res = run_episode(sim, seed=1, goal=load_trench_goal(goal), dig_budget=3)
    assert res.digs == [] and res.reason.startswith("no dig of minimum utility")


def test_cli_trench_refuses_a_bad_budget(capsys):
    assert main(["trench", "--dig-budget", "0"]) == 2
    assert "--dig-budget" in capsys.readouterr().err


def test_a_small_trench_is_finished_to_tolerance_and_the_same_seed_repeats_it_exactly():
    from excavsim.loop.scenario import EpisodeSpec, episode_summary, run_spec

    spec = EpisodeSpec(goal="small", seed=0, dig_budget=4,
                       sensing={"map": {"n_scans": 2}, "scanner": {"n_azimuth": 100, "n_elevation": 100}},
                       planner={"grid": {"k_min_m": 1.7, "k_max_m": 2.7, "alpha_step_deg": 10.0}})
    runs = [episode_summary(run_spec(spec)) for _ in range(2)]
    first = runs[0]
    assert first["end"] == "done", first["reason"]
    assert first["removed_fraction"] > 0.85 and first["overdig_max_cm"] < 3.0  # on the true terrain
    assert abs(first["volume_change_m3"]) < 1e-12
    timing = ("wall_s", "planning_s")
    untimed = [{k: v for k, v in run.items() if k not in timing} for run in runs[:2]]
    assert untimed[0] == untimed[1]


def test_an_episode_spec_can_plan_with_a_predictor_learned_online():
    from excavsim.config import ConfigError
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.learning.adapter import LearnedForcePredictor
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    with pytest.raises(ConfigError, match="unknown predictor 'oracle'; allowed: wedge, global"):
        EpisodeSpec(predictor="oracle")

    class Seen(EpisodeObserver):
        def started(self, sim, rig, goal_mask, goal_z):
            self.predictor = rig.planner.predictor

        def dug(self, index, record, metrics):
            self.dug_l = metrics.bucket_m3 * 1000

    seen = Seen()
    spec = EpisodeSpec(goal="small", dig_budget=1, predictor="global",
                       sensing={"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
                       planner={"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0}})
    run_spec(spec, observer=seen)
    assert isinstance(seen.predictor, LearnedForcePredictor) and seen.dug_l > 0


def test_cli_trench_runs_a_spec_saves_its_maps_and_plan_reads_one(tmp_path, capsys):
    import yaml

    spec = tmp_path / "tiny.yaml"
    spec.write_text(yaml.safe_dump({
        "name": "tiny", "goal": "small", "dig_budget": 1,
        "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
        "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0}}}))
    maps = tmp_path / "maps"
    assert main(["trench", "--spec", str(spec), "--seed", "2", "--save-maps", str(maps)]) == 0
    out = capsys.readouterr().out
    assert "small trench, 1 digs at most" in out and "seed 2" in out and "ended:" in out
    assert sorted(p.name for p in maps.iterdir()) == ["map_01.npz", "map_02.npz"]  # before and after the dig
    assert main(["plan", "--map", str(maps / "map_02.npz"), "--goal", "small",
                 "--no-figures"]) == 0
    assert "action" in capsys.readouterr().out
