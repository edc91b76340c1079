"""The T3 arm as numbers: planar kinematics, Jacobian, statics, reachability table, servo commands.

Built from the compiled MuJoCo model once (:meth:`PlanarArm.from_model`); everything else is numpy,
so the planner can use it without MuJoCo.
"""

from excavsim.robot.kinematics import PlanarArm, wrap_angle

__all__ = ["PlanarArm", "wrap_angle"]
