"""Hydraulic cylinders' droop under the arm's weight, fed forward: the excavator's targets raised by it.

An excavator's cylinder servo is a stiff spring on its length (:mod:`excavsim.world.hydraulics`: the force is
``kp (set-point - L)`` with ``kp`` the relief force over ``servo_error_m``, an integrating valve on the
set-point, not on the measured length), so a cylinder that holds a load sits short of its set-point by
``F / kp``: under the arm's own weight the TB035's boom lets the bucket's edge 2-3 cm below where it was sent
(the T3's integrating servos have no such error). The trenching planner keeps the tip path on the goal
profile, so that droop is over-dig. :class:`DroopCompensation` is the executor's servos with the droop the
arm's statics predict added to every target: the joint torque that holds the links against gravity
(:func:`~excavsim.robot.statics.gravity_torques`) over the joint's stiffness ``kp (dL/dq)^2``. Simplified,
stated: the links' weight only (not the soil's force or the load's, which change along a dig), static.
"""

from __future__ import annotations

import numpy as np

from excavsim.handoff.observation import Observation, Servos
from excavsim.robot.excavators import FUNCTIONS
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import Machine
from excavsim.robot.statics import gravity_torques


class DroopCompensation:
    """:class:`~excavsim.handoff.observation.Servos` that send each target plus the gravity droop of its pose.

    Args:
        servos: the world's servos (an :class:`~excavsim.world.hydraulics.ExcavatorWorld`).
        arm: the planar chain (links' masses for the holding torques).
        machine: a machine with hydraulics (the cylinders' stiffness and moment arms).
    """

    def __init__(self, servos: Servos, arm: PlanarArm, machine: Machine):
        spec = machine.hydraulics
        if spec is None:
            raise ValueError(f"machine {machine.name} has no cylinders to droop")
        self.servos = servos
        self.arm = arm
        self.spec = spec
        self._planar = np.asarray(machine.index(machine.planar))
        self._kp = np.array([spec.cylinder(f).force_limits(spec.relief_pa)[1] / spec.servo_error_m
                             for f in FUNCTIONS[1:]])

    @property
    def control_dt(self) -> float:
        return self.servos.control_dt

    @property
    def torque_limit(self) -> np.ndarray:
        return self.servos.torque_limit

    @property
    def time(self) -> float:
        return self.servos.time

    def observe(self) -> Observation:
        return self.servos.observe()

    def droop(self, q: np.ndarray) -> np.ndarray:
        """(3,) how far the planar joints at angles ``q`` (3,) sag below their set-points under the links'
        weight [rad]: the holding torque over ``kp (dL/dq)^2``, joint by joint."""
        q = np.asarray(q, dtype=float)
        m = np.array([float(self.spec.moment_arm(f, q[j])) for j, f in enumerate(FUNCTIONS[1:])])
        return gravity_torques(self.arm, q) / (self._kp * m * m)

    def track(self, target: np.ndarray) -> Observation:
        """One control step towards ``target`` plus its droop (within the joint limits)."""
        return self.servos.track(self._raised(target))

    def place(self, q: np.ndarray) -> None:
        """Set the machine still at joint angles ``q`` with its servos' set-points raised by the droop, so
        that they hold it there (a start pose without a simulated move; the world's ``place``)."""
        self.servos.place(q, self._raised(q))

    def _raised(self, target: np.ndarray) -> np.ndarray:
        """``target`` with its planar joints raised by their droop (within the joint limits) [rad]."""
        t = np.array(target, dtype=float)
        q = t[self._planar]
        t[self._planar] = np.clip(q + self.droop(q), self.arm.lower, self.arm.upper)
        return t
