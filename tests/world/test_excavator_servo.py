"""The excavators' cylinder servos settle: held still in the air, no joint keeps moving (a limit cycle
between the relief forces made the cylinder forces useless as a force reading before the linkage's armature)."""

import numpy as np
import pytest

from excavsim.robot.extract import arm_from_model
from excavsim.world.hydraulics import EXCAVATOR_JOINTS, ExcavatorWorld


@pytest.mark.parametrize("machine,lift_m", [("tb035", 0.6), ("excavator_25t", 1.0)])
def test_held_still_in_the_air_the_servos_settle(machine, lift_m):
    world = ExcavatorWorld(machine, "dry_sand")
    arm = arm_from_model(world.model, joints=EXCAVATOR_JOINTS)
    tip = arm.forward(world.joint_angles()[1:4])
    q_arm, ok = arm.inverse(np.array([tip[0], lift_m, tip[2]]))
    assert ok
    target = np.r_[0.0, q_arm]
    speeds, forces = [], []
    for k in range(250):
        world.step(target)
        if k >= 150:
            speeds.append(np.abs(world.data.qvel[:4]).max())
            forces.append(world.cylinder_forces())
    forces = np.array(forces)
    assert max(speeds) < 0.02  # rad/s; the limit cycle ran at 1.4-4 rad/s
    # the cylinder forces hold the arm's weight steadily: no swing between the relief limits
    assert np.all(forces[:, 1:].std(axis=0) < 0.01 * np.abs(forces[:, 1:]).max() + 50.0)
    assert np.abs(world.joint_angles() - target).max() < 0.02
