"""``configs/scene.yaml``: the scene, the soil in the box, settlement, truth terms, how the bucket holds soil."""

from __future__ import annotations

import pathlib

from typing import Literal

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

class SettleConfig(StrictModel):
    """Settlement of the soil surface (excavsim.world.settle)."""

    tolerance_m: float = Field(default=1e-3, gt=0, le=0.05, description="largest slope excess left [m]")
    max_iterations: int = Field(default=400, ge=1, le=100_000, description="sweep cap per settle")
    interval_s: float = Field(
        default=0.1, gt=0, le=10, description="how often the soil near the bucket is settled while it moves [s]"
    )


class SoilTruthConfig(StrictModel):
    """What the static wedge model misses: truth-only terms of the world's soil (the planner never sees them).

    The planner's nominal model is eq. 8 alone; the world adds these so that predictions are
    approximate, as they were on the real testbed (Singh 1995 §5.1.3).

    ``model`` picks the world's bucket-soil force model: ``wedge`` (the default, eq. 8 with the
    terms below and bearing on the outer surface) or ``dimaio``, the bucket-ground model of
    DiMaio 1998 §5.1-5.2 (viscous friction, lagging stiffness with shear failure, the
    load, Coulomb friction; :mod:`excavsim.world.dimaio`), with the parameters of the soil preset's
    ``dimaio`` block. The rate effect, the failure cycle and heterogeneity act on the wedge only; rocks
    and F/T noise act on both.
    """

    model: Literal["wedge", "dimaio"] = Field(
        default="wedge", description="the world's bucket-soil force model: wedge (eq. 8) or dimaio (DiMaio ch. 5)"
    )

    cohesion_rate_per_decade: float = Field(
        default=0.1, ge=0, le=1,
        description="rate effect: cohesion and adhesion grow by this share per tenfold advance speed above the "
                    "reference (clays ~0.1 per log cycle of strain rate, Kulhawy & Mayne 1990) [-]",
    )
    rate_reference_speed_m_s: float = Field(
        default=0.01, gt=0, le=10, description="advance speed at which the preset's cohesion holds (assumed) [m/s]"
    )
    brittleness_index: float = Field(
        default=0.2, ge=0, lt=1,
        description="share of the failure force lost when the wedge fails along its critical plane, the "
                    "saw-tooth's drop (post-peak softening, Bishop 1967; assumed from Fig. 54) [-]",
    )
    heterogeneity_std: float = Field(
        default=0.15, ge=0, le=2, description="std of the log of a spatially correlated strength factor"
    )
    heterogeneity_length_m: float = Field(default=0.3, gt=0, le=10, description="correlation length of that factor [m]")
    rocks: int = Field(default=0, ge=0, le=200, description="buried rocks (spheres) the cutting edge cannot cut")
    rock_radius_min_m: float = Field(default=0.04, gt=0, le=0.5, description="smallest rock radius [m]")
    rock_radius_max_m: float = Field(default=0.10, gt=0, le=0.5, description="largest rock radius [m]")
    ft_force_noise_n: float = Field(default=5.0, ge=0, le=1e4, description="std of F/T force noise per axis [N]")
    ft_torque_noise_nm: float = Field(default=1.0, ge=0, le=1e4, description="std of F/T torque noise per axis [N m]")
    ft_dig_noise_share: float = Field(
        default=0.0, ge=0, le=5,
        description="std per axis, as a share of the soil's force on the bucket (load included), of a random force "
                    "at the bucket's centre of mass added to the F/T reading while the cutting edge advances into "
                    "soil: the vibration digging excites in the compliant hydraulic arm, read by the sensor "
                    "(Singh 1995 §7.1.3); calibrated to Table 4's shuffled 3-NN error [-]",
    )

    arm_damping_ratio: float | None = Field(
        default=None, gt=0, le=2,
        description="damping ratio of each planar servo (shoulder, elbow, wrist pitch) at the home pose, the others "
                    "locked: a lightly damped hydraulic arm rings on contact and after a move (Singh 1995 §7.1.3, "
                    "Fig. 104; excavsim.world.arm); null keeps robot.yaml's servo damping [-]",
    )
    arm_give_share: float = Field(
        default=0.0, ge=0, le=10,
        description="compliance of each planar joint's transmission as a share of its servo's (k_t = kp / share): "
                    "the joint gives under load by a further share x tau / kp that its encoder does not see "
                    "(Singh 1995 §7.1.3; excavsim.world.arm); 0 is rigid [-]",
    )

    @model_validator(mode="after")
    def _rock_range(self) -> SoilTruthConfig:
        if self.rock_radius_min_m > self.rock_radius_max_m:
            raise ValueError(
                f"rock_radius_min_m={self.rock_radius_min_m} exceeds rock_radius_max_m={self.rock_radius_max_m}"
            )
        return self


class BucketSoilConfig(StrictModel):
    """How the bucket holds, spills and dumps soil, and the contact constants of the soil model."""

    heaped_capacity_factor: float = Field(
        default=1.25, ge=1, le=2, description="heaped capacity / struck capacity (the model's bucket_capacity)"
    )
    spill_start_deg: float = Field(
        default=95.0, ge=0, le=180, description="mouth tilt from vertical at which the load starts to pour out [deg]"
    )
    dump_angle_deg: float = Field(
        default=135.0, ge=0, le=180, description="mouth tilt from vertical at which the bucket is empty [deg]"
    )
    cut_stiffness_n_per_m: float = Field(
        default=1.0e5, gt=0, le=1e8, description="rate at which the cutting force builds with edge travel [N/m]"
    )
    bearing_mobilisation_m: float = Field(
        default=0.06, gt=0, le=0.5, description="penetration at which bearing pressure reaches capacity [m]"
    )
    friction_velocity_m_s: float = Field(
        default=0.02, gt=0, le=1, description="sliding speed below which friction is scaled down (regularization) [m/s]"
    )
    rock_stiffness_n_per_m: float = Field(default=1.0e5, gt=0, le=1e8, description="rock contact stiffness [N/m]")
    load_surcharge: bool = Field(
        default=True,
        description="the bucket's load bears on the failure wedge as surcharge, its share growing with the fill "
                    "(Singh 1995 eq. 7, Fig. 57, §5.1.3); false: only soil heaped ahead of the edge does",
    )
    friction_mass_kg: float = Field(
        default=25.0, gt=0, le=1e4,
        description="lower bound on the bucket's effective mass that keeps the explicit friction stable [kg]",
    )

    @model_validator(mode="after")
    def _angles(self) -> BucketSoilConfig:
        if self.dump_angle_deg <= self.spill_start_deg:
            raise ValueError(
                f"dump_angle_deg={self.dump_angle_deg} must be greater than spill_start_deg={self.spill_start_deg}"
            )
        return self


class SceneConfig(StrictModel):
    """``configs/scene.yaml``: how the scene is composed, and the soil in the box."""

    soil_cell_size_m: float = Field(
        ge=0.005, le=0.25, description="heightfield cell size; must divide the 3 m box evenly [m]"
    )
    soil: str = Field(default="testbed_sand", description="soil preset name from configs/soils.yaml")
    initial_soil_height_m: float = Field(
        default=0.5, ge=0, le=1.0, description="level of the flat soil fill above the box floor [m]"
    )
    settle: SettleConfig = SettleConfig()
    truth: SoilTruthConfig = SoilTruthConfig()
    bucket: BucketSoilConfig = BucketSoilConfig()

    @model_validator(mode="after")
    def _divides_box(self) -> SceneConfig:
        n = 3.0 / self.soil_cell_size_m
        if abs(n - round(n)) > 1e-6:
            raise ValueError(
                f"soil_cell_size_m={self.soil_cell_size_m} does not divide the 3 m box into whole cells; "
                "allowed: 3 / n for a whole number n, e.g. 0.025, 0.05, 0.1"
            )
        return self

    @property
    def soil_grid_samples(self) -> int:
        """Heightfield samples per side (cells + 1)."""
        return int(round(3.0 / self.soil_cell_size_m)) + 1


def load_scene_config(path: str | pathlib.Path | None = None) -> SceneConfig:
    """Load ``configs/scene.yaml`` (or ``path``)."""
    return load_config(path or constants.SCENE_YAML, SceneConfig)
