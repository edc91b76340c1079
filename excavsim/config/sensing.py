"""``configs/sensing.yaml``: the laser scanner and its errors, the elevation map, the F/T sensor's rate."""

from __future__ import annotations

import pathlib

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

MAX_SCANNER_RAYS = 1_000_000  # rays per range image (the default has 40 000)


class ScannerConfig(StrictModel):
    """The laser range scanner (Singh 1995 §7.1.2) and its errors."""

    n_azimuth: int = Field(default=200, ge=4, le=4000, description="rays across the image")
    n_elevation: int = Field(default=200, ge=4, le=4000, description="rays down the image")
    margin_deg: float = Field(default=1.0, ge=0, le=20, description="field of view beyond the box corners [deg]")
    range_noise_m: float = Field(default=0.01, ge=0, le=1, description="std of Gaussian range noise [m]")
    scale_drift_per_scan: float = Field(
        default=0.002, ge=0, le=0.1, description="std of the scale's random-walk step between scans"
    )
    offset_drift_m_per_scan: float = Field(
        default=0.005, ge=0, le=1, description="std of the offset's random-walk step between scans [m]"
    )
    pose_error_deg: float = Field(
        default=0.15, ge=0, le=10, description="std of the mount's fixed misalignment per axis, per episode [deg]"
    )
    drift_memory: float = Field(
        default=0.95, ge=0, le=1, description="fraction of the scale/offset error kept from one scan to the next"
    )
    grazing_dropout_deg: float = Field(
        default=80.0, gt=0, le=90, description="incidence from the surface normal beyond which returns drop out [deg]"
    )
    dropout_probability: float = Field(default=0.002, ge=0, le=1, description="random dropout probability per ray")
    outlier_probability: float = Field(default=0.002, ge=0, le=1, description="probability of a wild range per ray")
    max_range_m: float = Field(default=8.0, gt=0, le=100, description="no return beyond this range [m]")
    target_rays: int = Field(default=3, ge=1, le=15, description="rays per side of the patch aimed at each target")
    # -- the testbed's errors (configs/sensing_testbed.yaml); all off by default, so the default scanner's
    # ranges are those it gave before they existed (a test holds them equal) --------------------------
    beam_divergence_mrad: float = Field(
        default=0.0, ge=0, le=50,
        description="full divergence of the beam (1/e^2) [mrad]; 0 = a line beam, no footprint, no mixed pixels",
    )
    incidence_bias_m: float = Field(
        default=0.0, ge=0, le=0.5, description="range bias k (1/cos(incidence) - 1), long, on oblique surfaces [m]"
    )
    reflectance_bias_m: float = Field(
        default=0.0, ge=-0.5, le=0.5,
        description="range walk k ln(soil_reflectance / reflectance): dark surfaces read long for k > 0 [m]",
    )
    reflectance_image: bool = Field(default=False, description="return a reflectance image with each range image")
    reflectance_noise: float = Field(default=0.0, ge=0, le=1, description="std of the reflectance image's noise")
    soil_reflectance: float = Field(default=0.3, gt=0, le=1, description="mean reflectance of the soil")
    soil_reflectance_texture: float = Field(
        default=0.0, ge=0, le=0.9, description="relative std of the soil's reflectance from cell to cell, per episode"
    )
    wall_reflectance: float = Field(default=0.5, gt=0, le=1, description="reflectance of the box's walls")
    target_reflectance: float = Field(default=0.1, gt=0, le=1, description="reflectance of the (dark) target plates")
    mount_offset_m: float = Field(
        default=0.0, ge=0, le=0.5,
        description="std of the mount's position error per axis, per episode [m] (the targets' fit absorbs it)",
    )

    @property
    def testbed_errors(self) -> bool:
        """True when any of the testbed's error terms (footprint, biases, reflectance, mount offset) is on."""
        return bool(self.beam_divergence_mrad or self.incidence_bias_m or self.reflectance_bias_m
                    or self.reflectance_image or self.mount_offset_m)

    @model_validator(mode="after")
    def _rays(self) -> ScannerConfig:
        rays = self.n_azimuth * self.n_elevation
        if rays > MAX_SCANNER_RAYS:
            raise ValueError(f"n_azimuth x n_elevation = {rays} rays per image; allowed: at most {MAX_SCANNER_RAYS} "
                             "(each ray's hit and noise are held in memory for every scan of a map)")
        return self


class ElevationMapConfig(StrictModel):
    """How scans become an elevation map (§7.1.2)."""

    cell_size_m: float = Field(default=0.05, ge=0.01, le=0.5, description="map cell size [m]")
    n_scans: int = Field(default=10, ge=1, le=100, description="range images median-filtered per map")
    calibrate: bool = Field(default=True, description="fit scale and offset to the surveyed targets every scan")
    calibrate_pose: bool = Field(
        default=False, description="fit the mount's pose error (x, y, rotation) to the targets with the scales"
    )
    level: bool = Field(default=True, description="level the map to the surveyed tops of the box's walls")
    edge_filter_m: float = Field(
        default=0.0, ge=0, le=1,
        description="drop pixels whose range jumps by more than this from a neighbour's (Fig. 96's filtered "
                    "pixels: mixed pixels at edges) [m]; 0 = keep all",
    )


class ForceSensorConfig(StrictModel):
    """The wrist F/T sensor as the robot reads it (§7.1.3)."""

    rate_hz: float = Field(default=10.0, gt=0, le=1000, description="sample rate of F/T readings [Hz]")


class SensingConfig(StrictModel):
    """``configs/sensing.yaml``: scanner, elevation map and F/T sensor."""

    scanner: ScannerConfig = ScannerConfig()
    map: ElevationMapConfig = ElevationMapConfig()
    force_sensor: ForceSensorConfig = ForceSensorConfig()


def load_sensing_config(path: str | pathlib.Path | None = None) -> SensingConfig:
    """Load ``configs/sensing.yaml`` (or ``path``)."""
    return load_config(path or constants.SENSING_YAML, SensingConfig)
