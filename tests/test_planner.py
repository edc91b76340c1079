"""The action-space trenching planner: trajectories, constraints, search, objectives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import TrenchGoal, get_soil, load_planner_config, load_trench_goal
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

LIMITS = np.array([25000.0, 12000.0, 1000.0])  # configs/robot.yaml: shoulder, elbow, wrist pitch
WIDTH, CAPACITY = 0.3, 0.0203981  # models/t3/t3.xml numerics
STRAIGHT = constants.TRENCHES_DIR / "straight.yaml"


def flat_map(z: float = 0.5) -> ElevationMap:
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)


def make_planner(arm, table, *, goal=None, soil="testbed_sand", limits=LIMITS, **cfg) -> TrenchPlanner:
    s = get_soil(soil)
    config = load_planner_config().model_copy(update=cfg)
    return TrenchPlanner(arm, table, limits, WIDTH, CAPACITY, goal or load_trench_goal(STRAIGHT), config,
                         WedgePredictor(s, WIDTH), s.density_kg_m3)


@pytest.fixture(scope="module")
def straight_plan(arm, reach_table):
    planner = make_planner(arm, reach_table)
    return planner, planner.plan(flat_map())


def test_goal_profile_follows_the_walls_and_bottom():
    g = TrenchGoal(near_x_m=1.7, far_x_m=2.9, depth_m=0.3, near_wall_deg=45.0, far_wall_deg=90.0)
    z = goal_profile(g, np.array([1.0, 1.7, 1.8, 2.5, 2.89, 3.2]))
    np.testing.assert_allclose(z, [0.5, 0.5, 0.4, 0.2, 0.2, 0.5])


def test_trajectory_follows_the_rake_rules(straight_plan):
    """§3.4.2: penetrate at rake alpha + epsilon; drag with rake max(zeta, rho_i - omega s); curl up."""
    planner, _ = straight_plan
    surface = SurfaceProfile.from_map(flat_map(), planner.arm, 0.0, WIDTH)
    alpha = math.radians(30)
    poses, phases = planner.trajectory((2.6, alpha, 0.2, 1.0), surface, radius=0.3)
    pen, drag, curl = poses[phases == 0], poses[phases == 1], poses[phases == 2]
    np.testing.assert_allclose(pen[:, 2], alpha + math.radians(10))
    np.testing.assert_allclose(pen[-1, :2], [2.6 - 0.2 * math.cos(alpha), 0.5 - 0.2 * math.sin(alpha)])
    s = pen[-1, 0] - drag[:, 0]
    np.testing.assert_allclose(drag[:, 2], np.maximum(math.radians(8), alpha + math.radians(10) - math.radians(50) * s))
    np.testing.assert_allclose(drag[:, 1], pen[-1, 1])
    # The curl turns about a centre 0.3 m from the edge, between the blade's heel direction and its
    # normal, to -30 deg; the blade's points then move away from the soil below it (Fig. 16).
    rho = drag[-1, 2]
    b, zt = np.array([math.cos(rho), math.sin(rho)]), np.array([-math.sin(rho), math.cos(rho)])
    centre = drag[-1, :2] + 0.3 * (b + zt) / math.sqrt(2)
    np.testing.assert_allclose(np.linalg.norm(curl[:, :2] - centre, axis=1), 0.3, atol=1e-12)
    heel = drag[-1, :2] + 0.2 * b  # a point of the bottom 0.2 m behind the edge (< 0.3 / sqrt 2)
    v = np.array([(heel - centre)[1], -(heel - centre)[0]])  # clockwise rotation at unit rate
    assert v @ zt > 0
    assert curl[-1, 2] == pytest.approx(math.radians(-30))
    assert np.all(np.diff(curl[:, 2]) < 0) and curl[-1, 1] > drag[-1, 1]


def test_flat_terrain_max_volume_dig_is_the_one_known_by_construction(arm, reach_table):
    """A shallow trench with vertical walls and no volume limit: the biggest dig must cut down to the
    bottom of the goal and no further, inside the trench, with the largest swept volume of the grid."""
    goal = TrenchGoal(near_x_m=1.9, far_x_m=2.6, depth_m=0.08, near_wall_deg=90.0, far_wall_deg=90.0)
    planner = make_planner(arm, reach_table, goal=goal, objective="volume", fill_fraction=5.0)
    res = planner.plan(flat_map())
    k, alpha, d1, d2 = res.action
    assert goal.near_x_m < k <= goal.far_x_m + 1e-9  # it enters within the trench's opening
    assert res.poses[:, 1].min() == pytest.approx(0.42, abs=planner.cfg.shaping_tolerance_m + 0.01)
    assert np.all(res.poses[:, 1] >= goal_profile(goal, res.poses[:, 0]) - planner.cfg.shaping_tolerance_m)
    assert res.volume_m3 == pytest.approx(np.nanmax(res.volume))
    assert d2 > 0.2


def test_each_constraint_rejects_a_violating_dig_and_accepts_a_compliant_one(straight_plan, arm, reach_table):
    planner, res = straight_plan
    emap = flat_map()
    good = planner.check_action(emap, res.action)
    assert all(good[c] for c in ("shaping", "sensible", "volume", "reachability", "force")), good
    a30 = math.radians(30)
    # shaping: a penetration of 0.8 m at 30 deg goes 0.4 m deep, below the 0.3 m bottom
    assert not planner.check_action(emap, (2.8, a30, 0.8, 0.0))["shaping"]
    # volume: 0.25 m deep for 0.6 m sweeps far more than a bucketful
    v = planner.check_action(emap, (2.8, math.radians(40), 0.39, 0.3))
    assert v["shaping"] and not v["volume"] and v["volume_m3"] > CAPACITY
    # reachability: entering 3.3 m out at 45 deg
    assert not planner.check_action(emap, (3.3, math.radians(45), 0.1, 0.0))["reachability"]
    # sensible: a drag through a pre-dug pit runs through air
    pit = flat_map()
    pit.heights[28:33, 30:36] = 0.25  # x 2.05-2.35, y around 0, 25 cm deep
    assert planner.check_action(emap, (2.6, a30, 0.2, 0.6))["sensible"]
    assert not planner.check_action(pit, (2.6, a30, 0.2, 0.6))["sensible"]
    # force: the same dig with a 50 N m wrist
    weak = make_planner(arm, reach_table, limits=np.array([25000.0, 12000.0, 50.0]))
    assert planner.check_action(emap, res.action)["force"]
    assert not weak.check_action(emap, res.action)["force"]


def test_the_chosen_dig_passes_every_constraint_on_its_whole_path(straight_plan):
    planner, res = straight_plan
    assert res.action is not None and res.volume_m3 >= 0.9 * CAPACITY  # eq. 44 threshold met
    check = planner.check_action(flat_map(), res.action)
    assert check["volume_m3"] == pytest.approx(res.volume_m3, rel=1e-9)
    assert np.max(np.abs(res.torques) / LIMITS) <= 1.0 + 1e-9
    assert set(np.unique(res.phases)) == {0, 1, 2}


def test_pruning_gives_the_same_answer_as_no_pruning(straight_plan):
    planner, res = straight_plan
    full = planner.plan(flat_map(), prune=False)
    assert full.action == res.action
    np.testing.assert_array_equal(full.feasible, res.feasible)
    np.testing.assert_allclose(full.volume[res.feasible], res.volume[res.feasible])
    assert res.counts["pruned_d1"] > 0 and full.counts["pruned_d1"] == 0
    assert res.counts["force_samples"] < full.counts["force_samples"]


def test_a_weaker_wrist_shrinks_the_feasible_set_and_shortens_the_dig(arm, reach_table):
    """§7.2.2: 1000 -> 500 N m at the wrist, maximizing volume. The nominal wedge forces of the testbed
    sand never load the wrist past 350 N m on this trench, so the comparison uses Table 1's lean clay."""
    strong = make_planner(arm, reach_table, soil="lean_clay", objective="volume").plan(flat_map(), classify_limits=True)
    weak = make_planner(arm, reach_table, soil="lean_clay", objective="volume",
                        limits=np.array([25000.0, 12000.0, 500.0])).plan(flat_map(), classify_limits=True)
    assert weak.feasible.sum() < strong.feasible.sum()
    # Nearly a subset: d2 is found by a strided scan, which can land on a different drag length
    # when the force bound moves the scan's starting point.
    assert np.sum(weak.feasible & ~strong.feasible) <= 0.02 * weak.feasible.sum()
    ds, dw = strong.action, weak.action
    assert dw[3] < ds[3] or dw[2] * math.sin(dw[1]) < ds[2] * math.sin(ds[1])  # shorter or shallower
    assert (weak.limiting == 2).sum() > (strong.limiting == 2).sum()


def test_objectives_pick_what_they_promise(arm, reach_table, straight_plan):
    planner, lex = straight_plan
    vol = make_planner(arm, reach_table, objective="volume").plan(flat_map())
    peak = make_planner(arm, reach_table, objective="peak_torque").plan(flat_map())
    assert vol.volume_m3 == pytest.approx(np.nanmax(vol.volume))
    useful = vol.feasible & (vol.volume >= 0.1 * CAPACITY)
    assert np.nanmax(np.abs(peak.torques) / LIMITS) == pytest.approx(np.nanmin(vol.peak_torque_ratio[useful]), rel=1e-6)
    assert lex.volume_m3 >= 0.9 * CAPACITY and vol.volume_m3 >= lex.volume_m3


def test_no_dig_when_the_goal_is_out_of_reach(arm, reach_table):
    goal = TrenchGoal(near_x_m=3.6, far_x_m=3.95, depth_m=0.2)
    res = make_planner(arm, reach_table, goal=goal).plan(flat_map())
    assert res.action is None and res.reason
    assert not np.any(res.volume >= 0.1 * CAPACITY)  # at most digs that skim the surface outside the trench


def test_bad_planner_inputs_are_refused(arm, reach_table):
    from excavsim.errors import ConfigError, ExcavsimError

    with pytest.raises(ExcavsimError, match="torque_limits"):
        make_planner(arm, reach_table, limits=np.array([1.0, -2.0, 3.0]))
    from excavsim.config import PlannerConfig, parse_config

    with pytest.raises(ConfigError, match="objective"):
        parse_config({"objective": "fastest"}, PlannerConfig, source="test")
    with pytest.raises(ConfigError, match="far_x_m"):
        parse_config({"near_x_m": 2.0, "far_x_m": 1.5, "depth_m": 0.2}, TrenchGoal, source="test")
