"""The T3 arm as numbers: planar kinematics, Jacobian, statics, reachability table, servo commands.

Read from the compiled MuJoCo model once (:func:`~excavsim.robot.extract.arm_from_model`, the only
module here that imports MuJoCo); everything else is numpy, so the planner can use it without MuJoCo.
"""

from excavsim.robot.kinematics import PlanarArm, wrap_angle

__all__ = ["PlanarArm", "wrap_angle"]
