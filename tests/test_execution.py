"""The parameterized-script executor: the engine's triggers, the dig script, touch-down, stalls."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_executor_config, load_planner_config, load_robot_config, load_trench_goal
from excavsim.execution.dig import DigExecutor
from excavsim.execution.script import (Command, Script, ScriptEngine, Sense, Step, SubScript, after, all_of, always,
                                       event, force_above, joint_above, reached)
from excavsim.handoff.dig import DigPlan
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.rig import bucket_witness
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner
from excavsim.sensing.ft import ForceSensor
from excavsim.world.simulation import Simulation

JOINTS = list(constants.JOINTS)


def sense(t, q=None, force=0.0, events=()):
    q = dict(zip(JOINTS, q if q is not None else np.zeros(6)))
    zeros = dict.fromkeys(JOINTS, 0.0)
    return Sense(t, q, zeros, zeros, np.array([force, 0.0, 0.0]), frozenset(events))


def test_engine_triggers_fire_in_order_on_a_synthetic_stream():
    """Rowe & Stentz's coupling: the waist swings when the shoulder passes an angle; other steps wait
    for time, a force, an event and for a joint to reach its command."""
    boom = SubScript(("shoulder_joint",), (
        Step("dig", always(), Command((0.1,))),
        Step("raise", force_above(100.0), Command((0.6,))),
        Step("hold", all_of(reached("shoulder_joint", 0.01), after(0.5)), Command()),
    ))
    swing = SubScript(("waist_joint",), (
        Step("stay", always(), Command((0.0,))),
        Step("swing", joint_above("shoulder_joint", 0.4), Command((1.0,))),
        Step("back", event("dumped"), Command((0.0,))),
    ))
    engine = ScriptEngine(Script("synthetic", (boom, swing)))
    stream = [  # time, shoulder angle, F/T force, events
        (0.0, 0.0, 0.0, ()), (0.1, 0.1, 50.0, ()), (0.2, 0.1, 150.0, ()), (0.3, 0.3, 0.0, ()),
        (0.4, 0.45, 0.0, ()), (0.5, 0.6, 0.0, ()), (0.8, 0.6, 0.0, ()), (1.1, 0.6, 0.0, ()), (1.2, 0.6, 0.0, ("dumped",)),
    ]
    for t, sh, f, ev in stream:
        q = np.zeros(6)
        q[1] = sh
        engine.tick(sense(t, q, f, ev))
    order = [(tr.time, tr.name) for tr in engine.transitions]
    assert order == [(0.0, "dig"), (0.0, "stay"), (0.2, "raise"), (0.4, "swing"), (0.8, "hold"), (1.2, "back")]
    assert engine.finished
    assert engine.targets == {"shoulder_joint": 0.6, "waist_joint": 0.0}
    assert "when shoulder_joint > 0.4 -> go to 57.3 deg" in engine.script.describe()


def run_dig(sim, arm, cfg, plan):
    """Execute ``plan`` as the loop does: F/T at the tip, the model's park pose, the bucket measured at lift-out."""
    return DigExecutor(sim, arm, cfg, ForceSensor(sim.model), sim.index.park).run(plan, on_phase=bucket_witness(sim))


def flat_map(z=0.5):
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)


def planned_dig(sim, arm, table, emap, soil="testbed_sand"):
    s = get_soil(soil)
    planner = TrenchPlanner(arm, table, sim.torque_limit[1:4], 0.3, 0.0204, load_trench_goal(
        constants.TRENCHES_DIR / "straight.yaml"), load_planner_config(), WedgePredictor(s, 0.3), s.density_kg_m3)
    res = planner.plan(emap)
    assert res.action is not None
    return DigPlan(res.poses, res.phases, 0.0, res.volume_m3)


@pytest.fixture(scope="module")
def flat_run(arm, reach_table):
    sim = Simulation(seed=0)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    rec = run_dig(sim, arm, load_executor_config(), plan)
    return sim, plan, rec


def test_a_planned_dig_in_flat_sand_follows_its_path(flat_run):
    sim, plan, rec = flat_run
    assert rec.completed, (rec.outcome, rec.warnings)
    assert rec.path_error() < 0.03  # the servos track the planned tip path within 3 cm under load
    assert rec.bucket_volume_m3 > 0.8 * plan.volume_m3  # soil actually in the bucket at lift-out
    assert sim.truth.volumes.bucket == pytest.approx(0.0, abs=1e-9)  # dumped
    assert abs(sim.truth.volumes.total - sim.soil.initial_volume) < 1e-12 * sim.soil.initial_volume
    assert set(rec.phase_times) >= {"above entry", "touch-down", "dig", "lift out", "dump", "park"}
    assert len(rec.ft) > 100 and rec.stall is None


@pytest.mark.parametrize("bias", [0.05, -0.05])
def test_touch_down_finds_the_surface_when_the_map_is_biased(arm, reach_table, bias):
    """§7.1.3: the offset between planned and found contact estimates the map's error."""
    sim = Simulation(seed=1)
    plan = planned_dig(sim, arm, reach_table, flat_map(0.5 + bias))
    rec = run_dig(sim, arm, load_executor_config(), plan)
    assert rec.touch_offset_m == pytest.approx(-bias, abs=0.03)
    assert rec.planned_path[0, 1] == pytest.approx(plan.poses[0, 1] + rec.touch_offset_m)  # the dig moved
    assert rec.outcome in ("completed", "stalled")


def stiff_soil_run(arm, reach_table, compliance: str):
    """Planned with the nominal sand; the world's sand is 5x stiffer at 10 cm (cohesion 6.8 kPa adds
    c d N_c w = 408 N to eq. 8's 102 N) and the wrist relief is 500 N m."""
    robot = load_robot_config()
    wrist = robot.joints.wrist_pitch.model_copy(update={"torque_limit_nm": 500.0})
    robot = robot.model_copy(update={"joints": robot.joints.model_copy(update={"wrist_pitch": wrist})})
    stiff = get_soil("testbed_sand").model_copy(update={"cohesion_pa": 6800.0})
    sim = Simulation(robot=robot, soil=stiff, seed=0)  # seed 2's weaker patches let this dig through
    plan = planned_dig(sim, arm, reach_table, flat_map())
    cfg = load_executor_config().model_copy(update={"compliance": compliance})
    return sim, plan, run_dig(sim, arm, cfg, plan)


@pytest.mark.parametrize("mode", ["stiffness", "impedance"])
def test_with_compliance_the_same_dig_completes(arm, reach_table, mode):
    """§5.4 / DiMaio: the path yields (rises) while a joint nears its limit, so the dig finishes."""
    sim, plan, rec = stiff_soil_run(arm, reach_table, mode)
    assert rec.outcome == "completed", (rec.outcome, rec.warnings)
    assert rec.stall is None
    rise = np.asarray(rec.compliance)
    assert 0.01 < rise.max() <= load_executor_config().compliance_max_m
    assert np.all(np.diff(rise) >= 0)  # the path only ever rises
    assert rec.bucket_volume_m3 > 0.005


def test_compliance_leaves_an_easy_dig_alone(arm, reach_table):
    sim = Simulation(seed=0)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    cfg = load_executor_config().model_copy(update={"compliance": "stiffness"})
    rec = run_dig(sim, arm, cfg, plan)
    assert rec.completed and max(rec.compliance) == 0.0  # the wrist stays below 80 % of 1000 N m


def test_in_stiffer_soil_with_a_weak_wrist_the_dig_stalls_and_ends_cleanly(arm, reach_table):
    sim, plan, rec = stiff_soil_run(arm, reach_table, "off")
    assert rec.outcome == "stalled"
    assert rec.stall["joint"] == "wrist_pitch_joint" and abs(rec.stall["torque"]) >= 0.97 * 500
    assert rec.stall["tip"][0] < plan.poses[0, 0]  # somewhere along the dig
    assert abs(sim.truth.volumes.total - sim.soil.initial_volume) < 1e-12 * sim.soil.initial_volume
