"""Figures of a trenching plan and the ``excavsim plan`` command, on a coarse planner grid."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from excavsim import constants
from excavsim.cli import main
from excavsim.config import PlannerGrid, get_soil, load_planner_config, load_trench_goal
from excavsim.errors import ExcavsimError
from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning import figures
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
LIMITS = np.array([25000.0, 12000.0, 1000.0])  # configs/robot.yaml: shoulder, elbow, wrist pitch
WIDTH, CAPACITY = 0.3, 0.0203981  # models/t3/t3.xml numerics
STRAIGHT = constants.TRENCHES_DIR / "straight.yaml"
# 7 x 4 x 7 = 196 cells instead of 9800: the same ranges, coarser steps.
COARSE = PlannerGrid(k_step_m=0.3, alpha_step_deg=15.0, d1_step_m=0.08)
COARSE_YAML = """\
grid:
  k_step_m: 0.3
  alpha_step_deg: 15.0
  d1_step_m: 0.08
"""


def flat_map(z: float = 0.5) -> ElevationMap:
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)


def assert_png(path) -> None:
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert len(data) > 10_000, f"{path} is suspiciously small ({len(data)} bytes)"


@pytest.fixture(scope="module")
def coarse_plan(arm, reach_table):
    soil = get_soil("testbed_sand")
    config = load_planner_config().model_copy(update={"grid": COARSE})
    goal = load_trench_goal(STRAIGHT)
    planner = TrenchPlanner(arm, reach_table, LIMITS, WIDTH, CAPACITY, goal, config, WedgePredictor(soil, WIDTH),
                            soil.density_kg_m3)
    emap = flat_map()
    result = planner.plan(emap, prune=False)
    assert result.action is not None, f"the coarse grid should still find a dig: {result.reason}"
    surface = SurfaceProfile.from_map(emap, arm, 0.0, WIDTH)
    return planner, result, goal, emap, surface


def test_feasible_sets_figure_is_a_png(coarse_plan, tmp_path):
    _, result, *_ = coarse_plan
    out = figures.plot_feasible_sets(result, tmp_path / "sub" / "sets.png", min_volume_m3=0.9 * CAPACITY)
    assert out == tmp_path / "sub" / "sets.png"
    assert_png(out)


def test_limits_figure_is_a_png(coarse_plan, tmp_path):
    _, result, *_ = coarse_plan
    assert_png(figures.plot_limits(result, tmp_path / "limits.png"))


def test_dig_figure_is_a_png_from_a_profile_or_a_map(coarse_plan, arm, tmp_path):
    planner, result, goal, emap, surface = coarse_plan
    assert_png(figures.plot_dig(result, goal, surface, tmp_path / "dig.png", torque_limits_nm=planner.limits))
    assert_png(figures.plot_dig(result, goal, emap, tmp_path / "dig_map.png", arm=arm, width_m=WIDTH))


def test_dig_figure_needs_an_action(coarse_plan, tmp_path):
    _, result, goal, _, surface = coarse_plan
    no_dig = dataclasses.replace(result, action=None, reason="no feasible dig")
    with pytest.raises(ExcavsimError, match="no dig .*no feasible dig"):
        figures.plot_dig(no_dig, goal, surface, tmp_path / "dig.png")
    assert not (tmp_path / "dig.png").exists()


def test_dig_figure_from_a_map_needs_the_arm(coarse_plan, tmp_path):
    _, result, goal, emap, _ = coarse_plan
    with pytest.raises(ExcavsimError, match="arm= and width_m="):
        figures.plot_dig(result, goal, emap, tmp_path / "dig.png")


def test_set_figures_draw_a_plan_without_a_dig(coarse_plan, tmp_path):
    _, result, *_ = coarse_plan
    no_dig = dataclasses.replace(result, action=None, reason="no feasible dig")
    assert_png(figures.plot_feasible_sets(no_dig, tmp_path / "sets.png"))
    assert_png(figures.plot_limits(no_dig, tmp_path / "limits.png"))


def test_limit_classes_count_pruned_cells_as_geometry_limited(coarse_plan):
    planner, result, *_ = coarse_plan
    pruned = planner.plan(flat_map(), classify_limits=True)  # cells skipped along d1 failed shaping
    full = planner.plan(flat_map(), prune=False, classify_limits=True)
    assert pruned.counts["pruned_d1"] > 0
    classes = figures.limit_classes(pruned)
    feasible = (classes == figures.GEOMETRY_LIMITED) | (classes == figures.FORCE_LIMITED)
    np.testing.assert_array_equal(feasible, pruned.feasible)
    np.testing.assert_array_equal(classes, figures.limit_classes(full))  # same map as the full search


def test_figures_reject_arrays_that_do_not_match_the_grid(coarse_plan, tmp_path):
    _, result, *_ = coarse_plan
    bad = dataclasses.replace(result, feasible=result.feasible[:, :, :-1])
    with pytest.raises(ExcavsimError, match="do not match its grid"):
        figures.plot_limits(bad, tmp_path / "limits.png")


@pytest.fixture()
def cli_env(monkeypatch, tmp_path, arm, reach_table):
    """Run ``excavsim plan`` on the coarse grid with the session's reachability table."""
    import excavsim.robot.reachability as reachability

    def cached(arm_, *args, **kwargs):
        assert arm_.fingerprint() == arm.fingerprint()
        return reach_table

    monkeypatch.setattr(reachability, "load_or_build", cached)
    planner_yaml = tmp_path / "planner.yaml"
    planner_yaml.write_text(COARSE_YAML)
    return ["--planner-config", str(planner_yaml)]


def test_plan_command_prints_the_action_and_writes_three_figures(cli_env, tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["plan", "--out", str(out), *cli_env]) == 0
    text = capsys.readouterr().out
    assert "action" in text and "alpha" in text and "d2" in text
    assert "l of 20.4 l capacity" in text
    assert "torque wrist pitch" in text and "of    1000 N m" in text
    for name in ("feasible_sets.png", "limits.png", "dig.png"):
        assert str(out / name) in text
        assert_png(out / name)


def test_plan_command_without_figures_uses_the_wrist_limit(cli_env, tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["plan", "--out", str(out), "--no-figures", "--wrist-limit", "500", *cli_env]) == 0
    text = capsys.readouterr().out
    assert "of     500 N m" in text
    assert "pruned search" in text
    # with the volume constraint on, Chapter 5's setting of Fig. 87 (volume constraint off) is reported too
    assert "force-limited with the volume constraint off" in text
    assert not out.exists()


def test_plan_command_with_a_bad_goal_exits_2_naming_the_file(cli_env, tmp_path, capsys):
    goal = tmp_path / "goal.yaml"
    goal.write_text("near_x_m: 2.9\nfar_x_m: 1.7\ndepth_m: 0.3\n")
    assert main(["plan", "--goal", str(goal), "--out", str(tmp_path), *cli_env]) == 2
    err = capsys.readouterr().err
    assert str(goal) in err and "far_x_m" in err


def test_plan_command_with_a_missing_map_exits_2_naming_the_file(cli_env, tmp_path, capsys):
    missing = tmp_path / "nowhere.npz"
    assert main(["plan", "--map", str(missing), "--no-figures", *cli_env]) == 2
    assert str(missing) in capsys.readouterr().err
