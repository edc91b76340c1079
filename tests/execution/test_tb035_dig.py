"""One planned dig of the TB035 through the trenching loop's pieces: its world (ExcavatorWorld as the
executor's Servos), the rig on its joints (planar chain from its model, its reachability table, its
cylinders' torque limits, the cylinder-pressure reading), the dig script on swing, boom, stick and bucket."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import (ExecutorConfig, PlannerConfig, load_executor_config, load_planner_config, load_trench_goal,
                             parse_config)
from excavsim.tasks.trench.machines import load_machine_config
from excavsim.handoff.dig import DigPlan
from excavsim.handoff.goal import goal_profile
from excavsim.tasks.trench.digs import PlannedDigs
from excavsim.rig.core import bucket_witness, go_home, make_rig, park, scan
from excavsim.loop.scenario import merge
from excavsim.robot.machine import get_machine
from excavsim.world.machines import make_world


@pytest.fixture(scope="module")
def dug():
    machine = get_machine("tb035")
    mc = load_machine_config("tb035")
    ex = parse_config(merge(load_executor_config().model_dump(), mc.executor), ExecutorConfig, source="tb035")
    pl = parse_config(merge(load_planner_config().model_dump(), mc.planner), PlannerConfig, source="tb035")
    goal = load_trench_goal(constants.TRENCHES_DIR / "tb035" / "sand.yaml")
    world = make_world("tb035", seed=0)
    rig = make_rig(world, seed=0, goal=goal, planner_cfg=pl, executor_cfg=ex, machine=machine)
    v0 = world.volumes()
    park(world, rig)
    emap, accuracy = scan(world, rig)
    choice = PlannedDigs(None).choose(rig, emap)
    dig = choice.dig
    go_home(world, rig)
    clearance = float(np.min(dig.poses[:, 1] - goal_profile(goal, dig.poses[:, 0])))
    plan = DigPlan(dig.poses, dig.phases, math.radians(goal.waist_deg), dig.volume_m3,
                   (-max(clearance, 0.0), math.inf if dig.shift_up else 0.0), surface=rig.planner.surface(emap))
    rec = rig.executor.run(plan, on_phase=bucket_witness(world))
    world.settle_soil()
    return world, rig, accuracy, dig, rec, v0, world.volumes()


def test_the_rig_runs_on_the_excavators_joints(dug):
    world, rig, accuracy, *_ = dug
    assert rig.machine.name == "tb035" and rig.executor._names == list(get_machine("tb035").joints)
    np.testing.assert_allclose(rig.arm.links[:, 0], [2.4, 1.4, get_machine("tb035").hydraulics.bucket.pin_to_tip_m],
                               atol=1e-9)
    assert rig.planner.table.spec == get_machine("tb035").table
    assert accuracy.rms_m < 0.02  # the pit's scan, calibrated on the targets around its rim


def test_a_planned_tb035_dig_fills_the_bucket_and_the_volume_account_closes(dug):
    world, rig, _, dig, rec, v0, v1 = dug
    assert dig.kind == "planned" and dig.volume_m3 > 0.9 * rig.capacity  # the planner's limits let it fill
    assert rec.outcome == "completed", rec.warnings
    assert rec.bucket_volume_m3 > 0.9 * rig.capacity
    assert v0.box - v1.box > 0.9 * rig.capacity  # out of the pit ...
    assert v1.spoil == pytest.approx(v0.box - v1.box, abs=1e-9)  # ... into the spoil beside it
    assert abs(v1.total - v0.total) < 1e-9
    assert rec.stall is None and not [w for w in rec.warnings if "did not settle" in w]
    # touch-down found the soil where the map said, within the sand's sink and the cylinder reading's lag
    assert abs(rec.touch_offset_m) < 0.06
