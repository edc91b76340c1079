"""What the robot's sensors report, and the servo interface the executor and the loop drive.

:class:`Observation` is the sensor-level reading of one control step (the world's
:class:`~excavsim.world.simulation.Simulation` produces it); :class:`Servos` is the part of the
world the robot's mind may command and read, so that the executor never imports the world;
:class:`HydraulicServos` adds the cylinders' pressure transducers of a hydraulic machine.
:class:`Diverged` and :class:`OutOfTime` are what :meth:`Servos.track` raises when the world can no
longer be stepped: its physics became unstable, or the episode's wall-clock limit passed.
"""

from __future__ import annotations

import dataclasses
from typing import Protocol

import numpy as np

from excavsim.errors import Diverged, OutOfTime  # their home is excavsim.errors; kept importable here for the loop


@dataclasses.dataclass(frozen=True)
class Observation:
    """What the robot's sensors report after a control step (all arrays in qpos/actuator order).

    ``ft_force``/``ft_torque`` are MuJoCo's force/torque sensors at ``ft_mount`` (the force and
    moment the wrist exerts on the bucket subtree, in the ``ft_mount`` frame) plus Gaussian noise.

    Attributes:
        time: simulated time [s].
        q, qdot: (n,) joint angles [rad] and velocities [rad/s] (the T3's six; an excavator's four:
            swing, boom, stick, bucket).
        actuator_force: (n,) servo torques [N m].
        ft_force, ft_torque: (3,) wrist reading [N, N m].
    """

    time: float
    q: np.ndarray
    qdot: np.ndarray
    actuator_force: np.ndarray
    ft_force: np.ndarray
    ft_torque: np.ndarray


class Servos(Protocol):
    """The robot's hydraulic servos and sensors, as the executor drives them (a Simulation is one, and
    so is an excavator's world).

    Attributes:
        control_dt: the control period [s].
        torque_limit: (n,) relief limits of the joints [N m].
    """

    control_dt: float
    torque_limit: np.ndarray

    @property
    def time(self) -> float:
        """Simulated time now [s] (reading it takes no sensor sample); it never goes back."""
        ...

    def observe(self) -> Observation:
        """The sensor reading now (draws the F/T noise)."""
        ...

    def track(self, target: np.ndarray) -> Observation:
        """One control step driving the joints towards ``target`` (n,) [rad]; the reading after it.

        Raises:
            Diverged: the physics became unstable in this step or an earlier one.
            OutOfTime: the episode's wall-clock limit has passed.
        """
        ...


class HydraulicServos(Servos, Protocol):
    """Servos of a hydraulic machine whose cylinders report their working pressures
    (the pressure sensors of Rowe 1997 §6.1; the 25 t excavator's world beside a truck is one). Besides
    the full observation, the encoders and the pressures read alone: a loop that needs only those
    (AutoDig) skips the rest of :meth:`observe` (on the 25 t, its joint torques through the
    cylinders' moment arms take about a third of a control step's time: measured)."""

    def joint_angles(self) -> np.ndarray:
        """The joint encoders (n,) [rad]."""
        ...

    def step(self, target: np.ndarray) -> np.ndarray:
        """One control step towards joint targets ``target`` (n,) [rad]; the encoders after it (as
        :meth:`track`, without the rest of the observation)."""
        ...

    def cylinder_pressures(self) -> np.ndarray:
        """The boom, stick and bucket cylinders' pressures (3,) [Pa] (positive: pushing)."""
        ...
