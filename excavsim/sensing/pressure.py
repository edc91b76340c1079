"""The soil's wrench on an excavator's bucket from its cylinders' forces: the cylinder-pressure reading.

An excavator has no wrist F/T sensor between the bucket and the soil. The models' ``ft_mount`` sits on the
bucket pin and reads the wrench between stick and bucket, which carries the bucket linkage's push
(tens of kN on the TB035, whatever the soil does), so the T3's reading (:class:`~excavsim.sensing.ft.ForceSensor`:
the sensor's wrench minus the bucket's weight) does not tell the soil's force there. What a hydraulic
excavator measures is its cylinders' pressures, i.e. each function's force and, through the moment
arms, the torque it applies to its joint (the observation's ``actuator_force``). The static balance of
the planar chain (Singh 1995 eq. 28, :func:`~excavsim.robot.statics.static_joint_torques`),
``tau = G(q) - J(q)^T w``, then gives the environment's wrench ``w = (F_x, F_z, M)`` at the bucket tip:
``w = J^-T (G(q) - tau)``.

Simplified, stated: static (the links' inertia and the oil's dynamics read as force while the arm
accelerates, so readings right after a move are not trusted: the executor's ``touch_ignore_s``), the
links' masses and centres of mass as the arm's model of itself holds them (the bucket linkage lumped into
the stick), and the transducers without noise (the world's cylinder forces are exact). Near a singular
``J`` (the stick folded onto the boom) the estimate is not defined; the reading is then NaN.

:class:`CylinderForceReading` has the interface the dig executor uses of
:class:`~excavsim.sensing.ft.ForceSensor` (``rate_hz``, ``reading``, ``reading_into``, ``sample``,
``reset``), so the executor runs on either.
"""

from __future__ import annotations

import math

import numpy as np

from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.observation import Observation
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import Machine
from excavsim.robot.statics import gravity_torques
from excavsim.sensing.ft import FTReading


class CylinderForceReading:
    """The soil's wrench on the bucket about its tip, from the joint torques of the cylinders (see the
    module docstring), at a fixed rate.

    Args:
        arm: the planar chain (its Jacobian and link masses).
        machine: which of the observation's joints are the waist and the planar chain.
        rate_hz: sample rate of :meth:`sample` [Hz].
    """

    def __init__(self, arm: PlanarArm, machine: Machine, *, rate_hz: float = 10.0):
        rate = float(rate_hz)
        if not (math.isfinite(rate) and rate > 0.0):
            raise ConfigError(f"CylinderForceReading rate_hz must be a positive finite number [Hz], got {rate_hz!r}")
        self.arm = arm
        self.rate_hz = rate
        self.period_s = 1.0 / rate
        self._planar = np.asarray(machine.index(machine.planar))
        self._waist = machine.index((machine.waist,))[0]
        self._n = len(machine.joints)
        self.reset()

    def wrench(self, q: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """(3,) the environment's planar wrench ``(F_x, F_z, M)`` on the bucket at its tip [N, N, N m] from the
        planar joint angles ``q`` (3,) and the torques the cylinders apply ``tau`` (3,) [N m]."""
        jac = self.arm.jacobian(np.asarray(q, dtype=float))
        rhs = gravity_torques(self.arm, q) - np.asarray(tau, dtype=float)
        try:
            return np.linalg.solve(jac.T, rhs)
        except np.linalg.LinAlgError:
            return np.full(3, np.nan)

    def reading_into(self, obs: Observation, out: np.ndarray) -> np.ndarray:
        """:meth:`reading`'s four vectors written into ``out`` (4, 3): force_tip, torque_tip, force_world,
        torque_world (the executor's per-step reading)."""
        r = self.reading(obs)
        out[0], out[1], out[2], out[3] = r.force_tip, r.torque_tip, r.force_world, r.torque_world
        return out

    def reading(self, obs: Observation) -> FTReading:
        """The environment's wrench on the bucket about its tip, from one observation (static balance).

        Raises:
            UsageError: the observation's ``q`` or ``actuator_force`` do not list the machine's joints.
        """
        q_all, tau_all = np.asarray(obs.q, dtype=float), np.asarray(obs.actuator_force, dtype=float)
        if q_all.shape != (self._n,) or tau_all.shape != (self._n,):
            raise UsageError(f"the cylinder reading needs q and actuator_force of shape ({self._n},); got "
                             f"{q_all.shape} and {tau_all.shape}")
        q = q_all[self._planar]
        fx, fz, m = self.wrench(q, tau_all[self._planar])
        rho = float(self.arm.forward(q)[2])
        # the tip frame: x along the blade (at pi + rho in the plane), z into the bucket (-sin rho, cos rho),
        # y the plane's -y (robot.statics.tip_force_in_plane)
        x_t = np.array([-math.cos(rho), -math.sin(rho)])
        z_t = np.array([-math.sin(rho), math.cos(rho)])
        f_plane = np.array([fx, fz])
        force_tip = np.array([f_plane @ x_t, 0.0, f_plane @ z_t])
        torque_tip = np.array([0.0, m, 0.0])
        phi = self.arm.waist_sign * float(q_all[self._waist])
        c, s = math.cos(phi), math.sin(phi)
        force_world = np.array([c * fx, s * fx, fz])
        torque_world = m * np.array([s, -c, 0.0])  # about the plane's -y (counter-clockwise in (x, z))
        return FTReading(float(obs.time), force_tip, torque_tip, force_world, torque_world)

    def sample(self, obs: Observation) -> FTReading | None:
        """A reading if ``obs.time`` has reached the next sample time (every ``1 / rate_hz``), else None."""
        t = float(obs.time)
        if self._last is not None and t < self._last + self.period_s - 1e-9:
            return None
        self._last = t
        return self.reading(obs)

    def reset(self) -> None:
        """Forget the sampling schedule: the next :meth:`sample` call samples."""
        self._last: float | None = None
