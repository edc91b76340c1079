"""The loop adapts to what its digs met: walls, touch-down reach, failures not repeated, the map corrected."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_planner_config, load_trench_goal
from excavsim.handoff.dig import Dig, DigPlan, ExecutionRecord, TrenchAction
from excavsim.handoff.episode import EpisodeObserver
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.scenario import EpisodeSpec, run_spec
from excavsim.planning.constraints import touchdown
from excavsim.planning.experience import DigExperience, failure_kind
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

LIMITS = np.array([25000.0, 12000.0, 1000.0])
WIDTH, CAPACITY = 0.3, 0.0203981


def flat_map(z: float = 0.5) -> ElevationMap:
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)


def planner_for(arm, table, *, goal="small", predictor=None, limits=LIMITS) -> TrenchPlanner:
    soil = get_soil("testbed_sand")
    return TrenchPlanner(arm, table, limits, WIDTH, CAPACITY, load_trench_goal(constants.TRENCHES_DIR / f"{goal}.yaml"),
                         load_planner_config(), predictor or WedgePredictor(soil, WIDTH), soil.density_kg_m3)


class UnderPredictor:
    """A force model that knows nothing of the soil beyond x = 2.0 m (it predicts no force there)."""

    def __init__(self, nominal):
        self.nominal = nominal

    def predict(self, depth, rake, volume, context=None):
        f = self.nominal.predict(depth, rake, volume, context)
        return np.where((context.poses[..., 0] > 2.0)[..., None], 0.0, f)


def stalled(plan) -> ExecutionRecord:
    rec = ExecutionRecord(outcome="stalled", executed_path=list(plan.poses[:5]), lifted_load_n=50.0)
    rec.stall = {"joint": "wrist_pitch_joint", "time": 10.0, "tip": plan.poses[4], "torque": 1000.0}
    return rec


def test_a_drag_into_the_box_wall_is_not_sensible(arm, reach_table):
    """The soil ends at the box's walls (x = 0.55 m near the robot): a drag whose bucket reaches them
    fails the sensible constraint, although the map's clamped edge reads as soil up to the robot."""
    planner = planner_for(arm, reach_table)
    verdict = planner.check_action(flat_map(), TrenchAction(1.6, math.radians(5.0), 0.15, 1.2))
    assert not verdict["sensible"]
    assert planner.check_action(flat_map(), TrenchAction(1.6, math.radians(5.0), 0.15, 0.6))["sensible"]
    surface = planner.surface(flat_map())
    assert surface.x_in == pytest.approx(0.55, abs=0.011) and surface.x_out == pytest.approx(3.55, abs=0.011)


def test_no_planned_dig_leaves_the_box(arm, reach_table):
    planner = planner_for(arm, reach_table, goal="straight")
    plan = planner.plan(flat_map(0.5))
    surface = planner.surface(flat_map(0.5))
    assert plan.action is not None and np.all(surface.in_box(plan.poses))
    pts = arm.bucket_points(plan.poses)[..., 0]
    assert pts.min() >= 0.55 + planner.cfg.wall_clearance_m - 1e-9


def test_touch_down_must_reach_below_the_entry(arm, reach_table):
    """At the bottom of the workspace the arm reaches the entry but cannot search below it (§7.1.3)."""
    planner = planner_for(arm, reach_table)
    pitch = math.radians(45.0)
    z = np.arange(1.0, 0.0, -0.005)
    ok = planner.reach(np.column_stack([np.full(z.size, 2.7), z, np.full(z.size, pitch)]))[0]
    lowest = z[ok].min()  # the lowest reachable pose at x = 2.7 m, 45 deg
    assert not touchdown(np.array([2.7, lowest + 0.01, pitch]), planner.statics, 0.05)
    assert touchdown(np.array([2.7, lowest + 0.06, pitch]), planner.statics, 0.05)


def test_failures_are_told_from_the_record_and_the_weighed_load():
    assert failure_kind(ExecutionRecord(outcome="completed"), 0.010, 0.001) is None
    assert failure_kind(ExecutionRecord(outcome="completed"), 0.0005, 0.001) == "little soil"
    assert failure_kind(ExecutionRecord(outcome="completed"), math.nan, 0.001) == "little soil"
    assert failure_kind(ExecutionRecord(outcome="no contact"), 0.0, 0.001) == "no contact"
    assert failure_kind(ExecutionRecord(outcome="timeout in step 'dig'"), 0.0, 0.001) == "timeout"
    assert failure_kind(ExecutionRecord(outcome="completed", stall={"joint": "elbow_joint"}), 0.01, 0.001) == "stall"
    assert failure_kind(ExecutionRecord(outcome="diverged"), 0.0, 0.001) == "diverged"  # not "little soil"


def test_a_stalled_dig_in_an_under_predicted_region_is_not_chosen_again(arm, reach_table):
    """The predictor sees no force past x = 2.0 m; after the dig it chose there stalled, the planner
    plans around its neighbourhood (and the same action never comes back on the same terrain)."""
    nominal = WedgePredictor(get_soil("testbed_sand"), WIDTH)
    planner = planner_for(arm, reach_table, predictor=UnderPredictor(nominal))
    emap = flat_map()
    first = planner.plan(emap)
    assert first.action is not None and first.action.k > 2.0  # it enters where the model sees no force
    experience = DigExperience()
    surface = planner.surface(emap)
    dig = Dig("planned", first.poses, first.phases, first.volume_m3, first.action, 0.0)
    failure = experience.learn(1, dig, stalled(first), surface, planner.density)
    assert failure.kind == "stall" and failure.action == first.action
    exclude = experience.excluded(planner.grid_k, planner.grid_alpha, planner.grid_d1, surface)
    second = planner.plan(emap, exclude=exclude)
    assert second.counts["excluded"] > 0
    steps = np.abs(np.array(second.action[:3]) - np.array(first.action[:3])) / np.array(
        [planner.cfg.grid.k_step_m, math.radians(planner.cfg.grid.alpha_step_deg), planner.cfg.grid.d1_step_m])
    assert np.max(steps) > 1.0 + 1e-6  # more than one grid cell away along some axis
    # once the terrain along the failed path has changed (4 cm of new soil), the action may come back
    changed = planner.surface(flat_map(0.54))
    assert not experience.excluded(planner.grid_k, planner.grid_alpha, planner.grid_d1, changed).any()


def _empty_skim(planner, emap, edge_z: float, executed_above_m: float = 0.0):
    """A drag at ``edge_z`` from x 1.5 to 0.9 m that weighed nothing, run ``executed_above_m`` above
    its plan; returns the experience that learned it and the belief it gives on ``emap``."""
    surface = planner.surface(emap)
    path = np.column_stack([np.linspace(1.5, 0.9, 30), np.full(30, edge_z), np.full(30, 0.2)])
    dig = Dig("planned", path, np.ones(30, np.int8), 0.003, TrenchAction(1.5, 0.0, 0.02, 0.6), 0.0)
    executed = path + np.array([0.0, executed_above_m, 0.0])
    experience = DigExperience()
    rec = ExecutionRecord(outcome="completed", executed_path=list(executed), lifted_load_n=2.0)
    assert experience.learn(1, dig, rec, surface, planner.density).kind == "little soil"
    return experience, experience.belief(emap, planner.arm, 0.0, WIDTH, surface)


def test_a_dig_that_found_no_soil_clips_the_map_along_its_path(arm, reach_table):
    """The map says 1.5 cm of soil where the bucket, passing at 0.5 m, weighed nothing: later maps are
    clipped to the edge's path there, and only there, until the map rises by more than 3 cm."""
    planner = planner_for(arm, reach_table)
    emap = flat_map(0.515)
    experience, belief = _empty_skim(planner, emap, 0.5)
    xc, yc = emap.centres()
    xx, yy = np.meshgrid(xc, yc)
    on = (np.abs(yy) < 0.1) & (xx > 1.0) & (xx < 1.4)
    assert np.all(belief.heights[on] <= 0.5 + experience.cut_margin_m + 1e-12)
    off = (np.abs(yy) > 0.3) | (xx > 1.6) | (xx < 0.8)
    np.testing.assert_array_equal(belief.heights[off], emap.heights[off])
    risen = flat_map(0.515 + 0.04)
    assert np.array_equal(experience.belief(risen, arm, 0.0, WIDTH, planner.surface(risen)).heights, risen.heights)


def test_a_dig_shifted_up_at_touch_down_bounds_the_map_at_its_planned_edge(arm, reach_table):
    """Touch-down found contact above the map and the executor ran the dig 1 cm above its plan; it
    weighed nothing. The bound follows the planned edge, not the executed one: the same plan would be
    shifted the same way, so the map must not promise the centimetre the bucket never reached."""
    planner = planner_for(arm, reach_table)
    emap = flat_map(0.515)
    experience, belief = _empty_skim(planner, emap, 0.496, executed_above_m=0.01)
    xc, yc = emap.centres()
    xx, yy = np.meshgrid(xc, yc)
    on = (np.abs(yy) < 0.1) & (xx > 1.0) & (xx < 1.4)
    np.testing.assert_allclose(belief.heights[on], 0.496 + experience.cut_margin_m, atol=1e-12)


class Weak(EpisodeObserver):
    """Installs a force model that predicts no soil force at all."""

    class Zero:
        def predict(self, depth, rake, volume, context=None):
            return np.zeros(np.shape(depth) + (2,))

    def started(self, sim, rig, goal_mask, goal_z):
        rig.planner.predictor = self.Zero()


def test_after_a_stall_the_next_dig_is_a_different_one():
    """Lean clay and a 500 N m wrist, planned with no force model: the first dig stalls, and the
    loop does not try it again."""
    spec = EpisodeSpec(goal="small", soil="lean_clay", seed=0, dig_budget=2,
                       robot={"joints": {"wrist_pitch": {"torque_limit_nm": 500.0}}})
    res = run_spec(spec, observer=Weak())
    first, second = res.digs
    assert first.stall_joint == "wrist_pitch_joint" and first.failure == "stall"
    assert first.peak_torque_nm[3] >= 0.97 * 500.0  # the record carries the measured peak
    assert second.action is None or second.action[:3] != first.action[:3]


def test_the_per_dig_table_shows_predicted_and_measured_wrist_peaks():
    from excavsim.handoff.episode import format_episode

    res = run_spec(EpisodeSpec(goal="small", seed=0, dig_budget=1))
    (dig,) = res.digs
    assert np.isfinite(dig.predicted_peak_nm).all() and dig.peak_torque_nm[3] > 0
    assert f"{dig.predicted_peak_nm[2]:.0f}/{dig.peak_torque_nm[3]:.0f}" in format_episode(res)
    assert dig.weighed_m3 == pytest.approx(dig.bucket_m3, abs=0.001)  # the F/T weighs the load to 1 l


def test_touch_down_expects_contact_where_the_bucket_first_meets_the_map(arm, reach_table):
    """On a slope that rises behind the tip the bucket's heel touches first (Fig. 105)."""
    from excavsim.execution.dig import expected_contact_z
    from excavsim.handoff.goal import SurfaceProfile

    x = np.linspace(0.0, 4.0, 401)
    flat = SurfaceProfile(x, np.full_like(x, 0.5))
    slope = SurfaceProfile(x, 0.5 + np.clip(x - 2.0, 0.0, None) * math.tan(math.radians(30.0)))
    poses = np.array([[2.0, 0.5, 0.3], [1.8, 0.45, 0.3]])
    plan = DigPlan(poses, np.zeros(2, np.int8), 0.0, 0.01, surface=flat)
    assert expected_contact_z(plan, arm, math.radians(10.0)) == pytest.approx(0.5)
    on_slope = DigPlan(poses, np.zeros(2, np.int8), 0.0, 0.01, surface=slope)
    assert expected_contact_z(on_slope, arm, math.radians(10.0)) > 0.55
    assert expected_contact_z(DigPlan(poses, np.zeros(2, np.int8), 0.0, 0.01), arm, 0.2) == 0.5


def test_the_torque_margin_learns_from_digs_near_the_limit_only():
    """Measured against predicted peak wrist torque: digs far below the relief limit say nothing of
    the risk; one that came near it, or stalled (counted 25 % beyond the limit), sets the margin."""
    path = np.column_stack([np.linspace(2.4, 2.0, 10), np.full(10, 0.45), np.full(10, 0.5)])
    experience = DigExperience()
    surface = type("Flat", (), {"__call__": lambda self, x: np.full(np.shape(x), 0.5)})()

    def record(peak_nm, outcome="completed"):
        rec = ExecutionRecord(outcome=outcome, executed_path=list(path), lifted_load_n=200.0,
                              times=[1.0, 2.0], torques=[np.zeros(6), np.array([0, 0, 0, peak_nm, 0, 0])],
                              phase_starts={"touch-down": 0.5, "dig": 1.0, "lift out": 2.0},
                              phase_times={"touch-down": 0.5, "dig": 1.0, "lift out": 0.5})
        if outcome == "stalled":
            rec.stall = {"joint": "wrist_pitch_joint", "time": 2.0, "tip": path[-1], "torque": peak_nm}
        return rec

    def dig(predicted_nm):
        return Dig("planned", path, np.ones(10, np.int8), 0.01, TrenchAction(2.4, 0.3, 0.1, 0.3), 0.0,
                   predicted_peak_nm=np.array([1000.0, 500.0, predicted_nm]))

    experience.learn(1, dig(300.0), record(450.0), surface, 2000.0, wrist_limit_nm=1000.0)  # far below
    assert experience.torque_margin() == 1.0
    experience.learn(2, dig(700.0), record(950.0), surface, 2000.0, wrist_limit_nm=1000.0)  # near it
    assert experience.torque_margin() == pytest.approx(950.0 / 700.0)
    experience.learn(3, dig(800.0), record(1000.0, "stalled"), surface, 2000.0, wrist_limit_nm=1000.0)
    ratios = [950.0 / 700.0, 1.25 * 1000.0 / 800.0]
    assert experience.torque_margin() == pytest.approx(np.quantile(ratios, 0.8))


def test_a_torque_margin_that_leaves_no_dig_is_relaxed_not_the_end_of_the_episode(arm, reach_table):
    """A few stalls can raise the learned margin until nothing passes (a 200 N m wrist with margin 2
    here); the planner then plans within the largest of the relaxed margins that leaves a dig."""
    from types import SimpleNamespace

    from excavsim.tasks.trench.digs import PlannedDigs, relaxed_margins

    assert relaxed_margins(1.0) == [1.0]
    assert relaxed_margins(2.0) == [2.0, 1.5, 1.25, 1.0]
    planner = planner_for(arm, reach_table, limits=np.array([25000.0, 12000.0, 200.0]))
    emap = flat_map()
    found = [planner.plan(emap, torque_margin=m) for m in relaxed_margins(2.0)]
    assert found[0].action is None and found[-1].action is not None
    first = next(i for i, p in enumerate(found) if p.action is not None)
    experience = DigExperience()
    experience.torque_ratios = [2.0]
    assert experience.torque_margin() == 2.0
    choice = PlannedDigs(experience).choose(SimpleNamespace(planner=planner), emap)
    assert choice.dig is not None and choice.dig.kind == "planned"
    assert "torque margin 2.00 leaves no dig" in choice.note
    assert f"within {relaxed_margins(2.0)[first]:.2f}" in choice.note
    assert choice.dig.action == found[first].action
