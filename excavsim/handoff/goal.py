"""The trench goal's profile and the mapped surface along the arm plane, as the planner sees them.

A trench goal (:class:`~excavsim.config.TrenchGoal`, 000_a3ca905d8c6d92bf.txt §3.4) is a 2-D
profile in the arm plane at one waist angle: :func:`goal_profile` gives the lowest height the bucket
may cut to at each radial distance. :class:`SurfaceProfile` is the scanned elevation map sampled
along the same plane (the planner's view of the terrain). Both are shared by the planner, the
learned force predictors, the loop's metrics and the recorder.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import numpy as np

from excavsim.config import TrenchGoal
from excavsim.handoff.maps import ElevationMap


class ArmPlane(Protocol):
    """How the arm's plane sits in the world (:class:`~excavsim.robot.kinematics.PlanarArm` is one)."""

    waist_sign: float

    def plane_to_world(self, waist: float, xz: np.ndarray) -> np.ndarray:
        """World points (..., 3) of arm-plane points ``xz`` (..., 2) at waist angle ``waist`` [rad]."""
        ...


def goal_profile(goal: TrenchGoal, x: np.ndarray) -> np.ndarray:
    """Lowest height the bucket may cut to at radial distance ``x`` (the goal's 2-D profile)."""
    x = np.asarray(x, dtype=float)
    z_ref = goal.surface_z_m
    inside = (x >= goal.near_x_m) & (x <= goal.far_x_m)
    near = z_ref - (x - goal.near_x_m) * math.tan(math.radians(goal.near_wall_deg))
    far = z_ref - (goal.far_x_m - x) * math.tan(math.radians(goal.far_wall_deg))
    z = np.maximum(np.maximum(near, far), z_ref - goal.depth_m)
    return np.where(inside, z, z_ref)


@dataclasses.dataclass(frozen=True)
class SurfaceProfile:
    """The mapped surface along the arm plane, averaged across the bucket width."""

    x: np.ndarray
    z: np.ndarray

    @classmethod
    def from_map(cls, emap: ElevationMap, arm: ArmPlane, waist: float, width: float, *,
                 dx: float = 0.01, n_across: int = 5) -> SurfaceProfile:
        """Sample ``emap`` every ``dx`` from 0 to 4 m along the arm plane at ``waist`` [rad], each
        sample the mean of ``n_across`` points spread over the bucket ``width`` [m]."""
        x = np.arange(0.0, 4.0 + dx / 2, dx)
        offsets = (np.arange(n_across) + 0.5) / n_across * width - width / 2
        pts = arm.plane_to_world(waist, np.stack([x, np.zeros_like(x)], axis=-1))  # (n, 3)
        side = np.array([-math.sin(arm.waist_sign * waist), math.cos(arm.waist_sign * waist)])
        xs = pts[:, None, 0] + offsets[None, :] * side[0]
        ys = pts[:, None, 1] + offsets[None, :] * side[1]
        return cls(x, emap.height_at(xs, ys).mean(axis=1))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.interp(x, self.x, self.z)
