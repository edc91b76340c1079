"""AutoDig (Rowe 1997 §4.4): the 25 t's dig ends on the cylinder pressures, not on a fixed path."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.robot.extract import arm_from_model
from excavsim.tasks.truck_loading.mind.autodig import AutoDigConfig, autodig
from excavsim.tasks.truck_loading.world.truck import TruckWorld
from excavsim.world.hydraulics import EXCAVATOR_JOINTS


@pytest.fixture(scope="module")
def arm25():
    return arm_from_model(TruckWorld("excavator_25t", "dry_sand", seed=0).model, joints=EXCAVATOR_JOINTS)


class _Rig:
    """A machine that goes where it is told at once, with a stick pressure set by how far the drag went."""

    control_dt = 0.02

    def __init__(self, arm, resist_after_m: float, x0: float):
        self.arm, self.q, self.resist, self.x0 = arm, np.array([0.0, 0.4, -1.2, -0.8]), resist_after_m, x0

    def joint_angles(self):
        return self.q.copy()

    def step(self, target):
        self.q = np.asarray(target, float).copy()
        return self.q.copy()

    def cylinder_pressures(self):
        x = float(self.arm.forward(self.q[1:])[0])
        return np.array([5e6, -40e6 if self.x0 - x > self.resist else -5e6, 5e6])


def test_autodig_ends_the_drag_on_the_stick_pressure(arm25):
    """§4.4: the drag ends on resistance (the stick's pressure held high with the tip risen to the surface),
    shortly after the resistance rose; without it, after its length."""
    cfg = AutoDigConfig(depth_m=0.4, drag_m=3.0, full_pa=30e6, full_s=0.3)
    run = autodig(_Rig(arm25, 1.0, 7.5), arm25, 0.0, 7.5, lambda r: 0.0, cfg)
    assert run.drag_end == "stick pressure (full)"
    assert 1.0 < run.drag_m < 1.8  # the filter's lag and the hold time past the 1 m where resistance rose
    easy = autodig(_Rig(arm25, 10.0, 7.5), arm25, 0.0, 7.5, lambda r: 0.0, cfg)
    assert easy.drag_end == "length" and easy.drag_m == pytest.approx(3.0, abs=0.05)
