"""``configs/pile_loading_planar.yaml``: the 2-D loading simulation of Singh 1995 §7.2.1 (``excavsim load``).

Two machines (Table A1-3's front loader, a front shovel), a pile, its soil, the loading planner's grid
(§3.5, §4.1-4.2) and the Fig. 112 study. Lengths in m, angles in degrees, areas in units of soil
(``units_m2`` each), forces in kN per metre of width. The thesis gives no machine dimensions, no pile
and no soil: the file says which numbers are assumed.
"""

from __future__ import annotations

import pathlib

from pydantic import Field, field_validator, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

LOADING_YAML = constants.CONFIGS_DIR / "pile_loading_planar.yaml"
LOADING_MACHINES = ("loader", "shovel")  # the machines of the file (and of the MuJoCo loading lane)


def _ordered(pair: list[float]) -> list[float]:
    """A ``[low, high]`` range, refused unless its low end is below its high end."""
    if not pair[0] < pair[1]:
        raise ValueError("the low end is not below the high end; allowed: [low, high] with low < high")
    return pair


class LoaderSpec(StrictModel):
    """The front loader: Table A1-3's P-R-R chain (Singh 1995 App. A1-2; see excavsim.robot.loaders)."""

    l1: float = Field(le=0.0, description="minus the shoulder height (the table's a_1 = -l1) [m]")
    l2: float = Field(ge=-20.0, le=20.0, description="prismatic offset: the shoulder stands at x = l2 - d1 [m]")
    l3: float = Field(gt=0.0, le=20.0, description="boom length [m]")
    l4: float = Field(gt=0.0, le=10.0, description="bucket pin to tip [m]")
    mu_deg: float = Field(ge=-90.0, le=90.0, description="the bucket floor's turn from the bucket link [deg]")
    d1_range: list[float] = Field(min_length=2, max_length=2, description="travel's [low, high] [m]")
    theta2_range_deg: list[float] = Field(min_length=2, max_length=2, description="boom's [low, high] [deg]")
    theta3_range_deg: list[float] = Field(min_length=2, max_length=2, description="bucket's [low, high] [deg]")
    wheel_front: float = Field(ge=0.0, le=10.0, description="the wheels' front ahead of the shoulder [m]")
    floor: float = Field(gt=0.0, le=5.0, description="bucket floor behind the tip [m]")
    capacity_units: float = Field(gt=0.0, le=1e5, description="bucket capacity [units of soil]")

    _ranges = field_validator("d1_range", "theta2_range_deg", "theta3_range_deg")(_ordered)


class ShovelSpec(StrictModel):
    """The front shovel: three revolute joints on a base placed between digs (Singh 1995 §4.2)."""

    shoulder_height: float = Field(gt=0.0, le=20.0, description="the boom's pivot above the ground [m]")
    l1: float = Field(gt=0.0, le=20.0, description="boom length [m]")
    l2: float = Field(gt=0.0, le=20.0, description="stick length [m]")
    l3: float = Field(gt=0.0, le=10.0, description="bucket pin to tip [m]")
    mu_deg: float = Field(ge=-90.0, le=90.0, description="the bucket floor's turn from the bucket link [deg]")
    theta1_range_deg: list[float] = Field(min_length=2, max_length=2, description="boom's [low, high] [deg]")
    theta2_range_deg: list[float] = Field(min_length=2, max_length=2, description="stick's [low, high] [deg]")
    theta3_range_deg: list[float] = Field(min_length=2, max_length=2, description="bucket's [low, high] [deg]")
    track_front: float = Field(ge=0.0, le=10.0, description="the tracks' front ahead of the pivot [m]")
    floor: float = Field(gt=0.0, le=5.0, description="bucket floor behind the tip [m]")
    capacity_units: float = Field(gt=0.0, le=1e5, description="bucket capacity [units of soil]")

    _ranges = field_validator("theta1_range_deg", "theta2_range_deg", "theta3_range_deg")(_ordered)


class Machines(StrictModel):
    """Both machines of the 2-D simulation."""

    loader: LoaderSpec
    shovel: ShovelSpec


class PileSpec(StrictModel):
    """The pile of the single simulations (Figs. 108-111): a trapezoid at its angle of repose."""

    height: float = Field(gt=0.0, le=20.0, description="pile height [m]")
    top: float = Field(ge=0.0, le=50.0, description="length of the flat top [m]")
    foot: float = Field(ge=0.0, le=50.0, description="x of the near foot [m]")
    width: float = Field(gt=0.0, le=200.0, description="length of the section [m]")
    dx: float = Field(gt=0.0, le=1.0, description="column width of the section [m]")
    repose_deg: float = Field(gt=0.0, lt=90.0, description="angle of repose of the faces [deg]")


class SoilSpec(StrictModel):
    """The pile's soil for the force constraint (Singh 1995 eq. 8)."""

    unit_weight_kn_m3: float = Field(gt=0.0, le=100.0, description="unit weight [kN/m^3]")
    friction_deg: float = Field(ge=0.0, lt=90.0, description="internal friction angle [deg]")
    cohesion_kpa: float = Field(ge=0.0, le=1e4, description="cohesion [kPa]")


class PlannerSpec(StrictModel):
    """The loading planner's grid and rules (Singh 1995 §3.5, §4.1-4.2)."""

    parameterization: str = Field(pattern="^(k_alpha|k_alpha_r)$", description="k_alpha or k_alpha_r (§3.5)")
    k_max: float = Field(ge=0.0, le=50.0, description="farthest entry behind the pile's foot [m]")
    k_min: float = Field(ge=-10.0, le=0.0, description="nearest entry: this far in front of the foot [m]")
    k_step: float = Field(gt=0.0, le=5.0, description="entry grid step [m]")
    alpha_deg: list[float] = Field(min_length=3, max_length=3,
                                   description="approach angles [first, last, step] [deg]")
    d1_max: float = Field(gt=0.0, le=50.0, description="longest penetration [m]")
    d1_step: float = Field(gt=0.0, le=5.0, description="penetration grid step [m]")
    radii: list[float] = Field(min_length=1, description="the arc's radii tried, each > 0 [m]")
    min_fraction: float = Field(ge=0.0, le=1.0, description="least utility of a dig, as a share of the capacity")
    exit_heading_deg: float = Field(gt=0.0, le=90.0, description="the arc ends moving up at this angle [deg]")
    base_backoffs: list[float] = Field(min_length=1, max_length=20,
                                       description="the shovel's base this far behind its drive limit, each >= 0 [m]")
    max_digs: int = Field(ge=1, le=10_000, description="digs of one run at most")

    @field_validator("alpha_deg")
    @classmethod
    def _alpha(cls, v: list[float]) -> list[float]:
        if not (-90.0 <= v[0] <= v[1] <= 90.0 and v[2] > 0):
            raise ValueError("allowed: [first, last, step] with -90 <= first <= last <= 90 and step > 0 [deg]")
        return v

    @field_validator("radii")
    @classmethod
    def _radii(cls, v: list[float]) -> list[float]:
        if min(v) <= 0:
            raise ValueError("allowed: every radius > 0 [m]")
        return v

    @field_validator("base_backoffs")
    @classmethod
    def _backoffs(cls, v: list[float]) -> list[float]:
        if min(v) < 0:
            raise ValueError("allowed: every back-off >= 0 [m]")
        return v


class StudySpec(StrictModel):
    """The study of Fig. 112: random piles per force limit, both machines with one capacity."""

    runs: int = Field(ge=1, le=1000, description="random piles per force limit")
    remove_units: float = Field(gt=0.0, le=1e6, description="each run digs until this much is removed [units]")
    pile_units: float = Field(gt=0.0, le=1e6, description="each random pile holds this much [units]")
    pile_width: float = Field(gt=0.0, le=500.0, description="length of the random piles' section [m]")
    capacity_units: float = Field(gt=0.0, le=1e5, description="both machines' capacity [units]")
    force_limits_kn_m: list[float] = Field(min_length=1, description="the force limits studied, each > 0 [kN/m]")
    k_step: float = Field(gt=0.0, le=5.0, description="the study's coarser entry step [m]")
    alpha_step_deg: float = Field(gt=0.0, le=90.0, description="the study's coarser approach-angle step [deg]")
    d1_step: float = Field(gt=0.0, le=5.0, description="the study's coarser penetration step [m]")
    max_digs: int = Field(ge=1, le=100_000, description="digs of one run at most")

    @field_validator("force_limits_kn_m")
    @classmethod
    def _limits(cls, v: list[float]) -> list[float]:
        if min(v) <= 0:
            raise ValueError("allowed: every limit > 0 [kN/m]")
        return v

    @model_validator(mode="after")
    def _enough(self) -> StudySpec:
        if self.pile_units < self.remove_units:
            raise ValueError(f"pile_units={self.pile_units} is below remove_units={self.remove_units}; allowed: "
                             "pile_units >= remove_units (a run must be able to remove what it is asked to)")
        return self


class LoadingConfig(StrictModel):
    """``configs/pile_loading_planar.yaml``: the 2-D loading simulation (see the file's comments for each number's source)."""

    units_m2: float = Field(gt=0.0, le=100.0, description="one unit of soil, as an area of the section [m^2]")
    machines: Machines
    pile: PileSpec
    soil: SoilSpec
    planner: PlannerSpec
    fig111_force_limit_kn_m: float = Field(gt=0.0, le=1e5, description="the loader's limit of Fig. 111 [kN/m]")
    study: StudySpec


def load_loading_config(path: str | pathlib.Path | None = None) -> LoadingConfig:
    """The loading configuration (default ``configs/pile_loading_planar.yaml``), validated."""
    return load_config(LOADING_YAML if path is None else path, LoadingConfig)
