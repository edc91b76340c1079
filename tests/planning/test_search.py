"""The exhaustive trenching planner: its search, pruning, objectives and per-dig checks (§6.2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import TrenchGoal, get_soil, load_planner_config, load_trench_goal
from excavsim.handoff.goal import goal_profile
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
    assert (weak.limiting >= 2).sum() > (strong.limiting >= 2).sum()  # 2, 3: the force constraint binds


def test_objectives_pick_what_they_promise(arm, reach_table, straight_plan):
    planner, lex = straight_plan
    vol = make_planner(arm, reach_table, objective="volume").plan(flat_map())
    peak = make_planner(arm, reach_table, objective="peak_torque").plan(flat_map())
    assert vol.volume_m3 == pytest.approx(np.nanmax(vol.volume))
    useful = vol.feasible & (vol.volume >= planner.cfg.min_volume_fraction * CAPACITY)
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


def test_the_trajectory_of_the_chosen_action_is_the_planned_path(straight_plan):
    """Without a radius, ``trajectory`` curls with the smallest reachable radius, as the search does."""
    planner, res = straight_plan
    surface = planner.surface(flat_map())
    poses, phases = planner.trajectory(res.action, surface)
    np.testing.assert_array_equal(poses, res.poses)
    np.testing.assert_array_equal(phases, res.phases)
    assert planner.swept_volume(poses, surface) == pytest.approx(res.volume_m3, rel=1e-9)


class _LimitsWatcher:
    """A force predictor that notes the planner's torque limits each time the search asks it."""

    def __init__(self, inner, planner_ref: list):
        self.inner, self.planner_ref, self.seen = inner, planner_ref, []

    def predict(self, depth, rake, volume, context=None):
        self.seen.append(self.planner_ref[0].limits.copy())
        return self.inner.predict(depth, rake, volume, context)


def test_classifying_the_limits_leaves_the_planner_untouched(arm, reach_table):
    """The force-free search of ``classify_limits`` gets its limits as a parameter: the planner's own
    limits never change, even while the search runs, and the answer is that of the plain search."""
    ref = []
    planner = make_planner(arm, reach_table, soil="lean_clay", objective="volume")
    planner.predictor = watcher = _LimitsWatcher(planner.predictor, ref)
    ref.append(planner)
    limits = planner.limits
    classified = planner.plan(flat_map(), classify_limits=True)
    assert planner.limits is limits and watcher.seen
    assert all(np.array_equal(seen, LIMITS) for seen in watcher.seen)
    plain = planner.plan(flat_map())
    assert classified.action == plain.action
    np.testing.assert_array_equal(classified.feasible, plain.feasible)
    assert (classified.limiting >= 2).any()
    assert np.all(np.isin(classified.limiting[classified.feasible], (0, 3)))
    assert np.all(np.isin(classified.limiting[~classified.feasible], (1, 2)))


def test_the_force_constraint_binds_at_steep_alpha_and_long_d1_in_the_testbed_sand(arm, reach_table):
    """Fig. 87: with the volume constraint off (§7.2.2: the force constraint takes its place), the
    force constraint, not geometry, limits digs of steep approach angles and long penetrations in
    the testbed sand, on a region that grows when the wrist's limit falls from 1000 to 500 N m. The
    force model sees what a full bucket cannot take stay ahead of the blade as surcharge (eq. 7)."""
    s = get_soil("testbed_sand")
    found = {}
    for wrist in (1000.0, 500.0):
        planner = make_planner(arm, reach_table, limits=np.array([25000.0, 12000.0, wrist]), volume_constraint=False)
        planner.predictor = WedgePredictor(s, WIDTH, capacity_m3=planner.cfg.heaped_capacity_factor * CAPACITY)
        res = planner.plan(flat_map(), classify_limits=True)
        found[wrist] = (res, (res.limiting >= 2))
    (_, f1000), (r500, f500) = found[1000.0], found[500.0]
    assert f1000.sum() > 0
    assert f500.sum() > 2 * f1000.sum()
    _, alpha, d1 = np.meshgrid(r500.grid_k, r500.grid_alpha, r500.grid_d1, indexing="ij")
    free = r500.feasible & (r500.limiting == 0)  # feasible cells whose drag geometry ends
    assert alpha[f500].mean() > alpha[free].mean() + math.radians(10)
    assert d1[f500].mean() > d1[free].mean()
    # With the volume constraint on, a bucketful of this sand stays within 500 N m: no force limit.
    on = make_planner(arm, reach_table, limits=np.array([25000.0, 12000.0, 500.0])).plan(flat_map(),
                                                                                        classify_limits=True)
    assert not (on.limiting >= 2).any()


def test_fig87_the_testbed_sand_is_force_limited_at_steep_alpha_or_long_d1_and_more_so_at_500(arm, reach_table):
    """Singh 1995 Fig. 87 (`excavsim plan --soil testbed_sand --wrist-limit 1000 --no-volume-constraint`):
    with the load bearing on the wedge (the world's law, which the nominal predictor believes) a
    significant area of the testbed sand's action space is force-limited at 1000 N m -- steep
    approach angles or long penetrations -- and more of it at 500 N m (measured 50 and 308 cells;
    21 and 161 with the constant 0.3 share before issue 35)."""
    from excavsim.planning.figures import force_limited

    s = get_soil("testbed_sand")
    config = load_planner_config().model_copy(update={"volume_constraint": False})
    counts = {}
    for wrist in (1000.0, 500.0):
        planner = TrenchPlanner(arm, reach_table, np.array([25000.0, 12000.0, wrist]), WIDTH, CAPACITY,
                                load_trench_goal(STRAIGHT), config,
                                WedgePredictor(s, WIDTH, capacity_m3=config.heaped_capacity_factor * CAPACITY),
                                s.density_kg_m3)
        res = planner.plan(flat_map(), classify_limits=True)
        lim = force_limited(res)
        counts[wrist] = int(lim.sum())
        if wrist == 1000.0:
            geometric = res.feasible & ~lim
            alpha = np.broadcast_to(res.grid_alpha[None, :, None], lim.shape)
            d1 = np.broadcast_to(res.grid_d1[None, None, :], lim.shape)
            # the force-limited cells lie at steeper alpha or longer d1 than the geometry-limited ones
            steep = alpha[lim].mean() > alpha[geometric].mean()
            long = d1[lim].mean() > d1[geometric].mean()
            assert steep or long
    assert counts[1000.0] >= 20
    assert counts[500.0] > 2 * counts[1000.0]
