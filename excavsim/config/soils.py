"""``configs/soils.yaml``: the soil presets (Singh 1995 §5.1.1, Table 1)."""

from __future__ import annotations

import math
import pathlib

from pydantic import Field

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config
from excavsim.errors import ConfigError, shorten

class DiMaioParams(StrictModel):
    """Parameters of DiMaio's bucket-ground model (DiMaio 1998 §5.2, eqs. 5.41-5.49).

    The thesis gives numbers only for its identification experiment (§5.5.1, Table 5.3: b_t0 30000,
    b_n0 10000, mu 0.9, epsilon 10000, rho 2000, k 100000, T_rt 0.1 s, T_rn 0.5 s, for a full-size
    excavator); §5.2.5 names what they depend on but gives no values. The presets' values are
    therefore assumed (each preset says so), chosen to give the T3 testbed's bucket forces of the
    order of the wedge model's. The soil density ``rho`` of eq. 5.47 is the preset's
    ``density_kg_m3``.
    """

    viscous_tangential_n_s_m2: float = Field(ge=0, le=1e7, description="b_t0 of eq. 5.43: tangential damping "
                                                                         "per metre of penetration [N s/m^2]")
    viscous_normal_n_s_m2: float = Field(ge=0, le=1e7, description="b_n0 of eq. 5.43 [N s/m^2]")
    viscous_angular_n_s: float = Field(default=0.0, ge=0, le=1e7,
                                       description="b_a0 of eq. 5.42: rotational damping per metre penetrated [N s]")
    stiffness_n_m: float = Field(ge=0, le=1e8, description="k of eq. 5.44, translational soil stiffness [N/m]")
    angular_stiffness_nm_rad: float = Field(default=0.0, ge=0, le=1e8, description="k_alpha of eq. 5.44 [N m/rad]")
    relax_tangential_s: float = Field(gt=0, le=1e3, description="T_rt of eq. 5.46, stiffness-centre lag along "
                                                                "the cutting surface [s]")
    relax_normal_s: float = Field(gt=0, le=1e3, description="T_rn of eq. 5.46, lag normal to it [s]")
    relax_angular_s: float = Field(default=0.5, gt=0, le=1e3, description="lag of the orientation centre alpha_c "
                                                                          "(assumed: eq. 5.46 lags r, z only) [s]")
    shear_strength_pa: float = Field(gt=0, le=1e9, description="S of eq. 5.45: shear when |f_kn| >= S w d_p [Pa]; "
                                                               "1e9 never shears")
    accumulation_n_m3: float = Field(ge=0, le=1e7, description="epsilon of eq. 5.47, drag of the load [N/m^3]")
    friction_coefficient: float = Field(ge=0, le=5, description="mu of eq. 5.49, soil-bucket Coulomb friction [-]")
    cutting_surface_m: float = Field(default=0.3, gt=0, le=5, description="s_bucket, length of the flat cutting "
                                                                          "surface (Fig. 5.27) [m]")


class SoilParams(StrictModel):
    """Mohr-Coulomb soil and soil-tool parameters (Singh 1995 §5.1.1, eq. 2, Table 1).

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
    dimaio: DiMaioParams | None = Field(default=None, description="DiMaio's bucket-ground model (truth.model: dimaio)")

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
        raise ConfigError(f"unknown soil {shorten(repr(name))}; allowed: {', '.join(sorted(soils))}")
    return soils[name]
