"""The TB035's cylinders droop under the arm's weight; the executor's servos feed the predicted droop forward."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.execution.droop import DroopCompensation
from excavsim.robot.extract import arm_from_model
from excavsim.robot.machine import T3, get_machine
from excavsim.world.machines import make_world


def _held_tip_error(compensate: bool) -> np.ndarray:
    machine = get_machine("tb035")
    world = make_world("tb035")
    arm = arm_from_model(world.model, joints=machine.chain_joints)
    servos = DroopCompensation(world, arm, machine) if compensate else world
    pose = np.array([2.2, 0.0, math.radians(10.0)])  # the edge at the ground, the arm reaching out
    q, ok = arm.inverse(pose)
    assert ok
    for _ in range(400):  # 8 s: settled
        obs = servos.track(np.r_[0.0, q])
    return arm.forward(obs.q[1:]) - pose


def test_the_droop_fed_forward_holds_the_edge_where_it_was_sent():
    sag = _held_tip_error(False)
    held = _held_tip_error(True)
    assert sag[1] < -0.015  # the boom's cylinder lets the edge 2 cm below the target ...
    assert abs(held[1]) < 0.5 * abs(sag[1]) and abs(held[1]) < 0.01  # ... and less than 1 cm with the droop fed forward


def test_a_machine_without_cylinders_has_no_droop_to_feed():
    with pytest.raises(ValueError, match="no cylinders"):
        DroopCompensation(None, None, T3)
