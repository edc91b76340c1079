"""The rig's privileged measures of a trench: where it lies on the soil grid, and the true terrain against it.

The world's truth, for metrics and results only (the mind sees the scanned maps): the trenching task
measures its episodes with them, and so do the other drivers of the T3 that dig towards a trench goal
(teleoperation,
:mod:`excavsim.apps.playback.teleop`; the joint-level environments).
"""

from __future__ import annotations

import math

import numpy as np

from excavsim.config import TrenchGoal
from excavsim.handoff.episode import DigMetrics, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.world.simulation import Simulation


def trench_footprint(sim: Simulation, goal: TrenchGoal, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid samples inside the trench's footprint (mask) and the goal profile height at each sample."""
    g = sim.soil.grid
    xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
    w = math.radians(goal.waist_deg)
    radial = xs * math.cos(w) + ys * math.sin(w)
    lateral = -xs * math.sin(w) + ys * math.cos(w)
    mask = (np.abs(lateral) <= width / 2) & (radial >= goal.near_x_m) & (radial <= goal.far_x_m)
    return mask, goal_profile(goal, radial)



def episode_result(sim: Simulation, digs: list[DigMetrics], end: str, reason: str, *, mask: np.ndarray,
                   z_goal: np.ndarray, h0: np.ndarray, v0: float, wall_s: float) -> EpisodeResult:
    """The trench against the goal on the true terrain (privileged), and the episode's totals.

    ``h0`` and the grid's heights are above the soil's floor (``grid.z0``), ``z_goal`` is a world height:
    the comparison adds the floor (0 in the T3's box, the pit's floor below an excavator's ground)."""
    z0 = sim.soil.grid.z0
    h = sim.soil.grid.heights + z0
    h0 = h0 + z0
    cell = sim.soil.grid.cell_area
    removed = float(np.clip(h0 - h, 0, None)[mask].sum() * cell)
    goal_m3 = float(np.clip(h0 - z_goal, 0, None)[mask].sum() * cell)
    over = np.append(np.clip(z_goal - h, 0, None)[mask], 0.0)  # below the goal profile (0 if off the box)
    under = np.append(np.clip(h - z_goal, 0, None)[mask], 0.0)  # soil still above it
    return EpisodeResult(
        digs=digs, end=end, reason=reason, goal_m3=goal_m3, removed_m3=removed, overdig_max_m=float(over.max()),
        overdig_rms_m=float(np.sqrt(np.mean(over[:-1] ** 2))) if over.size > 1 else 0.0,
        underdig_max_m=float(under.max()),
        underdig_rms_m=float(np.sqrt(np.mean(under[:-1] ** 2))) if under.size > 1 else 0.0,
        sim_time_s=sim.time, wall_time_s=wall_s, volume_change_m3=sim.soil.volumes().total - v0)
