"""A short trenching episode end to end, with its metrics and stopping rules."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.handoff.episode import format_episode
from excavsim.loop.episode import run_episode
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


def _tiny_episode(**kw):
    from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec, spec_episode

    fields = {"goal": "small", "dig_budget": 2,
              "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
              "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0}}}
    spec = EpisodeSpec(**{**fields, **kw})
    return spec, spec_episode(spec, ResolvedSpec(spec))


def test_an_episode_stepped_phase_by_phase_is_run_episode_and_refuses_phases_out_of_order():
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.episode import EpisodeError
    from excavsim.loop.scenario import episode_summary, run_spec, spec_digs

    class Hooks(EpisodeObserver):
        def __init__(self):
            self.calls = []

        def started(self, sim, rig, goal_mask, goal_z):
            self.calls.append("started")

        def scanned(self, index, emap, accuracy):
            self.calls.append(f"scanned {index}")

        def planned(self, index, plan, dig):
            self.calls.append(f"planned {index}")

        def dug(self, index, record, metrics):
            self.calls.append(f"dug {index}")

        def finished(self, result):
            self.calls.append("finished" if result is not None else "finished None")

    spec, _ = _tiny_episode(dig_budget=2, done_fraction=1.0, tolerance_m=0.001)
    whole = episode_summary(run_spec(spec))
    hooks = Hooks()
    _, ep = _tiny_episode(dig_budget=2, done_fraction=1.0, tolerance_m=0.001)
    ep.observer = hooks
    with pytest.raises(EpisodeError, match="call reset"):
        ep.look()
    ep.reset(spec.seed, digs=spec_digs(spec))
    with pytest.raises(EpisodeError, match="the next phase is look"):
        ep.dig()
    emap = ep.look()
    assert emap is not None and ep.index == 1 and not ep.over
    ep.decide()
    ep.dig()
    assert len(ep.task.metrics) == 1 and ep.task.record is not None
    ep.step()  # a whole cycle: the second dig
    assert not ep.over and len(ep.task.metrics) == 2
    ep.step()  # the last scan: the budget is spent
    assert ep.over and ep.result.end == "budget"
    timing = ("wall_s", "planning_s")
    assert {k: v for k, v in episode_summary(ep.result).items() if k not in timing} == \
        {k: v for k, v in whole.items() if k not in timing}
    assert hooks.calls == ["started", "scanned 1", "planned 1", "dug 1", "scanned 2", "planned 2", "dug 2",
                           "scanned 3", "finished"]
    with pytest.raises(EpisodeError, match="has ended"):
        ep.step()
    ep.reset(spec.seed, digs=spec_digs(spec))  # again, then abandoned: the observers hear finished(None)
    ep.look()
    ep.close()
    assert hooks.calls[-3:] == ["started", "scanned 1", "finished None"] and ep.over
    assert ep.sim.step_hooks == []


def test_an_error_in_a_phase_ends_the_episode_with_finished_none():
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.digs import DigSource

    class Broken(DigSource):
        def choose(self, rig, emap):
            raise RuntimeError("the source broke")

    class Ends(EpisodeObserver):
        result = "not called"

        def finished(self, result):
            self.result = result

    _, ep = _tiny_episode()
    ep.observer = ends = Ends()
    ep.reset(0, digs=Broken())
    with pytest.raises(RuntimeError, match="the source broke"):
        ep.step()
    assert ep.over and ends.result is None and ep.sim.step_hooks == [] and ep.sim.wall_deadline is None
