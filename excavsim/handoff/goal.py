"""The trench goal's profile and the mapped surface along the arm plane, as the planner sees them.

A trench goal (:class:`~excavsim.config.TrenchGoal`, Singh 1995 §3.4) is a 2-D
profile in the arm plane at one waist angle: :func:`goal_profile` gives the lowest height the bucket
may cut to at each radial distance, and :func:`goal_met` is the done test of a goal on a map's heights.
:class:`SurfaceProfile` is the scanned elevation map sampled along the same plane (the planner's view
of the terrain). They are shared by the planner, the learned force predictors, the loop's metrics and
the recorder.
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


def outline_points(poses: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """A tool outline at tip poses in the arm plane: (..., m, 2) [m].

    Args:
        poses: (..., 3) tip poses (x, z, pitch) [m, m, rad].
        outline: (m, 2) points in the tip frame: along the blade from heel to cutting edge, and
            normal to it into the bucket [m]. With pitch ``rho`` those axes are
            ``x_t = (-cos rho, -sin rho)`` and ``z_t = (-sin rho, cos rho)`` in the plane.
    """
    poses = np.asarray(poses, dtype=float)
    a, b = np.asarray(outline, dtype=float).reshape(-1, 2).T
    c, s = np.cos(poses[..., 2])[..., None], np.sin(poses[..., 2])[..., None]
    return np.stack([poses[..., 0, None] - a * c - b * s, poses[..., 1, None] - a * s + b * c], axis=-1)


def goal_met(z: np.ndarray, z_goal: np.ndarray, initial_z: float, *, done_fraction: float,
             tolerance_m: float) -> tuple[bool, float]:
    """Whether surface heights ``z`` meet the goal heights ``z_goal`` at the same sample points (a done test on
    a scanned map), and the fraction of the goal's soil removed there.

    Args:
        z, z_goal: (n,) the surface's and the goal's heights at the samples [m].
        initial_z: the surface's height before digging [m]; the goal's soil is what lies between it and ``z_goal``.
        done_fraction: the fraction of that soil that must be removed.
        tolerance_m: how far any sample may stay above its goal height [m].

    Returns:
        (met, removed fraction): met when at least ``done_fraction`` is removed and no sample is more than
        ``tolerance_m`` above the goal; the fraction is 1 when the goal holds no soil.
    """
    target = np.clip(initial_z - z_goal, 0, None).sum()
    removed = np.clip(initial_z - z, 0, None).clip(max=initial_z - z_goal).sum()
    frac = float(removed / target) if target > 0 else 1.0
    return bool(frac >= done_fraction and np.max(z - z_goal) <= tolerance_m), frac


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
    """The mapped surface along the arm plane, averaged across the bucket width, and where the box ends.

    Attributes:
        x: (n,) radial distances of the samples [m]; z: (n,) mapped surface height there [m].
        x_in, x_out: the radial interval along the arm plane in which the whole bucket width lies
            inside the mapped area, i.e. between the soil box's walls [m]; beyond it there is no soil
            (the map clamps its edge cells, which would read as soil up to the robot).
        outline: (m, 2) the bucket's outline in the tip frame (see
            :meth:`~excavsim.robot.kinematics.PlanarArm.bucket_points`) [m]; empty: the tip alone.
        clearance_m: how far every outline point must stay from the walls [m].
    """

    x: np.ndarray
    z: np.ndarray
    x_in: float = -math.inf
    x_out: float = math.inf
    outline: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    clearance_m: float = 0.0

    @classmethod
    def from_map(cls, emap: ElevationMap, arm: ArmPlane, waist: float, width: float, *,
                 dx: float = 0.01, n_across: int = 5, clearance_m: float = 0.0) -> SurfaceProfile:
        """Sample ``emap`` every ``dx`` from 0 to 4 m along the arm plane at ``waist`` [rad] (further, to
        the map's farthest corner rounded up to a metre, when the map reaches beyond 4 m from the waist
        axis: an excavator's pit), each sample the mean of ``n_across`` points spread over the bucket
        ``width`` [m]; the box's walls are the map's extent, and the bucket (``arm.bucket_outline``) keeps
        ``clearance_m`` from them."""
        x0, x1, y0, y1 = emap.extent
        far = max(math.hypot(cx, cy) for cx in (x0, x1) for cy in (y0, y1))
        x = np.arange(0.0, max(4.0, float(math.ceil(far))) + dx / 2, dx)
        offsets = (np.arange(n_across) + 0.5) / n_across * width - width / 2
        pts = arm.plane_to_world(waist, np.stack([x, np.zeros_like(x)], axis=-1))  # (n, 3)
        side = np.array([-math.sin(arm.waist_sign * waist), math.cos(arm.waist_sign * waist)])
        xs = pts[:, None, 0] + offsets[None, :] * side[0]
        ys = pts[:, None, 1] + offsets[None, :] * side[1]
        z = emap.height_at(xs, ys).mean(axis=1)
        # where the bucket's whole width (its edges, half a width either side) is inside the map
        ex = pts[:, None, 0] + np.array([-0.5, 0.5]) * width * side[0]
        ey = pts[:, None, 1] + np.array([-0.5, 0.5]) * width * side[1]
        inside = np.all((ex >= x0) & (ex <= x1) & (ey >= y0) & (ey <= y1), axis=1)
        x_in, x_out = (float(x[inside][0]), float(x[inside][-1])) if inside.any() else (math.inf, -math.inf)
        outline = np.asarray(getattr(arm, "bucket_outline", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
        return cls(x, z, x_in, x_out, outline, float(clearance_m))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.interp(x, self.x, self.z)

    def in_box(self, poses: np.ndarray) -> np.ndarray:
        """(...,) whether the bucket at tip poses (..., 3) keeps ``clearance_m`` from the box's walls."""
        poses = np.asarray(poses, dtype=float)
        lo, hi = self.x_in + self.clearance_m, self.x_out - self.clearance_m
        ok = (poses[..., 0] >= lo) & (poses[..., 0] <= hi)
        if len(self.outline):
            px = outline_points(poses, self.outline)[..., 0]
            ok &= np.all((px >= lo) & (px <= hi), axis=-1)
        return ok
