"""``configs/truck_loading.yaml``: Rowe's truck loading with the 25 t excavator (Rowe 1997 §4, §6).

The numbers as written (angles in degrees, lengths in metres, pressures in MPa): the truck and where it is
parked, AutoDig's thresholds (§4.4), where digs may start, the loading script's "magic numbers" (§4.2),
the swing's profile, the cost of §6.2 and the online tuner (§5, §6.2). Read by
:mod:`excavsim.tasks.truck_loading.task`, which turns it into the world's and the mind's pieces.
"""

from __future__ import annotations

import pathlib

from pydantic import Field, field_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

TRUCK_LOADING_YAML = constants.CONFIGS_DIR / "truck_loading.yaml"


class TruckParked(StrictModel):
    """The dump truck (assumed: a tri-axle on-highway dump truck; Rowe 1997 §6.1 names none)."""

    x_m: float = Field(ge=-20.0, le=20.0, description="the bed's centre, world x [m] (swing axis at the origin)")
    y_m: float = Field(ge=-20.0, le=20.0, description="the bed's centre, world y [m]")
    yaw_deg: float = Field(ge=-180.0, le=180.0, description="the truck's heading from the world x axis [deg]")
    length_m: float = Field(gt=1.0, le=12.0, description="the bed's inside length [m]")
    width_m: float = Field(gt=1.0, le=4.0, description="the bed's inside width [m]")
    floor_m: float = Field(gt=0.2, le=3.0, description="the bed floor's height above the ground [m]")
    side_m: float = Field(gt=0.2, le=3.0, description="the sides' height above the floor [m]")
    payload_t: float = Field(gt=0.0, le=100.0, description="the rated payload [t]")
    full_fraction: float = Field(gt=0.0, le=1.5, description="the truck counts as full at this share of the "
                                                              "rated payload (by the scanned volume)")


class AutoDigFile(StrictModel):
    """AutoDig (Rowe 1997 §4.4): the dig's steps end on angles and cylinder pressures (assumed numbers)."""

    depth_m: float = Field(gt=0.05, le=2.0, description="the cut's depth below the scanned surface [m]")
    drag_m: float = Field(gt=0.2, le=6.0, description="the longest drag [m]")
    penetrate_mpa: float = Field(gt=0.0, le=50.0, description="boom pressure that ends the penetration [MPa]")
    slow_mpa: float = Field(gt=0.0, le=50.0, description="stick pressure above which the drag slows [MPa]")
    rise_mpa: float = Field(gt=0.0, le=50.0, description="stick pressure above which the tip rises [MPa]")
    full_mpa: float = Field(gt=0.0, le=50.0, description="stick pressure that, held, ends the drag [MPa]")
    full_s: float = Field(gt=0.0, le=5.0, description="how long it must be held [s]")
    full_depth_m: float = Field(ge=0.0, le=1.0, description="... with the cut no deeper than this [m]")
    rise_speed_m_s: float = Field(gt=0.0, le=3.0, description="how fast the tip rises out of resistance [m/s]")
    drag_speed_m_s: float = Field(gt=0.0, le=3.0, description="the drag's top speed [m/s]")
    attack_deg: float = Field(ge=-90.0, le=90.0, description="the tip's pitch while digging [deg]")
    capture_deg: float = Field(ge=-120.0, le=30.0, description="the tip's pitch once curled [deg]")


class DigSites(StrictModel):
    """Where digs may start: swing angles and start radii on the pit's map (choose_dig)."""

    swings_deg: list[float] = Field(min_length=1, max_length=20, description="candidate swing angles [deg]")
    radii_m: list[float] = Field(min_length=1, max_length=50, description="candidate start radii [m]")
    floor_z_m: float = Field(ge=-4.0, le=0.0, description="no dig goes below this height [m]")

    @field_validator("radii_m")
    @classmethod
    def _radii(cls, v: list[float]) -> list[float]:
        if not all(4.0 <= r <= 10.0 for r in v):
            raise ValueError("allowed: radii between 4 and 10 m (the 25 t machine's digging reach)")
        return v


class ScriptFile(StrictModel):
    """The loading script's computed parameters' "magic numbers" (Rowe 1997 §4.2; assumed)."""

    clearance_m: float = Field(ge=0.0, le=2.0, description="the bucket's lowest point above the truck's sides [m]")
    pour_pitch_deg: float = Field(ge=0.0, le=120.0, description="the tip's pitch in the middle of the pour [deg]")
    open_pitch_deg: float = Field(ge=0.0, le=140.0, description="the tip's pitch with the bucket open [deg]")
    swing_accel_rad_s2: float = Field(gt=0.0, le=2.0, description="the swing profile's acceleration [rad/s^2]")
    swing_speed_rad_s: float = Field(gt=0.0, le=2.0, description="the swing profile's top speed [rad/s]")
    safety: float = Field(gt=0.0, le=1.0, description="the share of the swing's time the boom gets to clear")


class TuningFile(StrictModel):
    """The online tuner over the passes (Rowe 1997 §5, §6.2): LWR and the downhill simplex."""

    tune: bool = Field(description="tune the script's parameters online (false: computed + noise every pass)")
    trucks: int = Field(default=1, ge=1, le=100, description="trucks loaded in one episode, one after the other "
                                                            "(the learner's memory carried over)")
    initial_passes: int = Field(ge=1, le=100, description="passes from the computed parameters plus noise")
    noise: list[float] = Field(min_length=4, max_length=4, description="noise of swing acceleration [rad/s^2], aim "
                                                                       "dr [m], aim dtheta [deg], return fraction [-]")
    lower: list[float] = Field(min_length=4, max_length=4, description="lowest values, same order and units")
    upper: list[float] = Field(min_length=4, max_length=4, description="highest values, same order and units")
    w1_per_s: float = Field(ge=0.0, le=1e3, description="the cost's weight of the script's time [1/s]")
    w2_per_m2: float = Field(ge=0.0, le=1e5, description="its weight of the squared placement error [1/m^2]")
    failure_cost: float = Field(ge=0.0, le=1e6, description="added for a failed pass (§5.4.1)")
    spill_fail_fraction: float = Field(gt=0.0, le=1.0, description="a pass fails when more of its load misses")


class TruckLoadingFile(StrictModel):
    """``configs/truck_loading.yaml``: see the file for every number and its source."""

    truck: TruckParked
    autodig: AutoDigFile
    dig: DigSites
    script: ScriptFile
    tuning: TuningFile
    pit_scan_cell_m: float = Field(gt=0.05, le=1.0, description="the pit map's cell [m]")
    wall_limit_s: float = Field(gt=0.0, le=1e6, description="the episode's wall-clock limit [s]")


def load_truck_loading_file(path: str | pathlib.Path | None = None) -> TruckLoadingFile:
    """``configs/truck_loading.yaml`` (or ``path``), validated."""
    return load_config(TRUCK_LOADING_YAML if path is None else path, TruckLoadingFile)
