"""Cartesian tip paths the executor follows: polylines of planar tip poses (x m, z m, pitch rad).

A path's length counts the turn of the bucket as ``pitch_radius_m`` times its angle, so that a
path that mostly turns the bucket (the curl, the pour) still takes time to follow.

The follower moves every control step: :meth:`PathFollower.advance` interpolates with the compiled
:func:`interp_pose`, which computes what :func:`point_at` (``np.interp`` per coordinate) does, bit
for bit. :func:`follow_path` drives a machine's tip along a path through its inverse kinematics (the
T3's fixed dig of Rowe 1997 §6.2).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np

if TYPE_CHECKING:
    from excavsim.handoff.observation import Servos
    from excavsim.robot.kinematics import PlanarArm


def segment_lengths(path: np.ndarray, pitch_radius_m: float) -> np.ndarray:
    """Lengths of a pose polyline's segments, (n - 1,): position, and pitch turned at ``pitch_radius_m`` [m].

    Args:
        path: (n, 3) tip poses (x m, z m, pitch rad).
        pitch_radius_m: the radius that turns a pitch angle into a length [m].
    """
    d = np.diff(path, axis=0)
    return np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (pitch_radius_m * d[:, 2]) ** 2)


def path_length(path: np.ndarray, pitch_radius_m: float) -> float:
    """Length of a pose polyline (n, 3) [m] (see :func:`segment_lengths`)."""
    return float(segment_lengths(path, pitch_radius_m).sum()) if len(path) > 1 else 0.0


def point_at(path: np.ndarray, s: float, cum: np.ndarray) -> np.ndarray:
    """Pose (3,) at length ``s`` along a pose polyline (n, 3); ``cum`` (n,) is the cumulative length at
    its vertices [m]."""
    if cum[-1] <= 0:
        return path[-1].copy()
    return np.array([np.interp(s, cum, path[:, k]) for k in range(3)])


@numba.njit(cache=True)
def interp_pose(path, s, cum, out):
    """:func:`point_at` into ``out`` (3,), compiled: ``np.interp``'s arithmetic (the last vertex at or
    before ``s``; its pose exactly when ``s`` falls on it or at the end; else the slope times the
    distance from it, with numpy's fallbacks where that is not a number) with ``s`` clamped to the path."""
    n = cum.shape[0]
    if cum[n - 1] <= 0:
        for k in range(3):
            out[k] = path[n - 1, k]
        return
    if math.isnan(s):
        for k in range(3):
            out[k] = s
        return
    if s < cum[0]:
        for k in range(3):
            out[k] = path[0, k]
        return
    if s > cum[n - 1]:
        for k in range(3):
            out[k] = path[n - 1, k]
        return
    lo, hi = 0, n  # the last j with cum[j] <= s (cum never decreases)
    while lo < hi:
        mid = lo + ((hi - lo) >> 1)
        if s >= cum[mid]:
            lo = mid + 1
        else:
            hi = mid
    j = lo - 1
    if j == n - 1 or cum[j] == s:
        for k in range(3):
            out[k] = path[j, k]
        return
    for k in range(3):
        slope = (path[j + 1, k] - path[j, k]) / (cum[j + 1] - cum[j])
        v = slope * (s - cum[j]) + path[j, k]
        if math.isnan(v):
            v = slope * (s - cum[j + 1]) + path[j + 1, k]
            if math.isnan(v) and path[j, k] == path[j + 1, k]:
                v = path[j, k]
        out[k] = v


class PathFollower:
    """A cursor that moves along a pose path at a fixed speed, one control step at a time.

    Args:
        path: (n, 3) tip poses (x m, z m, pitch rad).
        speed: cursor speed along the path [m/s].
        pitch_radius_m: see :func:`segment_lengths` [m].
        cut_from: path length from which the bucket is in the cut, where the stall watch and
            compliance act [m]; infinite for a path that never cuts.
    """

    def __init__(self, path: np.ndarray, speed: float, pitch_radius_m: float, cut_from: float = math.inf):
        self.path = path
        self._path = np.ascontiguousarray(path, dtype=np.float64)  # one layout for the compiled interpolation
        self.speed = speed
        self.cum = np.concatenate([[0.0], np.cumsum(segment_lengths(path, pitch_radius_m))])
        self._end = float(self.cum[-1])
        self.cut_from = cut_from
        self.s = 0.0  # the cursor's length along the path [m]

    def advance(self, dt: float) -> np.ndarray:
        """Move the cursor on by ``dt`` [s] (not past the end) and return the pose (3,) there."""
        self.s = min(self.s + self.speed * dt, self._end)
        out = np.empty(3)
        interp_pose(self._path, self.s, self.cum, out)
        return out

    @property
    def at_end(self) -> bool:
        """The cursor has reached the end of the path."""
        return self.s >= self._end

    @property
    def in_cut(self) -> bool:
        """The cursor is past the path's lead-in, in the cut."""
        return self.s >= self.cut_from


def follow_path(servos: Servos, arm: PlanarArm, path: np.ndarray, speed: float, waist: float, *,
                pitch_radius: float = 0.5, settle_s: float = 0.5) -> np.ndarray:
    """Drive the bucket tip along the pose polyline ``path`` (n, 3) (x m, z m, pitch rad) in the
    plane at swing angle ``waist`` [rad] at ``speed`` [m/s] through IK, then hold the end for
    ``settle_s``; returns the joint angles (6,) at the end (the T3's six joints: waist, the three planar
    ones, and the wrist's yaw and roll held level)."""
    follower = PathFollower(np.asarray(path, dtype=float), speed, pitch_radius)
    obs = servos.observe()
    target = np.array(obs.q, dtype=float)
    target[0], target[4:] = waist, 0.0
    while not follower.at_end:
        q, ok = arm.inverse(follower.advance(servos.control_dt))
        if ok:
            target[1:4] = q
        obs = servos.track(target)
    for _ in range(int(settle_s / servos.control_dt)):
        obs = servos.track(target)
    return np.array(obs.q, dtype=float)
