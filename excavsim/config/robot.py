"""``configs/robot.yaml``: the T3's hydraulic servos (relief pressure, pump flow, gains) and the control rate."""

from __future__ import annotations

import math
import pathlib

from pydantic import Field

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

class JointServo(StrictModel):
    """One hydraulic joint servo (an ``intvelocity`` actuator in t3.xml).

    The set-point moves at most at ``velocity_limit_deg_s`` (pump flow); the torque
    ``kp (setpoint - q) - kv qdot`` is clipped at ``torque_limit_nm`` (relief pressure).
    """

    # Lower bounds are physical, not only positive: a joint weaker than 10 N m cannot hold the bucket,
    # one slower than 0.1 deg/s or softer than 1 N m/rad never finishes a move.
    torque_limit_nm: float = Field(ge=10, le=1e6, description="relief-pressure torque limit [N m]")
    velocity_limit_deg_s: float = Field(ge=0.1, le=720, description="flow-limited set-point speed [deg/s]")
    kp_nm_per_rad: float = Field(ge=1, le=1e9, description="servo stiffness [N m / rad]")
    kv_nm_s_per_rad: float = Field(ge=0, le=1e9, description="servo damping [N m s / rad]")

    @property
    def velocity_limit_rad_s(self) -> float:
        """Set-point speed limit [rad/s]."""
        return math.radians(self.velocity_limit_deg_s)


class JointServos(StrictModel):
    """The six servos of the T3, by actuator name."""

    waist: JointServo
    shoulder: JointServo
    elbow: JointServo
    wrist_pitch: JointServo
    wrist_yaw: JointServo
    wrist_roll: JointServo

    def by_actuator(self) -> dict[str, JointServo]:
        """Servos keyed by actuator name, in qpos order."""
        return {name: getattr(self, name) for name in constants.ACTUATORS}


class RobotConfig(StrictModel):
    """``configs/robot.yaml``: servo limits and gains of the T3 and the control rate."""

    control_rate_hz: float = Field(gt=0, le=2000, description="rate at which set-point rates are commanded [Hz]")
    setpoint_gain_per_s: float = Field(
        gt=0, le=1000, description="gain from joint error (target - q) to set-point rate, before the flow limit [1/s]"
    )
    joints: JointServos


def load_robot_config(path: str | pathlib.Path | None = None) -> RobotConfig:
    """Load ``configs/robot.yaml`` (or ``path``)."""
    return load_config(path or constants.ROBOT_YAML, RobotConfig)
