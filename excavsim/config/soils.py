"""``configs/soils.yaml``: the soil presets (000_a3ca905d8c6d92bf.txt §5.1.1, Table 1)."""

from __future__ import annotations

import math
import pathlib

from pydantic import Field

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config
from excavsim.errors import ConfigError, shorten

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
