"""The pit and its lanes: a rectangle in plan that the T3 digs as radial trenches.

A :class:`PitGoal` is a rectangular pit in the soil box: its opening at ``surface_z_m`` between
``near_x_m`` and ``far_x_m`` (world x, away from the arm) and ``y_min_m`` and ``y_max_m``, a flat bottom
``depth_m`` below, and four walls at ``wall_deg`` from horizontal (90: vertical; the soil's angle of
repose, 30 degrees in the testbed sand, leaves them standing after settlement).

The T3 digs in one arm plane at a time (a trenching dig is planar, Singh 1995 §3.4), so the pit is dug
as *lanes*: radial strips one bucket wide, each a :class:`~excavsim.config.TrenchGoal` at its own waist
angle, on which the trench planner plans digs. :func:`pit_lanes` lays them out. The simplifications:

* the lanes fan out from the waist axis, their centres at most a bucket apart along the far wall:
  neighbours overlap towards the arm, and the two corners on the arm's side, outside the fan, are dug
  less;
* the side walls are not dug as slopes (a lane's goal is one depth across the bucket): the outer lanes
  dig to the bottom up to the middle of each side wall, and the vertical face they leave slumps when the
  soil settles, its top back to the opening's edge and its foot out to the bottom's, a wall at the soil's
  angle of repose: the goal's wall when ``wall_deg`` is that angle (30 degrees in the testbed sand);
* the near and far walls are the lanes' end walls, at ``wall_deg`` along each lane (within a few degrees
  of x).

The task measures the pit itself, the rectangle against :func:`pit_surface`, on the map (its done test)
and on the true terrain (its metrics).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config import ConfigError, StrictModel, TrenchGoal

class PitGoal(StrictModel):
    """A rectangular pit in the T3's soil box (see the module docstring); world coordinates [m]."""

    name: str = Field(default="pit", description="label for logs")
    near_x_m: float = Field(default=1.8, gt=0, le=4, description="the opening's edge towards the arm (world x) [m]")
    far_x_m: float = Field(default=2.5, gt=0, le=4, description="the opening's far edge (world x) [m]")
    y_min_m: float = Field(default=-0.45, ge=-2, le=2, description="the opening's right side (world y) [m]")
    y_max_m: float = Field(default=0.45, ge=-2, le=2, description="the opening's left side (world y) [m]")
    surface_z_m: float = Field(default=0.5, ge=0, le=1.4, description="height the depth is measured from [m]")
    depth_m: float = Field(default=0.1, gt=0, le=1, description="depth of the flat bottom [m]")
    wall_deg: float = Field(default=30.0, gt=0, le=90, description="the walls' angle from horizontal [deg] "
                                                                   "(90: vertical)")

    @model_validator(mode="after")
    def _opening(self) -> PitGoal:
        if self.far_x_m <= self.near_x_m or self.y_max_m <= self.y_min_m:
            raise ValueError(f"the opening must have far_x_m > near_x_m and y_max_m > y_min_m; given x "
                             f"{self.near_x_m}..{self.far_x_m}, y {self.y_min_m}..{self.y_max_m}")
        return self

    @property
    def wall_run_m(self) -> float:
        """How far a wall reaches in from the opening's edge to the bottom [m] (0 for vertical walls)."""
        return 0.0 if self.wall_deg >= 90 else self.depth_m / math.tan(math.radians(self.wall_deg))


def bucket_width_m() -> float:
    """The T3's bucket width [m], the ``bucket_width`` numeric of its model (``models/t3/t3.xml``)."""
    numeric = ET.parse(constants.T3_XML).getroot().find(f".//numeric[@name='{constants.BUCKET_WIDTH_NUMERIC}']")
    return float(numeric.get("data"))


def pit_surface(pit: PitGoal, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The pit's goal height at world points ``x``, ``y`` [m]: its bottom and walls inside the opening, the
    surface outside."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    inward = np.minimum.reduce([x - pit.near_x_m, pit.far_x_m - x, y - pit.y_min_m, pit.y_max_m - y])
    below = pit.depth_m if pit.wall_deg >= 90 else np.minimum(pit.depth_m, inward * math.tan(math.radians(pit.wall_deg)))
    return np.where(inward >= 0, pit.surface_z_m - below, pit.surface_z_m)


def pit_lanes(pit: PitGoal, width: float) -> list[TrenchGoal]:
    """The lanes that dig ``pit`` with a bucket ``width`` [m] wide, from the right side (lowest y) on.

    Raises:
        ConfigError: the bucket does not fit between the middles of the pit's side walls.
    """
    run = pit.wall_run_m
    # the lanes' centres at the far wall, the outer lanes' strips reaching the middle of the side walls
    lo, hi = pit.y_min_m + run / 2 + width / 2, pit.y_max_m - run / 2 - width / 2
    if hi < lo:
        raise ConfigError(f"pit {pit.name}: a {width:g} m bucket does not fit between the middles of its side walls "
                          f"(y {pit.y_min_m:g}..{pit.y_max_m:g} m, the walls reaching {run:.2f} m in); allowed: an "
                          f"opening at least {width + run:.2f} m wide, or steeper walls")
    lanes = []
    for i, y in enumerate(np.linspace(lo, hi, 1 + math.ceil((hi - lo) / width - 1e-9))):
        waist = math.atan2(y, pit.far_x_m)
        c, s = math.cos(waist), math.sin(waist)
        # the strip's corners, half a bucket either side of its centre line, stay inside the opening
        near, far = (pit.near_x_m + width / 2 * abs(s)) / c, (pit.far_x_m - width / 2 * abs(s)) / c
        lanes.append(TrenchGoal(name=f"{pit.name} lane {i + 1}", waist_deg=math.degrees(waist), near_x_m=near,
                                far_x_m=far, surface_z_m=pit.surface_z_m, depth_m=pit.depth_m,
                                near_wall_deg=pit.wall_deg, far_wall_deg=pit.wall_deg))
    return lanes
