"""Checks across configuration files, after each file's schema: a trench goal against the scene it is dug in.

A goal that passes :class:`~excavsim.config.planner.TrenchGoal`'s ranges can still be nonsense in a
given scene: outside the soil box, above the soil, or holding no soil at all (an episode would then
report "done" after no dig, or a removed fraction of NaN). :func:`check_goal` refuses those with a
:class:`~excavsim.errors.ConfigError` naming the field and what is allowed.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import xml.etree.ElementTree as ET

from excavsim import constants
from excavsim.config.planner import TrenchGoal
from excavsim.config.scene import SceneConfig
from excavsim.errors import GoalError, ModelError

MIN_GOAL_SECTION_M2 = 1e-3  # smallest cross-section of soil a goal may hold (10 cm x 1 cm) [m^2]
SURFACE_TOLERANCE_M = 0.01  # a goal's surface_z_m may lie this far above the initial soil [m]
_SECTION_SAMPLES = 401  # points across the goal's opening for its section area [-]


@dataclasses.dataclass(frozen=True)
class SoilBox:
    """The soil box of ``models/soil_box/soil_box.xml`` in world coordinates: its inside and its floor [m]."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    floor_z: float


@functools.lru_cache(maxsize=4)
def soil_box(xml=constants.SOIL_BOX_XML) -> SoilBox:
    """The soil box's inside, read from its MJCF (the body's position and the heightfield's half-sizes):
    the T3's box by default, or the pit of another machine's scene (``models/<machine>/scene.xml``)."""
    root = ET.parse(xml).getroot()
    body = root.find(f".//body[@name='{constants.SOIL_BOX_BODY}']")
    hfield = root.find(f".//hfield[@name='{constants.SOIL_HFIELD}']")
    if body is None or hfield is None:
        raise ModelError(f"{xml}: no body {constants.SOIL_BOX_BODY!r} or hfield "
                         f"{constants.SOIL_HFIELD!r}")
    cx, cy, cz = (float(v) for v in body.get("pos", "0 0 0").split())
    rx, ry = (float(v) for v in hfield.get("size").split()[:2])
    return SoilBox(cx - rx, cx + rx, cy - ry, cy + ry, cz)


def goal_section_m2(goal: TrenchGoal, soil_height_m: float) -> float:
    """Cross-section of the soil a flat fill at ``soil_height_m`` holds above the goal's profile [m^2]."""
    x = [goal.near_x_m + (goal.far_x_m - goal.near_x_m) * i / (_SECTION_SAMPLES - 1) for i in range(_SECTION_SAMPLES)]
    tn, tf = math.tan(math.radians(goal.near_wall_deg)), math.tan(math.radians(goal.far_wall_deg))
    z_ref = goal.surface_z_m
    depth = [max(0.0, soil_height_m - max(z_ref - (xi - goal.near_x_m) * tn, z_ref - (goal.far_x_m - xi) * tf,
                                          z_ref - goal.depth_m)) for xi in x]
    dx = (goal.far_x_m - goal.near_x_m) / (_SECTION_SAMPLES - 1)
    return dx * (sum(depth) - 0.5 * (depth[0] + depth[-1]))


def check_goal(goal: TrenchGoal, scene: SceneConfig, *, source: str = "goal", box: SoilBox | None = None) -> None:
    """Refuse a goal that lies outside the soil box, above or below the initial soil, or holds no soil.

    The goal's opening (``near_x_m`` to ``far_x_m`` along the arm plane at ``waist_deg``, from the
    waist axis at the world origin) must lie inside the box; its ``surface_z_m`` at most
    :data:`SURFACE_TOLERANCE_M` above the initial soil; its bottom above the box floor; and the soil
    above its profile must have a cross-section of at least :data:`MIN_GOAL_SECTION_M2`.

    ``box`` is the soil's box (default the T3's, :func:`soil_box`; another machine's pit is
    ``soil_box(its scene.xml)``, with the scene's ``initial_soil_height_m`` its depth).

    Raises:
        GoalError: (a ConfigError) naming ``source``, the field and what is allowed.
    """
    box = box or soil_box()
    c, s = math.cos(math.radians(goal.waist_deg)), math.sin(math.radians(goal.waist_deg))
    for field in ("near_x_m", "far_x_m"):
        r = getattr(goal, field)
        x, y = r * c, r * s
        if not (box.x_min <= x <= box.x_max and box.y_min <= y <= box.y_max):
            raise GoalError(
                f"{source}: {field}: the trench edge at {r:g} m, waist {goal.waist_deg:g} deg is at world "
                f"({x:.2f}, {y:.2f}) m, outside the soil box (allowed: x in [{box.x_min:g}, {box.x_max:g}] m, "
                f"y in [{box.y_min:g}, {box.y_max:g}] m)")
    h = box.floor_z + scene.initial_soil_height_m
    if goal.surface_z_m > h + SURFACE_TOLERANCE_M:
        raise GoalError(f"{source}: surface_z_m: {goal.surface_z_m:g} m lies above the initial soil at {h:g} m "
                        f"(allowed: at most {h + SURFACE_TOLERANCE_M:g} m, the scene's initial_soil_height_m "
                        f"+ {SURFACE_TOLERANCE_M:g})")
    bottom = goal.surface_z_m - goal.depth_m
    if bottom < box.floor_z:
        raise GoalError(f"{source}: depth_m: the bottom at {bottom:g} m lies below the box floor at "
                        f"{box.floor_z:g} m (allowed: depth_m <= surface_z_m - {box.floor_z:g})")
    area = goal_section_m2(goal, h)
    if area < MIN_GOAL_SECTION_M2:
        raise GoalError(f"{source}: the goal holds {area:.2g} m^2 of soil in section with the initial soil at "
                        f"{h:g} m (allowed: at least {MIN_GOAL_SECTION_M2:g} m^2; is the goal above the soil, "
                        "or the box empty?)")
