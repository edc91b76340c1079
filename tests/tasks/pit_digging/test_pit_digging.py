"""The pit-digging task (``excavsim/tasks/pit_digging``, the example of docs/tasks/write-your-own-task.md) through
every tool: its lanes and goal, ``excavsim run`` and ``validate`` on its specification, a campaign with
``record: true`` whose recordings pass ``rerun rrd verify``, ``regress --only pit_small`` against the baseline,
and its Gymnasium environment."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from excavsim import constants
from excavsim.cli import main
from excavsim.errors import ConfigError, EnvError
from excavsim.loop import catalog
from excavsim.loop.scenario import EpisodeSpec, episode_summary, load_spec, resolve, run_spec
from excavsim.tasks.pit_digging.goal import PitGoal, bucket_width_m, pit_lanes, pit_surface
from excavsim.tasks.pit_digging.plugin import PIT_DIG_ENV_ID
from tests.record.test_task_recordings import T3_GRID, TINY_SENSING, verify

SPEC = constants.CONFIGS_DIR / "specs" / "pit_small.yaml"
GOLDEN = constants.CONFIGS_DIR / "regress" / "pit_small.yaml"
QUICK = {"sensing": TINY_SENSING, "planner": T3_GRID}  # coarse scans and planner grid: a quick episode


def strip_corners(lane, width: float) -> np.ndarray:
    """(4, 2) world (x, y) of a lane's bucket-wide strip at its near and far ends."""
    w = math.radians(lane.waist_deg)
    along, across = np.array([math.cos(w), math.sin(w)]), np.array([-math.sin(w), math.cos(w)])
    return np.array([r * along + side * width / 2 * across for r in (lane.near_x_m, lane.far_x_m) for side in (-1, 1)])


def test_the_lanes_fan_over_the_pit_inside_its_opening_and_reach_the_middles_of_its_side_walls():
    pit, width = PitGoal(), bucket_width_m()
    lanes = pit_lanes(pit, width)
    assert width == 0.3 and len(lanes) == 3 and [lane.depth_m for lane in lanes] == [pit.depth_m] * 3
    corners = np.array([strip_corners(lane, width) for lane in lanes])
    assert np.all(corners[..., 0] >= pit.near_x_m - 1e-9) and np.all(corners[..., 0] <= pit.far_x_m + 1e-9)
    half_run = pit.wall_run_m / 2  # 0.0866 m: a 0.1 m wall at 30 degrees reaches 0.173 m in
    assert corners[..., 1].min() == pytest.approx(pit.y_min_m + half_run, abs=0.005)  # the fan: within 5 mm
    assert corners[..., 1].max() == pytest.approx(pit.y_max_m - half_run, abs=0.005)
    centres_far = [lane.far_x_m * math.sin(math.radians(lane.waist_deg)) for lane in lanes]
    assert np.all(np.diff(centres_far) > 0) and np.all(np.diff(centres_far) <= width)  # no gap between lanes
    assert lanes[1].waist_deg == 0.0 and lanes[0].waist_deg == pytest.approx(-lanes[2].waist_deg)
    vertical = pit_lanes(pit.model_copy(update={"wall_deg": 90.0}), width)  # the strips reach the sides
    assert np.array([strip_corners(lane, width) for lane in vertical])[..., 1].max() == pytest.approx(pit.y_max_m, abs=0.005)


def test_the_pit_surface_is_its_bottom_inside_its_walls_and_the_surface_outside():
    pit = PitGoal()
    z = pit_surface(pit, [2.15, 1.0, pit.near_x_m, 2.15, 2.15], [0.0, 0.0, 0.0, pit.y_max_m, pit.y_max_m - 0.05])
    np.testing.assert_allclose(z, [0.4, 0.5, 0.5, 0.5, 0.5 - 0.05 * math.tan(math.radians(30))], atol=1e-12)


def test_a_pit_too_narrow_outside_the_box_or_under_the_spoil_is_refused_naming_what_is_allowed(tmp_path, capsys):
    with pytest.raises(ConfigError, match=r"opening at least 0\.47 m wide"):
        pit_lanes(PitGoal(y_min_m=-0.15, y_max_m=0.15), bucket_width_m())
    spec = yaml.safe_load(SPEC.read_text())
    spec["pit"]["far_x_m"] = 3.9
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(spec))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "pit_small: pit: the opening x 1.8..3.9 m" in err and "not inside the soil box" in err
    with pytest.raises(ConfigError, match=r"the spoil the dig script dumps at \(1.30, 1.09\) m .* lies 0.09 m from"):
        resolve(EpisodeSpec(task="pit_digging", pit={"near_x_m": 1.0, "y_max_m": 1.0}))  # the dumps would refill it


def test_validate_accepts_the_specification_and_the_golden_scenario(capsys):
    assert main(["validate", str(SPEC), str(GOLDEN)]) == 0
    out = capsys.readouterr().out
    assert "kind spec" in out and "kind regress" in out


def test_run_digs_the_small_pit_lane_by_lane(capsys):
    """``excavsim run configs/specs/pit_small.yaml``: the same episode as the library's, its table and end."""
    result = run_spec(load_spec(SPEC))
    s = episode_summary(result)
    assert s["task"] == "pit_digging" and s["end"] in ("done", "no_dig", "budget")
    assert s["lanes_dug"] == 3 and 3 <= s["digs"] <= 8 and s["removed_fraction"] > 0.7 and s["overdig_max_cm"] < 2
    assert [d.kind for d in result.digs][0] == "lane 2"  # the middle lane's strip holds the most soil at first
    assert main(["run", str(SPEC)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("excavsim run: pit small, 0.70 x 0.90 m, 0.10 m deep, in 3 lanes, 8 digs at most")
    assert f"removed {s['removed_l']:.1f} l of {s['goal_l']:.1f} l" in out and f"ended: {s['reason']}" in out


def test_a_campaign_with_record_true_over_two_seeds_records_episodes_rerun_verifies(tmp_path):
    from excavsim.studies.campaign.runner import load_campaign, run_campaign

    path = tmp_path / "pit.yaml"
    path.write_text(yaml.safe_dump({"name": "pit", "record": True, "grid": {"seed": [0, 1]},
                                    "base": {"task": "pit_digging", "dig_budget": 2, **QUICK}}))
    report = run_campaign(load_campaign(path), tmp_path / "out", workers=1, progress=None)
    assert report.errors == 0 and [r["task"] for r in report.rows] == ["pit_digging"] * 2
    assert all(r["digs"] == 2 and r["lanes_dug"] >= 1 for r in report.rows)
    recordings = sorted((tmp_path / "out" / "recordings").glob("*.rrd"))
    assert len(recordings) == 2
    for rrd in recordings:
        verify(rrd)


def test_regress_judges_pit_small_against_its_baseline(capsys):
    assert main(["regress", "--only", "pit_small", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    metrics = doc["scenarios"]["pit_small"]["metrics"]
    assert set(metrics) == set(catalog.plugin("pit_digging").metrics)
    assert {m["verdict"] for m in metrics.values()} <= {"same", "better"} and doc["verdict"] == "no regression"


def test_the_environment_is_registered_passes_gymnasiums_checker_and_digs_the_agents_lane():
    gymnasium = pytest.importorskip("gymnasium")
    from gymnasium.utils.env_checker import check_env

    import excavsim.envs  # noqa: F401  (registers every plug-in's environments)

    env = gymnasium.make(PIT_DIG_ENV_ID, spec={"dig_budget": 2, **QUICK})
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert env.action_space == gymnasium.spaces.Discrete(3) and obs["soil_l"].shape == (3,) and info == {}
    obs, reward, terminated, truncated, info = env.step(0)
    assert info["lane_used"] == 0 and info["dig"]["lane"] == "lane 1" and reward > 5  # litres removed
    assert obs["soil_l"][0] < obs["soil_l"][2] and obs["digs_left"] == 1 and not (terminated or truncated)
    *_, terminated, truncated, info = env.step(2)
    assert truncated and not terminated and info["episode"]["digs"] == 2 and "wall_s" not in info["episode"]
    with pytest.raises(EnvError, match="reset"):
        env.step(1)
    env.reset(seed=0)
    with pytest.raises(EnvError, match="integer from 0 to 2"):
        env.step(3)
    env.close()


def test_the_environment_refuses_a_specification_of_another_task():
    from excavsim.tasks.pit_digging.env import PitDigEnv

    with pytest.raises(EnvError, match="task pit_digging"):
        PitDigEnv(EpisodeSpec(task="trench", goal="small"))
