"""``configs/dump_trial.yaml``: truck loading by the mass-excavation script, self-tuned online (Rowe 1997 §4.3, §6.2).

The file's numbers as written (angles in degrees, lengths in metres): the dump target, the truck, the
fixed dig, the machine timing model's latency, the cost of §6.2, the learner's settings (§5, §6.2) and
the bounds of what it may change (§5.4.1). ``excavsim.tasks.dump_trial.trial`` turns the validated file into its
run-time configuration in radians.
"""

from __future__ import annotations

import pathlib

from pydantic import Field, field_validator, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

TRUCK_YAML = constants.CONFIGS_DIR / "dump_trial.yaml"


class TruckTarget(StrictModel):
    """The dump target in polar coordinates about the swing axis, the world origin (Rowe 1997 Fig. 11)."""

    r_m: float = Field(gt=0.0, le=10.0, description="radius of the desired pile [m]")
    theta_deg: float = Field(ge=-180.0, le=180.0, description="swing angle of the desired pile [deg]")


class TruckBody(StrictModel):
    """The truck the script's parameters are computed for (Rowe 1997 Fig. 3)."""

    side_z_m: float = Field(ge=0.0, le=5.0, description="height of the truck's side [m, world z]")
    half_width_m: float = Field(gt=0.0, le=5.0, description="the bed's half-width across the swing direction [m]")
    clearance_m: float = Field(ge=0.0, le=2.0, description="the bucket's lowest point above the side [m]")
    dump_z_m: float = Field(ge=0.0, le=5.0, description="tip height at the dump pose [m]")


class TruckCost(StrictModel):
    """The cost of Rowe 1997 §6.2: c = w1 t + w2 ((r_d - r)^2 + r_d^2 (theta_d - theta)^2), theta in radians."""

    w1_per_s: float = Field(ge=0.0, le=1e6, description="weight of the cycle time [1/s]")
    w2_per_m2: float = Field(ge=0.0, le=1e9, description="weight of the placement error [1/m^2]")


class TruckLearning(StrictModel):
    """The learner (Rowe 1997 §5, §6.2): locally weighted regression over the trials, a simplex on its prediction."""

    initial_trials: int = Field(ge=0, le=10_000, description="trials from the computed parameters plus noise")
    initial_noise_deg: float = Field(ge=0.0, le=45.0,
                                     description="size of that noise on the angles [deg]; on the fractions /100")
    widths_log2: list[int] = Field(min_length=2, max_length=2,
                                   description="kernel widths 2^a ... 2^b chosen by leave-one-out: [a, b], a >= b")
    min_support: float = Field(ge=0.0, le=1e3, description="a prediction with less kernel weight is not trusted")
    support_penalty: float = Field(ge=0.0, le=1e9, description="cost added per unit of missing support")
    margin: float = Field(ge=0.0, le=10.0, description="the simplex may leave the data's normalized box this much")
    trust_radius: float = Field(gt=0.0, le=10.0,
                                description="... and the nearest remembered trial this much (normalized)")
    failure_cost: float = Field(ge=0.0, le=1e9, description="added to the cost of a failed trial (§5.4.1)")
    min_dumped_fraction: float = Field(ge=0.0, le=1.0,
                                       description="a trial fails when the bucket dumps less than this share")
    expected_cost: bool = Field(default=False, description="add w2 times the predicted placement variance")
    retarget_trials: int = Field(default=1, ge=0, le=10_000,
                                 description="computed trials after the target moves, before the learner resumes")

    @field_validator("widths_log2")
    @classmethod
    def _widths(cls, v: list[int]) -> list[int]:
        if not -30 <= v[1] <= v[0] <= 30:
            raise ValueError("allowed: [a, b] with 30 >= a >= b >= -30 (the widths 2^a down to 2^b)")
        return v


class TruckRanges(StrictModel):
    """What the learner may change (Rowe 1997 §5.4.1: bounds on the action space)."""

    angles_deg: float = Field(default=25.0, gt=0.0, le=180.0,
                              description="the tuned angles stay this close to the computed ones [deg]")
    stick_fraction: list[float] = Field(default=[0.1, 0.9], min_length=2, max_length=2,
                                        description="the stick goes out at this share of the swing to the truck")
    return_fraction: list[float] = Field(default=[0.3, 1.0], min_length=2, max_length=2,
                                         description="the swing returns when the bucket is this share open")

    @field_validator("stick_fraction", "return_fraction")
    @classmethod
    def _fractions(cls, v: list[float]) -> list[float]:
        if not 0.0 <= v[0] < v[1] <= 1.0:
            raise ValueError("allowed: [low, high] with 0 <= low < high <= 1 (a share of the way)")
        return v


class TruckTuning(StrictModel):
    """An episode of task dump_trial as a self-tuning run (Rowe 1997 §6.2): ``trials`` trials of the script, each in
    a fresh world, the tuner choosing each trial's parameters (the task's dig source)."""

    trials: int = Field(ge=2, le=1000, description="trials of the run (at least twice learning.initial_trials: "
                                                   "a first and a last window)")
    learn: bool = Field(default=True, description="true: tuned by LWR and the simplex after the initial trials; "
                                                  "false: the untuned baseline, every trial from the computed "
                                                  "parameters plus the same small noise")


class TruckFile(StrictModel):
    """``configs/dump_trial.yaml``: see the file for every number and its source."""

    target: TruckTarget
    truck: TruckBody
    dig_swing_deg: float = Field(ge=-180.0, le=180.0, description="swing angle of the dig face [deg]")
    dig_speed_m_s: float = Field(gt=0.0, le=2.0, description="tip speed along the dig path [m/s]")
    dig_path: list[list[float]] = Field(min_length=2, max_length=1000,
                                        description="tip poses [x m, z m, pitch deg] of the fixed dig")
    latency_s: float = Field(ge=0.0, le=10.0, description="the timing model's latency (§4.2) [s]")
    open_pitch_deg: float = Field(ge=-180.0, le=180.0, description="the open bucket's tip pitch (§4.2) [deg]")
    cost: TruckCost
    learning: TruckLearning
    ranges: TruckRanges = Field(default_factory=TruckRanges)
    tuning: TruckTuning | None = Field(default=None, description="an episode of task dump_trial as a self-tuning run "
                                                                 "(default none: one trial, computed parameters)")

    @model_validator(mode="after")
    def _windows(self) -> TruckFile:
        if self.tuning is not None and self.tuning.trials < 2 * self.learning.initial_trials:
            raise ValueError(f"tuning.trials: a tuning run needs at least {2 * self.learning.initial_trials} trials "
                             f"(a first and a last window of learning.initial_trials = "
                             f"{self.learning.initial_trials}); given {self.tuning.trials}")
        return self

    @field_validator("dig_path")
    @classmethod
    def _dig_path(cls, v: list[list[float]]) -> list[list[float]]:
        for i, pose in enumerate(v):
            if len(pose) != 3 or not (0.0 <= pose[0] <= 5.0 and -2.0 <= pose[1] <= 5.0 and -180 <= pose[2] <= 180):
                raise ValueError(f"pose {i} is {pose}; allowed: [x, z, pitch] with x in [0, 5] m, z in [-2, 5] m, "
                                 "pitch in [-180, 180] deg")
        return v


def load_truck_file(path: str | pathlib.Path | None = None) -> TruckFile:
    """``configs/dump_trial.yaml`` (or ``path``), validated."""
    return load_config(TRUCK_YAML if path is None else path, TruckFile)
