"""The encoding of a dig and of the terrain before it (Singh 1995 §5.2.2, Figs. 65-67).

Every force sample, measured during a dig or queried by the planner along a candidate dig, becomes
one row of named columns. The same function, :func:`encode`, serves both, so that a predictor sees
the same quantities in planning as in training.

The action and where the bucket is on it (Fig. 66):

* ``k``, ``alpha``: where the dig enters the surface [m] and its approach angle [rad];
* ``s1``, ``s2``: the distance the tip has moved along the penetration (``d_1*``) and along the
  drag (``d_2**``) [m]; both stay at the dig's ``d1``, ``d2`` during the curl;
* ``x``, ``z``, ``rake``: the tip pose in the arm plane [m, m, rad]; ``v``: soil swept so far [m^3].

The terrain before the dig, from the scanned elevation map (never the true terrain), in the two
forms the thesis uses:

* naive (eq. 15, Fig. 65): ``lz1..lz5``, the mapped elevation along the trench at
  ``k - (i-1) PROFILE_SPACING_M`` (fixed for a dig), and ``cz1..cz3``, the elevation across the
  trench at the tip (bucket's left edge, centre, right edge) [m];
* mechanics (eqs. 16-17, Fig. 67): ``l1..l5``, the depth of soil above the tip at
  ``x - (i-1) AHEAD_SPACING_M``, i.e. at the tip and ahead of it in the direction of travel, and
  ``c1..c3``, the depth of the tip below the surface across the trench [m]; depths are clipped at
  0 (terrain below the tip does not resist).

Along the trench the surface is the planner's: the map averaged across the bucket width
(:class:`~excavsim.handoff.goal.SurfaceProfile`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping

import numpy as np

from excavsim.errors import UsageError
from excavsim.handoff.forces import trajectory_progress
from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.robot.kinematics import PlanarArm

N_AHEAD = 5  # l_1 .. l_5
N_ACROSS = 3  # c_1 .. c_3
AHEAD_SPACING_M = 0.1  # l_i: depth at the tip and every 10 cm ahead of it
PROFILE_SPACING_M = 0.2  # naive l_i: elevations every 20 cm from the entry, over a dig's length

ACTION_COLUMNS = ("k", "alpha", "s1", "s2", "x", "z", "rake", "v")
NAIVE_TERRAIN = tuple(f"lz{i}" for i in range(1, N_AHEAD + 1)) + tuple(f"cz{j}" for j in range(1, N_ACROSS + 1))
MECHANICS_TERRAIN = tuple(f"l{i}" for i in range(1, N_AHEAD + 1)) + tuple(f"c{j}" for j in range(1, N_ACROSS + 1))
FEATURE_COLUMNS = ACTION_COLUMNS + NAIVE_TERRAIN + MECHANICS_TERRAIN

Samples = Mapping[str, np.ndarray]


@dataclasses.dataclass(frozen=True)
class Terrain:
    """The scanned surface along the trench: across the bucket width (mean) and at its edges and centre.

    Attributes:
        x: (n,) radial distance in the arm plane [m], increasing.
        mean: (n,) elevation averaged across the bucket width [m] (the planner's surface).
        across: (3, n) elevation at the bucket's left edge, centre and right edge [m].
    """

    x: np.ndarray
    mean: np.ndarray
    across: np.ndarray

    @classmethod
    def from_map(cls, emap: ElevationMap, arm: PlanarArm, waist: float, width: float) -> Terrain:
        """The terrain of a scanned map along the arm plane at ``waist`` [rad] for a bucket ``width`` [m]."""
        surface = SurfaceProfile.from_map(emap, arm, waist, width)
        pts = arm.plane_to_world(waist, np.stack([surface.x, np.zeros_like(surface.x)], axis=-1))
        side = np.array([-math.sin(arm.waist_sign * waist), math.cos(arm.waist_sign * waist)])
        offsets = np.array([-0.5, 0.0, 0.5]) * width
        across = emap.height_at(pts[None, :, 0] + offsets[:, None] * side[0],
                                pts[None, :, 1] + offsets[:, None] * side[1])
        return cls(surface.x, surface.z, across)

    @classmethod
    def from_surface(cls, surface: SurfaceProfile) -> Terrain:
        """Terrain known only along the trench: the across-trench elevations all equal the mean."""
        z = np.asarray(surface.z, dtype=float)
        return cls(np.asarray(surface.x, dtype=float), z, np.broadcast_to(z, (N_ACROSS, z.size)))

    def matches(self, surface: Callable | None) -> bool:
        """Whether ``surface`` (a SurfaceProfile) is this terrain's mean profile (the same map)."""
        z = getattr(surface, "z", None)
        return z is not None and np.shape(z) == self.mean.shape and np.array_equal(z, self.mean)

    def elevation(self, x: np.ndarray) -> np.ndarray:
        """Mean elevation at radial distances ``x`` (any shape) [m]."""
        return np.interp(x, self.x, self.mean)


def encode(poses: np.ndarray, progress: np.ndarray, volume: np.ndarray, terrain: Terrain) -> dict[str, np.ndarray]:
    """Every feature column of samples along digs (see the module docstring).

    Args:
        poses: (..., 3) tip poses (x, z, pitch) [m, m, rad].
        progress: (..., 4) ``(k, alpha, s1, s2)`` of each sample
            (:func:`~excavsim.planning.predictor.trajectory_progress`).
        volume: (...) soil swept so far [m^3].
        terrain: the scanned terrain before the dig.

    Returns:
        ``FEATURE_COLUMNS`` -> arrays of the samples' shape (...).

    Raises:
        ExcavsimError: the shapes disagree.
    """
    poses = np.asarray(poses, dtype=float)
    progress = np.asarray(progress, dtype=float)
    volume = np.asarray(volume, dtype=float)
    if poses.shape[-1:] != (3,) or progress.shape != poses.shape[:-1] + (4,) or volume.shape != poses.shape[:-1]:
        raise UsageError(f"encode needs poses (..., 3), progress (..., 4) and volume (...) of one shape; given "
                         f"{poses.shape}, {progress.shape}, {volume.shape}")
    x, z = poses[..., 0], poses[..., 1]
    out = {"k": progress[..., 0], "alpha": progress[..., 1], "s1": progress[..., 2], "s2": progress[..., 3],
           "x": x, "z": z, "rake": poses[..., 2], "v": volume}
    for i in range(N_AHEAD):
        out[f"lz{i + 1}"] = terrain.elevation(progress[..., 0] - i * PROFILE_SPACING_M)
    for j in range(N_ACROSS):
        out[f"cz{j + 1}"] = np.interp(x, terrain.x, terrain.across[j])
    for i in range(N_AHEAD):
        out[f"l{i + 1}"] = np.maximum(terrain.elevation(x - i * AHEAD_SPACING_M) - z, 0.0)
    for j in range(N_ACROSS):
        out[f"c{j + 1}"] = np.maximum(out[f"cz{j + 1}"] - z, 0.0)
    return out


def infer_progress(poses: np.ndarray, epsilon: float) -> np.ndarray:
    """``(k, alpha, s1, s2)`` of paths that are not trenching actions (e.g. boundary-following digs).

    The path (..., S, 3) is read as a penetration down to its lowest point, a drag while it stays
    within 1 cm of that depth, then a curl; ``alpha`` is the entry rake less ``epsilon`` [rad].
    A single pose (S = 1) is an entry: ``s1 = s2 = 0``.
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim < 2:
        return infer_progress(poses[None], epsilon)[0]
    z = poses[..., 1]
    i_low = np.argmin(z, axis=-1)[..., None]
    idx = np.arange(z.shape[-1])
    low = np.take_along_axis(z, i_low, axis=-1)
    stays = np.cumprod((z <= low + 0.01) | (idx < i_low), axis=-1).astype(bool)
    phases = np.where(idx <= i_low, 0, np.where(stays, 1, 2))
    return trajectory_progress(poses, phases, epsilon)
