"""YAML configuration, validated on load.

Every configuration is a frozen pydantic model. :func:`load_config` reads a YAML file and returns
the model or raises :class:`~excavsim.errors.ConfigError` whose message names the file, the field,
what was given and what is allowed, one line per problem. Angles are in degrees in the files (the
configuration edge) and in radians in the code.
"""

from __future__ import annotations

import math
import pathlib
import re
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from excavsim import constants
from excavsim.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base for config sections: no unknown fields, no type coercion, no NaN or infinity, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


class JointServo(StrictModel):
    """One hydraulic joint servo (an ``intvelocity`` actuator in t3.xml).

    The set-point moves at most at ``velocity_limit_deg_s`` (pump flow); the torque
    ``kp (setpoint - q) - kv qdot`` is clipped at ``torque_limit_nm`` (relief pressure).
    """

    torque_limit_nm: float = Field(gt=0, le=1e6, description="relief-pressure torque limit [N m]")
    velocity_limit_deg_s: float = Field(gt=0, le=720, description="flow-limited set-point speed [deg/s]")
    kp_nm_per_rad: float = Field(gt=0, le=1e9, description="servo stiffness [N m / rad]")
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
    approximate, as they were on the real testbed (000_a3ca905d8c6d92bf.txt §5.1.3).
    """

    speed_coefficient_s_per_m: float = Field(
        default=2.0, ge=0, le=100, description="cutting force grows as (1 + k v), v the cutting speed (Fig. 63)"
    )
    sawtooth_amplitude: float = Field(
        default=0.2, ge=0, lt=1, description="relative drop of the cutting force when a failure surface shears (Fig. 54)"
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
    load_surcharge_fraction: float = Field(
        default=0.3, ge=0, le=1, description="share of the load's volume that acts as surcharge on the wedge"
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


class ScannerConfig(StrictModel):
    """The laser range scanner (000_a3ca905d8c6d92bf.txt §7.1.2) and its errors."""

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
        default=0.15, ge=0, le=10, description="std of the mount's fixed misalignment about each axis, per episode [deg]"
    )
    drift_memory: float = Field(
        default=0.95, ge=0, le=1, description="fraction of the scale/offset error kept from one scan to the next"
    )
    grazing_dropout_deg: float = Field(
        default=80.0, gt=0, le=90, description="incidence angle (from the surface normal) beyond which returns drop out [deg]"
    )
    dropout_probability: float = Field(default=0.002, ge=0, le=1, description="random dropout probability per ray")
    outlier_probability: float = Field(default=0.002, ge=0, le=1, description="probability of a wild range per ray")
    max_range_m: float = Field(default=8.0, gt=0, le=100, description="no return beyond this range [m]")
    target_rays: int = Field(default=3, ge=1, le=15, description="rays per side of the patch aimed at each target")


class ElevationMapConfig(StrictModel):
    """How scans become an elevation map (§7.1.2)."""

    cell_size_m: float = Field(default=0.05, ge=0.01, le=0.5, description="map cell size [m]")
    n_scans: int = Field(default=10, ge=1, le=100, description="range images median-filtered per map")
    calibrate: bool = Field(default=True, description="fit scale and offset to the surveyed targets every scan")


class ForceSensorConfig(StrictModel):
    """The wrist F/T sensor as the robot reads it (§7.1.3)."""

    rate_hz: float = Field(default=10.0, gt=0, le=1000, description="sample rate of F/T readings [Hz]")


class SensingConfig(StrictModel):
    """``configs/sensing.yaml``: scanner, elevation map and F/T sensor."""

    scanner: ScannerConfig = ScannerConfig()
    map: ElevationMapConfig = ElevationMapConfig()
    force_sensor: ForceSensorConfig = ForceSensorConfig()


class TrenchGoal(StrictModel):
    """``configs/trenches/*.yaml``: a trench to dig, as a 2-D profile in the arm plane (§3.4, Fig. 37).

    The arm plane is set by ``waist_deg``; x is the radial distance from the waist axis. The trench
    opens between ``near_x_m`` (towards the robot) and ``far_x_m`` at ``surface_z_m`` and goes down
    ``depth_m``, with walls at the given angles from horizontal (90 = vertical). Its width is the
    bucket's. Nothing below the profile may be cut; above it everything may.
    """

    name: str = Field(default="", description="label for logs")
    waist_deg: float = Field(default=0.0, ge=-45, le=100, description="waist angle of the arm plane [deg]")
    near_x_m: float = Field(gt=0, le=4, description="radial distance of the trench's near edge [m]")
    far_x_m: float = Field(gt=0, le=4, description="radial distance of the trench's far edge [m]")
    surface_z_m: float = Field(default=0.5, ge=0, le=1.4, description="height the depth is measured from [m]")
    depth_m: float = Field(gt=0, le=1.0, description="depth of the trench bottom [m]")
    near_wall_deg: float = Field(default=60.0, gt=0, le=90, description="near wall angle from horizontal [deg]")
    far_wall_deg: float = Field(default=60.0, gt=0, le=90, description="far wall angle from horizontal [deg]")

    @model_validator(mode="after")
    def _order(self) -> TrenchGoal:
        if self.far_x_m <= self.near_x_m:
            raise ValueError(f"far_x_m={self.far_x_m} must be greater than near_x_m={self.near_x_m}")
        return self


class PlannerGrid(StrictModel):
    """The discretized action space (k, alpha, d1) of the trenching action (§3.4.1, ch. 6)."""

    k_min_m: float = Field(default=1.4, gt=0, le=4)
    k_max_m: float = Field(default=3.3, gt=0, le=4)
    k_step_m: float = Field(default=0.1, gt=0, le=1)
    alpha_min_deg: float = Field(default=0.0, ge=0, le=89)
    alpha_max_deg: float = Field(default=45.0, ge=0, le=89)
    alpha_step_deg: float = Field(default=5.0, gt=0, le=45)
    d1_min_m: float = Field(default=0.02, gt=0, le=1)
    d1_max_m: float = Field(default=0.50, gt=0, le=1.5)
    d1_step_m: float = Field(default=0.01, gt=0, le=0.5)

    @model_validator(mode="after")
    def _ranges(self) -> PlannerGrid:
        for lo, hi in (("k_min_m", "k_max_m"), ("alpha_min_deg", "alpha_max_deg"), ("d1_min_m", "d1_max_m")):
            if getattr(self, lo) > getattr(self, hi):
                raise ValueError(f"{lo}={getattr(self, lo)} exceeds {hi}={getattr(self, hi)}")
        return self


class PlannerConfig(StrictModel):
    """``configs/planner.yaml``: the trenching action's rules, the search grid and the objective."""

    epsilon_deg: float = Field(default=10.0, ge=0, le=45, description="rake = alpha + epsilon while penetrating")
    omega_deg_per_m: float = Field(default=50.0, ge=0, le=500, description="rake decrease per metre of drag")
    zeta_deg: float = Field(default=8.0, ge=-30, le=60, description="smallest rake during the drag, zeta(omega)")
    sample_spacing_m: float = Field(default=0.025, gt=0, le=0.2, description="trajectory sample spacing [m]")
    d2_max_m: float = Field(default=1.2, gt=0, le=3, description="longest drag considered [m]")
    curl_end_pitch_deg: float = Field(default=-30.0, ge=-120, le=60, description="pitch at the end of the curl")
    curl_radii_m: list[float] = Field(default=[0.35, 0.4, 0.5, 0.6, 0.8], min_length=1,
                                      description="curl radii tried, smallest first (§3.4.2.4)")
    curl_samples: int = Field(default=10, ge=2, le=100, description="samples along the curl")
    curl_exit_pitch_deg: float = Field(
        default=0.0, ge=-120, le=60, description="the pitch the bucket must have reached when its edge leaves the soil"
    )
    fill_fraction: float = Field(default=1.0, gt=0, le=2, description="volume limit as a fraction of capacity")
    objective: str = Field(default="lexicographic",
                           description="volume | peak_torque | cumulative_torque | lexicographic (eq. 44)")
    volume_threshold: float = Field(default=0.9, ge=0, le=2,
                                    description="eq. 44: digs must sweep this fraction of capacity")
    min_volume_fraction: float = Field(default=0.1, ge=0, le=1, description="below this: no dig")
    shaping_tolerance_m: float = Field(default=0.005, ge=0, le=0.1)
    fallback_clearance_m: float = Field(default=0.01, ge=0, le=0.2,
                                        description="boundary-following digs stay this far above the goal [m]")
    fallback_bottom_step_m: float = Field(default=0.1, gt=0, le=1, description="spacing of bottom fallback digs [m]")
    fallback_min_volume_fraction: float = Field(default=0.02, ge=0, le=1,
                                                description="a boundary dig must sweep this fraction of capacity")
    surface_tolerance_m: float = Field(default=0.01, ge=0, le=0.2)
    payload_com_tip_m: list[float] = Field(default=[-0.2, 0.12], min_length=2, max_length=2,
                                           description="centre of the load in the tip frame (x, z) [m]")
    grid: PlannerGrid = PlannerGrid()

    @model_validator(mode="after")
    def _objective(self) -> PlannerConfig:
        allowed = ("volume", "peak_torque", "cumulative_torque", "lexicographic")
        if self.objective not in allowed:
            raise ValueError(f"objective={self.objective!r}; allowed: {', '.join(allowed)}")
        if sorted(self.curl_radii_m) != list(self.curl_radii_m) or min(self.curl_radii_m) <= 0:
            raise ValueError(f"curl_radii_m={self.curl_radii_m} must be positive and increasing")
        return self


class ExecutorConfig(StrictModel):
    """``configs/executor.yaml``: numbers of the trenching dig script (execution.dig); the file says
    where each comes from (000_a3ca905d8c6d92bf.txt §7.1.3, 001_0de172b0d6b3614b.txt §4, or tuned)."""

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
    touch_sink_m: float = Field(
        default=0.03, ge=0, le=0.5,
        description="how far the edge sinks into the soil before the force registers (calibrated, flat sand) [m]",
    )
    touch_search_m: float = Field(default=0.15, gt=0, le=1, description="how far below the map to keep seeking [m]")
    touch_warn_m: float = Field(default=0.04, gt=0, le=1,
                                description="contact this far from the map is reported (§7.1.3 failure modes) [m]")
    lead_in_clearance_m: float = Field(default=0.03, ge=0, le=0.5,
                                       description="height above the shifted entry at which the bucket turns to the "
                                                   "entry pitch before going in [m]")
    path_speed_m_s: float = Field(default=0.15, gt=0, le=2, description="tip speed along the planned path")
    pitch_radius_m: float = Field(default=0.5, gt=0, le=5,
                                  description="a turn of the bucket counts as this radius x its angle along a path [m]")
    lift_height_m: float = Field(default=1.1, gt=0, le=2.5, description="tip height after lift-out [m]")
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
    def _compliance(self) -> ExecutorConfig:
        if self.compliance not in ("off", "stiffness", "impedance"):
            raise ValueError(f"compliance={self.compliance!r}; allowed: off, stiffness, impedance")
        return self


class SoilParams(StrictModel):
    """Mohr-Coulomb soil and soil-tool parameters (000_a3ca905d8c6d92bf.txt §5.1.1, eq. 2, Table 1).

    Shear strength is ``tau = c + sigma tan(phi)``; the tool face has friction angle ``delta`` and
    adhesion ``c_a`` (the thesis ignores adhesion; so does eq. 8).
    """

    description: str = Field(default="", description="where the numbers come from")
    density_kg_m3: float = Field(gt=0, le=5000, description="bulk density gamma [kg/m^3]")
    friction_angle_deg: float = Field(ge=0, lt=60, description="angle of internal friction phi [deg]")
    tool_friction_angle_deg: float = Field(ge=0, lt=60, description="soil-tool friction angle delta [deg]")
    cohesion_pa: float = Field(ge=0, le=1e6, description="cohesion c [Pa]")
    adhesion_pa: float = Field(default=0.0, ge=0, le=1e6, description="soil-tool adhesion c_a [Pa]")
    repose_angle_deg: float = Field(gt=0, lt=80, description="angle of repose used by settlement [deg]")

    @property
    def phi(self) -> float:
        """Angle of internal friction [rad]."""
        return math.radians(self.friction_angle_deg)

    @property
    def delta(self) -> float:
        """Soil-tool friction angle [rad]."""
        return math.radians(self.tool_friction_angle_deg)

    @property
    def repose(self) -> float:
        """Angle of repose [rad]."""
        return math.radians(self.repose_angle_deg)


class SoilsFile(StrictModel):
    """``configs/soils.yaml``: named soil presets."""

    soils: dict[str, SoilParams] = Field(min_length=1)


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``5.0e5`` (PyYAML's 1.1 rules read a string)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _describe_error(err: dict[str, Any]) -> str:
    loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
    kind = err["type"]
    given = err.get("input")
    if kind == "missing":
        return f"{loc}: required field is missing"
    if kind == "extra_forbidden":
        return f"{loc}: unknown field (given {given!r}); check the spelling against the documented fields"
    msg = err["msg"]
    ctx = err.get("ctx") or {}
    if kind == "finite_number":
        msg = "must be a finite number"
    elif "gt" in ctx or "ge" in ctx or "lt" in ctx or "le" in ctx:
        lo = f"> {ctx['gt']}" if "gt" in ctx else (f">= {ctx['ge']}" if "ge" in ctx else "")
        hi = f"< {ctx['lt']}" if "lt" in ctx else (f"<= {ctx['le']}" if "le" in ctx else "")
        msg = f"{msg} (allowed: {' and '.join(p for p in (lo, hi) if p)})"
    return f"{loc}: {msg}; given {given!r}"


def parse_config(data: Any, model: type[M], *, source: str) -> M:
    """Validate already-parsed data against a config model.

    Args:
        data: the parsed YAML document.
        model: the pydantic config class.
        source: where the data came from, for messages (a file path).

    Raises:
        ConfigError: naming ``source``, each offending field, the given value and what is allowed.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a mapping of fields, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        lines = [_describe_error(e) for e in exc.errors(include_url=False)]
        raise ConfigError(f"{source}: invalid {model.__name__}:\n  " + "\n  ".join(lines)) from None


def load_config(path: str | pathlib.Path, model: type[M]) -> M:
    """Read and validate a YAML configuration file.

    Args:
        path: the YAML file.
        model: the pydantic config class, e.g. :class:`RobotConfig`.

    Returns:
        The validated, frozen configuration.

    Raises:
        ConfigError: the file is missing, is not YAML, or a field is invalid.
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the {model.__name__} file ({exc.strerror})") from None
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return parse_config(data, model, source=str(path))


def load_robot_config(path: str | pathlib.Path | None = None) -> RobotConfig:
    """Load ``configs/robot.yaml`` (or ``path``)."""
    return load_config(path or constants.ROBOT_YAML, RobotConfig)


def load_scene_config(path: str | pathlib.Path | None = None) -> SceneConfig:
    """Load ``configs/scene.yaml`` (or ``path``)."""
    return load_config(path or constants.SCENE_YAML, SceneConfig)


def load_soils(path: str | pathlib.Path | None = None) -> dict[str, SoilParams]:
    """Load the soil presets of ``configs/soils.yaml`` (or ``path``), keyed by name."""
    return dict(load_config(path or constants.SOILS_YAML, SoilsFile).soils)


def get_soil(name: str, path: str | pathlib.Path | None = None) -> SoilParams:
    """One soil preset by name.

    Raises:
        ConfigError: ``name`` is not a preset; the message lists the ones that are.
    """
    soils = load_soils(path)
    if name not in soils:
        raise ConfigError(f"unknown soil {name!r}; allowed: {', '.join(sorted(soils))}")
    return soils[name]


def load_sensing_config(path: str | pathlib.Path | None = None) -> SensingConfig:
    """Load ``configs/sensing.yaml`` (or ``path``)."""
    return load_config(path or constants.SENSING_YAML, SensingConfig)


def load_planner_config(path: str | pathlib.Path | None = None) -> PlannerConfig:
    """Load ``configs/planner.yaml`` (or ``path``)."""
    return load_config(path or constants.PLANNER_YAML, PlannerConfig)


def load_trench_goal(path: str | pathlib.Path) -> TrenchGoal:
    """Load a trench goal (``configs/trenches/*.yaml``)."""
    return load_config(path, TrenchGoal)


def load_executor_config(path: str | pathlib.Path | None = None) -> ExecutorConfig:
    """Load ``configs/executor.yaml`` (or ``path``)."""
    return load_config(path or constants.EXECUTOR_YAML, ExecutorConfig)
