"""``configs/executor.yaml``: the numbers of the trenching dig script (touch-down, paths, dump, stalls, compliance)."""

from __future__ import annotations

import pathlib

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

class ExecutorConfig(StrictModel):
    """``configs/executor.yaml``: numbers of the trenching dig script (execution.dig); the file says
    where each comes from (Singh 1995 §7.1.3, Rowe 1997 §4, or tuned)."""

    approach_height_m: float = Field(default=0.12, gt=0, le=1, description="start of touch-down above the map [m]")
    touch_speed_m_s: float = Field(default=0.05, gt=0, le=1, description="descent speed while seeking contact")
    touch_pitch_deg: float = Field(default=10.0, ge=-30, le=90,
                                   description="bucket pitch during touch-down: nearly flat, the bottom meets the soil")
    touch_pitch_step_deg: float = Field(default=5.0, gt=0, le=45,
                                        description="step of the search for a touch pitch whose descent is reachable")
    touch_reach_checks: int = Field(default=8, ge=2, le=1000,
                                    description="heights along the descent checked for reach in that search")
    touch_force_n: float = Field(default=120.0, gt=0, le=1e4, description="F/T force that signals contact [N]")
    touch_contact_ticks: int = Field(default=3, ge=1, le=1000,
                                     description="consecutive control ticks above touch_force_n that make a contact")
    touch_ignore_s: float = Field(default=0.3, ge=0, le=10,
                                  description="first part of the descent in which the F/T is not read for contact [s]")
    touch_quiet_n: float = Field(
        default=40.0, gt=0, le=1e4,
        description="F/T force under which the arm counts as still before the descent (see touch_quiet_s) [N]")
    touch_quiet_s: float = Field(
        default=0.0, ge=0, le=10,
        description="the descent starts once the F/T force has stayed under touch_quiet_n this long: the arm's "
                    "ringing after the move above the entry has died down (Singh 1995 §7.1.3, Fig. 104); 0: at once [s]")
    joint_give_rad_per_nm: list[float] = Field(
        default=[0.0, 0.0, 0.0], min_length=3, max_length=3,
        description="give of the shoulder, elbow and wrist pitch under load that their encoders miss, per N m of "
                    "actuator torque: the executor takes the links' angles as the encoders' less this times the "
                    "torques, and commands the encoders ahead by as much (calibrated against surveyed tip poses "
                    "under known loads, excavsim.studies.figures.touchdown.calibrate_give); zeros: the encoders "
                    "are the links' [rad/(N m)]")
    touch_sink_m: float = Field(
        default=0.03, ge=0, le=0.5,
        description="how far the edge sinks into the soil before the force registers (calibrated, flat sand) [m]",
    )
    touch_search_m: float = Field(default=0.15, gt=0, le=1, description="how far below the map to keep seeking [m]")
    touch_warn_m: float = Field(default=0.04, gt=0, le=1,
                                description="contact this far from the map is reported (§7.1.3 failure modes) [m]")
    touch_shift_max_m: float = Field(default=0.01, ge=0, le=1,
                                     description="the dig shifts by the touch-down offset, at most this far [m]")
    lead_in_clearance_m: float = Field(default=0.03, ge=0, le=0.5,
                                       description="height above the shifted entry at which the bucket turns to the "
                                                   "entry pitch before going in [m]")
    path_speed_m_s: float = Field(default=0.15, gt=0, le=2, description="tip speed along the planned path")
    pitch_radius_m: float = Field(default=0.5, gt=0, le=5,
                                  description="a turn of the bucket counts as this radius x its angle along a path [m]")
    lift_height_m: float = Field(default=1.1, gt=0, le=6, description="tip height after lift-out [m]")
    spoil_waist_deg: float = Field(default=40.0, ge=-45, le=100, description="waist angle of the spoil area")
    dump_pose: list[float] = Field(default=[1.7, 1.3, 100.0], min_length=3, max_length=3,
                                   description="tip (x m, z m, pitch deg) to dump at")
    empty_force_n: float = Field(default=40.0, gt=0, le=1e4, description="F/T force below which the bucket is empty")
    empty_hold_s: float = Field(default=0.5, gt=0, le=60,
                                description="how long the force must stay below empty_force_n at the dump pose [s]")
    settle_tol_rad: float = Field(default=0.01, gt=0, le=1, description="joint error that counts as reached")
    move_timeout_s: float = Field(default=20.0, gt=0, le=600, description="longest any one move may take")
    dig_timeout_moves: int = Field(default=8, ge=1, le=100,
                                   description="the whole dig stops after this many move_timeout_s")
    episode_wall_limit_s: float = Field(default=1800.0, gt=0, le=7 * 86400,
                                        description="an episode still running after this wall time ends as timeout [s]")
    stall_torque_fraction: float = Field(default=0.97, gt=0, le=1, description="torque/limit that counts as saturated")
    stall_error_rad: float = Field(default=0.02, gt=0, le=1, description="tracking error that counts as lagging")
    stall_time_s: float = Field(default=0.5, gt=0, le=10, description="how long both must last to declare a stall")
    compliance: str = Field(default="off", description="off | stiffness (§5.4) | impedance (DiMaio ch. 3.3.4)")
    compliance_torque_ratio: float = Field(default=0.8, gt=0, le=1,
                                           description="torque/limit of the most loaded joint where the path yields")
    compliance_gain_m_s: float = Field(default=0.5, gt=0, le=10,
                                       description="how fast the path rises per unit of torque ratio above that [m/s]")
    compliance_max_m: float = Field(default=0.15, ge=0, le=1, description="largest rise of the dig path [m]")
    impedance_ref_n_s_per_m: float = Field(default=5000.0, gt=0, le=1e7,
                                           description="soil force/velocity ratio that doubles the yield rate")
    impedance_min_speed_m_s: float = Field(default=0.01, gt=0, le=1,
                                           description="tip speed the force/velocity ratio uses at least [m/s]")

    @model_validator(mode="after")
    def _give(self) -> ExecutorConfig:
        if not all(0.0 <= g <= 1e-3 for g in self.joint_give_rad_per_nm):
            raise ValueError(f"joint_give_rad_per_nm={self.joint_give_rad_per_nm}; allowed: three numbers in "
                             "[0, 1e-3] rad/(N m)")
        return self

    @model_validator(mode="after")
    def _dump_pose(self) -> ExecutorConfig:
        x, z, pitch = self.dump_pose
        if not (0.3 <= x <= 12 and 0 <= z <= 6 and -180 <= pitch <= 180):
            raise ValueError(f"dump_pose={self.dump_pose}; allowed: x in [0.3, 12] m, z in [0, 6] m, "
                             "pitch in [-180, 180] deg (within the arm's reach)")
        return self

    @model_validator(mode="after")
    def _compliance(self) -> ExecutorConfig:
        if self.compliance not in ("off", "stiffness", "impedance"):
            raise ValueError(f"compliance={self.compliance!r}; allowed: off, stiffness, impedance")
        return self


def load_executor_config(path: str | pathlib.Path | None = None) -> ExecutorConfig:
    """Load ``configs/executor.yaml`` (or ``path``)."""
    return load_config(path or constants.EXECUTOR_YAML, ExecutorConfig)
