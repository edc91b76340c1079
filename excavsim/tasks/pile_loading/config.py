"""``configs/pile_loading.yaml`` and ``configs/campaigns/pile_loading_machines.yaml``: loading from a pile in MuJoCo.

The episode's configuration (:class:`LoadingMujocoConfig`: the world's soil, the pile in its lane, the
scanner, the map, the dig script's speeds) and a campaign of such episodes over machines and seeds
(:class:`LoadingCampaign`). Lengths in m, angles in degrees, speeds per second. Every number is
assumed (Singh 1995 §7.2.1 gives none).
"""

from __future__ import annotations

import pathlib
from typing import Annotated

from pydantic import Field, field_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config
from excavsim.config.soils import get_soil
from excavsim.tasks.pile_loading.config_planar import LOADING_MACHINES

LOADING_MUJOCO_YAML = constants.CONFIGS_DIR / "pile_loading.yaml"
MAX_SEED = 2**32 - 1  # seeds are unsigned 32-bit numbers

JointValue = Annotated[float, Field(gt=0.0, le=100.0)]  # a joint speed or tolerance: > 0


class PileLane(StrictModel):
    """The pile across the lane (models/pile_box: the lane runs from x = 0 to 8.5 m), faces at the soil's repose."""

    height: float = Field(gt=0.0, le=2.2, description="pile height [m]")
    top: float = Field(ge=0.0, le=8.0, description="length of the flat top [m]")
    foot: float = Field(ge=0.5, le=8.0, description="x of the near foot [m]")


class ScannerOverrides(StrictModel):
    """Overrides of ``configs/sensing.yaml``'s scanner for the lane."""

    n_azimuth: int = Field(ge=4, le=4000, description="rays across the image")
    n_elevation: int = Field(ge=4, le=4000, description="rays down the image")
    max_range_m: float = Field(gt=0.0, le=100.0, description="no return beyond this range [m]")


class LoaderScript(StrictModel):
    """The loader's joint-space script: travel, boom, bucket."""

    joint_speed: list[JointValue] = Field(min_length=3, max_length=3,
                                        description="travel [m/s], boom, bucket [rad/s], each > 0")
    tolerance: list[JointValue] = Field(min_length=3, max_length=3,
                                      description="arrival tolerance: travel [m], boom, bucket [rad], each > 0")


class ShovelScript(StrictModel):
    """The shovel's joint-space script: base, boom, stick, bucket."""

    joint_speed: list[JointValue] = Field(min_length=4, max_length=4,
                                        description="base [m/s], boom, stick, bucket [rad/s], each > 0")
    tolerance: list[JointValue] = Field(min_length=4, max_length=4,
                                      description="arrival tolerance: base [m], boom, stick, bucket [rad], each > 0")


class ScriptSpec(StrictModel):
    """The dig script (excavsim.tasks.pile_loading.mind.script): open loop in time, no touch-down."""

    tip_speed: float = Field(gt=0.0, le=5.0, description="the bucket tip's speed along the planned path [m/s]")
    path_step: float = Field(gt=0.001, le=0.5, description="the path's sampling for the inverse kinematics [m]")
    lift_extra: float = Field(ge=0.0, le=3.0, description="lift this much above the planner's lift-out [m]")
    back_off: float = Field(ge=0.0, le=10.0, description="the base backs off this far after the lift-out [m]")
    dump_hold_s: float = Field(gt=0.0, le=30.0, description="time held tipped at the dump [s]")
    loader: LoaderScript
    shovel: ShovelScript


class LoadingMujocoConfig(StrictModel):
    """``configs/pile_loading.yaml``: see the file's comments."""

    soil: str = Field(description="a preset of configs/soils.yaml: the world's soil (and its angle of repose)")
    pile: PileLane
    tolerance_fraction: float = Field(gt=0.0, lt=1.0,
                                      description="the pile counts as removed when the lane holds at most this share")
    max_digs: int = Field(ge=1, le=1000, description="digs of one episode at most")
    section_half_width: float = Field(gt=0.0, le=0.45,
                                      description="the planner's section: the map's median over |y| below this [m]")
    scanner: ScannerOverrides
    n_scans: int = Field(ge=1, le=50, description="range images per map")
    script: ScriptSpec

    @field_validator("soil")
    @classmethod
    def _soil(cls, v: str) -> str:
        get_soil(v)  # a ConfigError naming the presets
        return v


class LoadingCampaign(StrictModel):
    """``configs/campaigns/pile_loading_machines.yaml`` (``excavsim load --campaign``): episodes of each machine over
    seeds, judged together."""

    machines: list[str] = Field(min_length=1, description="the machines run: loader, shovel")
    seeds: list[int] = Field(min_length=1, description="distinct seeds, 0 to 2^32 - 1")
    mujoco_config: str | None = Field(default=None, description="the episodes' configuration "
                                      "(default configs/pile_loading.yaml)")

    @field_validator("machines")
    @classmethod
    def _machines(cls, v: list[str]) -> list[str]:
        bad = [m for m in v if m not in LOADING_MACHINES]
        if bad:
            raise ValueError(f"unknown {bad}; allowed: {', '.join(LOADING_MACHINES)}")
        return v

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, v: list[int]) -> list[int]:
        if any(not 0 <= s <= MAX_SEED for s in v) or len(set(v)) != len(v):
            raise ValueError("allowed: distinct integers from 0 to 2^32 - 1")
        return v


def load_loading_mujoco_config(path: str | pathlib.Path | None = None) -> LoadingMujocoConfig:
    """The MuJoCo loading configuration (default ``configs/pile_loading.yaml``), validated."""
    return load_config(LOADING_MUJOCO_YAML if path is None else path, LoadingMujocoConfig)


def load_loading_campaign(path: str | pathlib.Path) -> LoadingCampaign:
    """A loading campaign file, validated (machine names, seeds)."""
    return load_config(path, LoadingCampaign)
