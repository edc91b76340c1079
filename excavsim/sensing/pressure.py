"""The soil's force on an excavator's bucket from its cylinder pressures (a static balance of the arm).

DiMaio 1998 §4.2 plays back on the TB035 with the bucket's interaction force as an input of the
impedance (eq. 4.38); the real machine's force came from its cylinder pressures (the instrumented
TB035 of Fig. 4.13 had pressure transducers on each cylinder; Tafazoli 1997, cited there as [52]).
The excavator models carry one force sensor per cylinder (``actuatorfrc``: what the two chambers'
pressures give) and a force/torque sensor at the bucket pin. The pin sensor alone does not see the
environment's wrench on a backhoe's bucket: the bucket linkage's link carries a second load path into
the bucket (measured on ``models/tb035``: holding still with no soil, the pin reads 36 kN while the bucket
weighs 0.8 kN), so :class:`CylinderForceEstimate` reads the cylinders instead.

The balance is Singh 1995 §5.3's eq. 28 solved for the wrench: the actuators' joint torques are each
cylinder force times its moment arm ``dL/dq`` (virtual work through the pin triangle or the bucket's
four-bar, :mod:`excavsim.robot.cylinders`), and at rest ``tau_act = tau_grav - J^T F``, so

    J^T F = tau_grav(q) - tau_act

is solved for the planar wrench ``F = (F_x, F_z, M)`` at the bucket tip (``J`` the 3 x 3 planar Jacobian
with the pitch row, :meth:`~excavsim.robot.kinematics.PlanarArm.jacobian`). Simplified, stated: a static
balance (the links' and the servos' inertial and damping forces are read as soil force while the arm
accelerates, as the T3's wrist sensor reads the bucket's), the rocker's and link's weight is counted on the
stick (where :func:`~excavsim.robot.extract.arm_from_model` puts it), and the cylinders' friction is not
modelled. It is singular where ``J`` is (the stretched arm), so the solve is least squares.

:class:`CylinderForceReading` is the same balance for the trenching loop's dig executor: it reads the joint
torques an :class:`~excavsim.world.hydraulics.ExcavatorWorld` observation carries (cylinder force x moment
arm, already), at the F/T sensor's rate, and writes the whole :class:`~excavsim.sensing.ft.FTReading` the
executor reads (the force in the tip frame for touch-down and emptying, in the world for weighing).
"""

from __future__ import annotations

import math

import numpy as np

from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.observation import Observation
from excavsim.robot.excavators import FUNCTIONS, ExcavatorSpec
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import Machine
from excavsim.robot.statics import gravity_torques
from excavsim.sensing.ft import FTReading


class CylinderForceEstimate:
    """The environment's force on the bucket from the cylinder forces and the joint angles.

    It offers the part of :class:`~excavsim.sensing.ft.ForceSensor`'s interface the playback reads
    (:meth:`reading_into`), so that :func:`~excavsim.execution.demonstration.plane_state` takes it.

    Args:
        spec: the machine's numbers (the cylinders' moment arms).
        arm: its planar chain read from the model (masses, Jacobian).

    Observation layout: ``q``, ``actuator_force`` in the machine's function order (swing, boom, stick,
    bucket) in their first four entries; ``actuator_force[1:4]`` are cylinder forces [N], positive pushing.
    """

    def __init__(self, spec: ExcavatorSpec, arm: PlanarArm):
        self.spec, self.arm = spec, arm

    def joint_torques(self, q: np.ndarray, cylinder_forces: np.ndarray) -> np.ndarray:
        """(3,) boom, stick and bucket joint torques [N m] that the cylinder forces (3,) [N] give at ``q`` (3,)."""
        arms = np.array([float(self.spec.moment_arm(f, q[j])) for j, f in enumerate(FUNCTIONS[1:])])
        return np.asarray(cylinder_forces, dtype=float) * arms

    def wrench(self, q: np.ndarray, cylinder_forces: np.ndarray) -> np.ndarray:
        """(3,) the planar wrench (F_x radial, F_z up [N], M [N m]) of the soil on the bucket at its tip."""
        q = np.asarray(q, dtype=float)
        rhs = gravity_torques(self.arm, q) - self.joint_torques(q, cylinder_forces)
        jac = self.arm.jacobian(q)  # (3, 3): rows x, z, pitch; J^T F = tau
        return np.linalg.lstsq(jac.T, rhs, rcond=1e-9)[0]

    def reading_into(self, obs: Observation, out: np.ndarray) -> np.ndarray:
        """The estimate written as a :class:`~excavsim.sensing.ft.ForceSensor` reading into ``out`` (4, 3):
        rows force_tip, torque_tip (not estimated: zero), force_world [N] and torque_world (about the arm
        plane's normal) [N m].

        Raises:
            ExcavsimError: the observation's angles or forces are missing or not finite.
        """
        q = np.asarray(obs.q, dtype=float)
        f = np.asarray(obs.actuator_force, dtype=float)
        if q.shape[0] < 4 or f.shape[0] < 4 or not (np.all(np.isfinite(q[:4])) and np.all(np.isfinite(f[:4]))):
            raise UsageError(f"CylinderForceEstimate needs finite joint angles and cylinder forces (swing, boom, "
                             f"stick, bucket first); given q {q!r}, forces {f!r}")
        fx, fz, m = self.wrench(q[1:4], f[1:4])
        phi = self.arm.waist_sign * q[0]
        c, s = np.cos(phi), np.sin(phi)
        out[:] = 0.0
        out[2] = (fx * c, fx * s, fz)
        out[3] = (m * s, -m * c, 0.0)  # about the plane's -y turned by the swing: CCW in (x, z) positive
        return out


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
