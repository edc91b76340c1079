"""The boundary-following fallback digs of §7.2: shape, volume, feasibility and the order they are tried."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_planner_config, load_robot_config, load_trench_goal
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner
from excavsim.robot.extract import arm_from_model
from excavsim.robot.reachability import load_or_build
from excavsim.tasks.trench.mind import fallback


@pytest.fixture(scope="module")
def setup():
    model = mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))
    arm = arm_from_model(model)
    table = load_or_build(arm)
    width = float(model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    j = load_robot_config().joints
    limits = np.array([j.shoulder.torque_limit_nm, j.elbow.torque_limit_nm, j.wrist_pitch.torque_limit_nm])
    soil = get_soil("testbed_sand")
    goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")

    def make(limits=limits, **overrides):
        cfg = load_planner_config().model_copy(update=overrides)
        return TrenchPlanner(arm, table, limits, width, capacity, goal, cfg, WedgePredictor(soil, width),
                             soil.density_kg_m3)

    return make, goal


def _map(goal, above_goal_m: float, cell: float = 0.05) -> ElevationMap:
    """A flat-sand map with the trench already dug to ``above_goal_m`` over the goal profile."""
    n = int(round(3.0 / cell))
    x = 0.55 + cell * np.arange(n)
    z = np.minimum(goal.surface_z_m, goal_profile(goal, x) + above_goal_m)
    return ElevationMap(0.55, -1.5, cell, np.tile(z, (n, 1)), np.ones((n, n), bool), 0.0)


def test_the_boundary_path_runs_the_goal_outline_at_its_clearance(setup):
    make, goal = setup
    planner = make(fallback_clearance_m=0.02)
    line, (i_far, i_near) = fallback.boundary_polyline(planner)
    assert np.all(np.diff(line[:, 0]) < 0)  # always towards the robot
    np.testing.assert_allclose(line[:, 1] - goal_profile(goal, line[:, 0]), 0.02, atol=1e-9)
    assert line[0, 0] == goal.far_x_m and line[-1, 0] == goal.near_x_m
    np.testing.assert_allclose(line[i_far:i_near + 1, 1], goal.surface_z_m - goal.depth_m + 0.02)
    # rake: wall + epsilon going down, eq. 1 along the bottom, the curl's end pitch at the near top
    assert math.degrees(line[0, 2]) == pytest.approx(goal.far_wall_deg + planner.cfg.epsilon_deg)
    assert np.all(np.diff(line[i_far:, 2]) <= 1e-12)
    assert math.degrees(line[-1, 2]) == pytest.approx(planner.cfg.curl_end_pitch_deg)


def test_a_nearly_finished_trench_gets_a_feasible_boundary_dig_that_never_cuts_the_goal(setup):
    make, goal = setup
    planner = make()
    emap = _map(goal, 0.05)
    dig, why = fallback.choose_boundary(planner, emap)
    assert dig is not None and why.startswith("boundary dig")
    assert dig.reachable and dig.peak_torque_ratio <= 1.0
    vmin = planner.cfg.fallback_min_volume_fraction * planner.capacity
    assert vmin <= dig.volume_m3 <= planner.capacity * 1.01
    body = dig.poses[dig.phases < 2]
    assert np.all(body[:, 1] >= goal_profile(goal, body[:, 0]) + planner.cfg.fallback_clearance_m - 1e-9)
    # the planner's own check agrees on reachability and force for the same path
    assert dig.poses[0, 1] <= 0.5 + planner.cfg.surface_tolerance_m  # enters in the soil


def test_walls_come_before_the_bottom(setup):
    make, goal = setup
    labels = [d.label for d in fallback.candidates(make(), _map(goal, 0.05))]
    assert labels[:2] == ["far wall", "near wall"] and all(lab.startswith("bottom") for lab in labels[2:])


def test_no_fallback_once_the_trench_is_at_the_goal(setup):
    make, goal = setup
    # (a fine map: a 5 cm map's interpolation rounds the bottom corners off, which looks like soil)
    dig, why = fallback.choose_boundary(make(), _map(goal, 0.0, cell=0.01))
    assert dig is None and why


def test_a_weak_wrist_shortens_the_boundary_digs_or_refuses_them(setup):
    make, goal = setup
    emap = _map(goal, 0.08)
    strong = fallback.choose_boundary(make(), emap)[0]
    weak_planner = make(limits=np.array([20000.0, 20000.0, 150.0]))
    weak, why = fallback.choose_boundary(weak_planner, emap)
    assert strong is not None
    if weak is None:
        assert "torque" in why
    else:
        assert weak.peak_torque_ratio <= 1.0 and weak.volume_m3 < strong.volume_m3


def test_the_far_wall_beyond_the_wrists_reach_gets_a_steeper_rake_and_stays_above_the_goal(setup):
    """The default sand trench ends at 2.8 m with a 30-deg wall: wall + epsilon (40 deg) is out of the
    arm's reach there (the wrist holds the bucket no flatter than ~55 deg), so the far-wall dig raises
    the rake to the smallest the arm holds, and the dig is reachable and never cuts the goal."""
    make, _ = setup
    goal = load_trench_goal(constants.TRENCHES_DIR / "sand.yaml")
    planner = make()
    planner.goal = goal
    cfg = planner.cfg
    line, (i_far, i_near) = fallback.boundary_polyline(planner)
    nominal = math.radians(goal.far_wall_deg + cfg.epsilon_deg)
    assert not planner.reach(np.array([[line[0, 0], line[0, 1], nominal]]))[0][0]  # the thesis' rake fails
    assert np.all(line[: i_far + 1, 2] >= nominal - 1e-12) and line[0, 2] > nominal
    reach, _ = planner.reach(line[: i_near + 1])
    assert reach.all()
    raised = line[: i_near + 1, 2] > nominal + 1e-9
    lowered = line[: i_near + 1].copy()
    lowered[:, 1] -= cfg.touchdown_reach_m
    assert planner.reach(lowered[raised])[0].all()  # the touch-down search below holds too
    # each raised sample is the smallest rake (1-deg steps) that holds
    for p in line[: i_near + 1][raised][:5]:
        less = np.array([[p[0], p[1], p[2] - math.radians(1.0)], [p[0], p[1] - cfg.touchdown_reach_m,
                                                                  p[2] - math.radians(1.0)]])
        assert not planner.reach(less)[0].all()
    emap = _map(goal, 0.03)
    far = fallback.candidates(planner, emap)[0]
    assert far.label == "far wall" and far.feasible
    assert far.volume_m3 >= cfg.fallback_min_volume_fraction * planner.capacity
    body = far.poses[far.phases < 2]
    assert np.all(body[:, 1] >= goal_profile(goal, body[:, 0]) + cfg.fallback_clearance_m - 1e-9)
