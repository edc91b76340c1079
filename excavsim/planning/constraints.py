"""The constraints on a trenching dig (Singh 1995 ch. 4, §5.3), one function each.

Each is tested on the tip path sampled every ``sample_spacing_m`` and written once, vectorized over
the samples of any number of paths, for every search: the exhaustive search and annealing (through
:mod:`~excavsim.planning.feasibility`), the boundary-following fallback and
:meth:`~excavsim.planning.search.TrenchPlanner.check_action`. A path passes a per-sample test when
every sample passes; the searches also count the leading samples that pass, to bound the drag.

* **shaping** (§4.3.1): no sample below the goal profile (:class:`~excavsim.config.TrenchGoal`);
* **sensible** (§4.3.6): every sample from entry to the end of the drag is in the soil
  (:func:`sensible`), and the curl has turned the bucket to ``curl_exit_pitch_deg`` before the edge
  leaves the soil (:func:`sensible_curl`): soil must not spill as the bucket moves through the air;
* **volume** (§4.3.2): the swept volume at most ``fill_fraction`` x capacity;
* **reachability** (§4.3.3, App. 1): the (z, pitch) lookup table first, exact elbow-up IK on the survivors,
  and the touch-down below the entry (:func:`touchdown`, §7.1.3);
* **force** (§5.3, eq. 28): predicted soil forces (any :class:`~excavsim.handoff.forces.ForcePredictor`)
  and the swept soil's weight turned into joint torques ``tau = tau_grav - J^T F`` (eqs. 28-31,
  App. 2) within the relief limits at every sample (§5.3.3). The T3's limits are one torque per joint;
  a hydraulic excavator's are its cylinders' (:class:`PoseTorqueLimits`): relief pressure x piston (or
  annulus) area x moment arm, a different limit at every pose and in each direction.

The searches evaluate them cheapest first (§6.2.2); unreachable poses have no torques, so force
is only tested where reachability passes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from excavsim.config import TrenchGoal
from excavsim.handoff.forces import DigContext, ForcePredictor
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.robot.fast import arm_params, ik_torques
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.reachability import ReachabilityTable

CONSTRAINTS = ("shaping", "sensible", "volume", "reachability", "force")


@dataclasses.dataclass(frozen=True, eq=False)
class PoseTorqueLimits:
    """Joint-torque limits that vary with the pose: Singh 1995 §5.3's force constraint for cylinders.

    §5.3.3 holds the predicted joint torques within the relief limits, one torque per joint (the T3's
    hydraulic rotary actuators). A cylinder's force is limited by the relief pressure times its piston
    area (pushing) or annulus area (pulling); the torque it gives its joint is that force times its moment
    arm ``dL/dq``, which changes with the joint's angle. So the limit is ``p_relief A |dL/dq(q)|``,
    another at every pose and in each direction: the constraint compares each predicted torque with the
    limit at the sample's own joint angles, in the direction of that torque.

    Attributes:
        at: ``(q (..., 3)) -> (..., 3, 2)`` the (lower, upper) limits at planar joint angles ``q`` [N m]
            (:meth:`excavsim.robot.machine.Machine.torque_limits`, numpy only).
        nominal: (3,) a constant stand-in [N m] where one number per joint is needed (annealing's cost
            scale, the loop's wrist limit in its failure report): the weakest limit over the joint ranges.
        scale: the limits are ``at(q) * scale`` (dividing by a torque margin scales them).
    """

    at: Callable[[np.ndarray], np.ndarray] = dataclasses.field(repr=False)
    nominal: np.ndarray
    scale: float = 1.0

    def __truediv__(self, factor: float) -> PoseTorqueLimits:
        return dataclasses.replace(self, scale=self.scale / float(factor))

    def __getitem__(self, j):
        return self.nominal[j] * self.scale

    def sum(self) -> float:
        return float(np.sum(self.nominal) * self.scale)

    def magnitude(self, q: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """(..., 3) each joint's limit at angles ``q`` (..., 3) in the direction of torques ``tau`` (..., 3) [N m]."""
        lim = self.at(np.asarray(q, dtype=float)) * self.scale
        return np.where(np.asarray(tau) >= 0.0, lim[..., 1], -lim[..., 0])

    def ratio(self, q: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """(...,) the largest ``|tau| / limit`` over the joints (NaN propagated as ``np.max`` does)."""
        return np.max(np.abs(tau) / self.magnitude(q, tau), axis=-1)


def shaping(poses: np.ndarray, goal: TrenchGoal, tolerance_m: float) -> np.ndarray:
    """(...,) whether each tip pose (..., 3) is on or above the goal profile, within ``tolerance_m`` (§4.3.1)."""
    return poses[..., 1] >= goal_profile(goal, poses[..., 0]) - tolerance_m


def sensible(poses: np.ndarray, surface: SurfaceProfile, tolerance_m: float) -> np.ndarray:
    """(...,) whether each penetrate or drag pose (..., 3) is in the soil, within ``tolerance_m`` (§4.3.6).

    In the soil means below the mapped surface and inside the soil box: beyond its walls there is
    no soil (and a bucket dragged into a wall stalls), so the whole bucket must keep the surface's
    ``clearance_m`` from them (:meth:`~excavsim.handoff.goal.SurfaceProfile.in_box`); the thesis'
    feasible sets end at the box's walls too (§4.4, Fig. 38).
    """
    return (poses[..., 1] <= surface(poses[..., 0]) + tolerance_m) & surface.in_box(poses)


def sensible_curl(curl: np.ndarray, surface: SurfaceProfile, tolerance_m: float, exit_pitch_rad: float
                  ) -> np.ndarray:
    """(...) whether curls (..., M, 3) have turned the bucket to ``exit_pitch_rad`` before the edge leaves the soil.

    The sensible constraint on the curl (§4.3.6): the bucket must have curled enough to hold its
    load when the edge first rises ``tolerance_m`` above the mapped surface; what follows the exit
    is the lift-out. A curl that stays in the soil passes. The whole curl stays inside the box.
    """
    above = curl[..., 1] > surface(curl[..., 0]) + tolerance_m
    first = np.argmax(above, axis=-1)
    exit_pitch = np.take_along_axis(curl[..., 2], first[..., None], axis=-1)[..., 0]
    return (~above.any(axis=-1) | (exit_pitch <= exit_pitch_rad)) & np.all(surface.in_box(curl), axis=-1)


def volume(swept_m3: np.ndarray, limit_m3: float) -> np.ndarray:
    """Whether swept volumes [m^3] fit the bucket: at most ``limit_m3`` (``fill_fraction`` x capacity, §4.3.2)."""
    return swept_m3 <= limit_m3


class ArmStatics:
    """The planar arm as the reachability and force constraints see it: lookup table, compiled IK, static torques.

    Args:
        arm: the planar chain (shoulder, elbow, wrist pitch).
        table: reachability table of ``arm`` (App. A1-3).
        payload_com_tip_m: (2,) centre of the bucket's load in the tip frame [m].
    """

    def __init__(self, arm: PlanarArm, table: ReachabilityTable, payload_com_tip_m):
        self.table = table
        self.params = arm_params(arm)
        self.load_tip = np.asarray(payload_com_tip_m, dtype=float)

    def solve(self, poses: np.ndarray, wrench: np.ndarray | None = None, payload: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Elbow-up IK of flat poses (n, 3), and static torques when ``wrench`` (n, 3) is given.

        Args:
            poses: (n, 3) tip poses.
            wrench: (n, 3) soil wrench on the bucket at the tip (F_x, F_z, M) [N, N, N m], or None for IK only.
            payload: (n,) load in the bucket [kg] (with ``wrench``).

        Returns:
            Joint angles (n, 3) [rad], reachability (n,) and torques (n, 3) [N m] (NaN where unreachable).
        """
        n = poses.shape[0]
        q = np.empty((n, 3))
        ok = np.empty(n, bool)
        tau = np.empty((n, 3))
        want = wrench is not None
        ik_torques(self.params, np.ascontiguousarray(poses, dtype=float),
                   np.ascontiguousarray(wrench) if want else np.zeros((n, 3)),
                   np.ascontiguousarray(payload) if want else np.zeros(n), self.load_tip, want, q, ok, tau)
        return q, ok, tau


def reachability(poses: np.ndarray, statics: ArmStatics) -> tuple[np.ndarray, np.ndarray]:
    """Whether each tip pose (..., 3) is reachable (..., ), and its joint angles (..., 3) [rad] (§4.3.3).

    The table's lookup first, then exact IK on the poses the table accepts (NaN angles elsewhere).
    """
    flat = poses.reshape(-1, 3)
    ok = statics.table.contains(flat)
    q = np.full(flat.shape, np.nan)
    if ok.any():
        qi, oki, _ = statics.solve(flat[ok])
        q[ok] = qi
        ok[ok] = oki
    return ok.reshape(poses.shape[:-1]), q.reshape(poses.shape)


def touchdown(entries: np.ndarray, statics: ArmStatics, depth_m: float) -> np.ndarray:
    """(...,) whether the arm reaches ``depth_m`` below each entry pose (..., 3), at its pitch.

    Part of the reachability constraint: before a dig the bucket descends over the entry until the
    F/T sensor finds the soil (§7.1.3), which may lie below the map (its error, Fig. 104). A dig
    whose entry is at the edge of the workspace cannot search below it and ends "no contact".
    """
    lowered = np.array(entries, dtype=float, copy=True)
    lowered[..., 1] -= depth_m
    return reachability(lowered, statics)[0]


def torque_ratio(poses: np.ndarray, depth: np.ndarray, load_m3: np.ndarray, *, statics: ArmStatics,
                 predictor: ForcePredictor, density: float, limits: np.ndarray, progress: np.ndarray | None = None,
                 surface: SurfaceProfile | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predicted forces, static joint torques (eq. 28) and the largest torque/limit ratio per sample.

    Args:
        poses: (..., 3) tip poses; depth: (...,) their depth below the mapped surface [m].
        load_m3: (...,) soil swept so far [m^3]: the predictor's surcharge and, at ``density`` [kg/m^3],
            the load's weight.
        statics: the arm; predictor: the force model; limits: (3,) torque limits [N m], or
            :class:`PoseTorqueLimits` (a cylinder machine's, at each sample's joint angles).
        progress, surface: reach the predictor in its :class:`~excavsim.handoff.forces.DigContext`
            (see :func:`~excavsim.handoff.forces.trajectory_progress`).

    Returns:
        Forces (..., 2) [N], torques (..., 3) [N m] and ratios (...,), ``inf`` where a pose is unreachable.
    """
    f = predictor.predict(depth, poses[..., 2], load_m3, DigContext(poses, progress, surface))
    shape = poses.shape[:-1]
    wrench = np.concatenate([f.reshape(-1, 2), np.zeros((f[..., 0].size, 1))], axis=-1)
    q, ok, tau = statics.solve(poses.reshape(-1, 3), wrench, (density * load_m3).reshape(-1))
    if isinstance(limits, PoseTorqueLimits):
        with np.errstate(invalid="ignore"):
            ratio = np.where(ok, limits.ratio(np.where(ok[:, None], q, 0.0), tau), np.inf)
    else:
        ratio = np.where(ok, np.max(np.abs(tau) / limits, axis=-1), np.inf)
    return f, tau.reshape(shape + (3,)), ratio.reshape(shape)


def force(ratio: np.ndarray) -> np.ndarray:
    """Whether samples keep every joint within its limit, from their :func:`torque_ratio` (§5.3.3)."""
    return ratio <= 1.0
