"""Planar kinematics of the T3 digging chain (shoulder, elbow, wrist pitch), from the compiled model.

Trenching is planar (Singh 1995 §4.3.3): the waist fixes the arm's plane and only the
shoulder, elbow and wrist pitch move while digging; wrist yaw and roll are held at zero (App. A1,
"θ5 and θ6 are typically held constant"). :func:`~excavsim.robot.extract.arm_from_model` reads the chain's geometry
from a compiled MuJoCo model (joint anchors, the ``bucket_tip`` site, body masses and centres of
mass at the zero configuration), so there is no second copy of the dimensions. After that the class
is numpy only: the planner uses it without MuJoCo.

Conventions (radians and metres throughout):

* The *arm plane* turns with the waist. Its x axis points horizontally away from the waist axis
  through the arm, z is up. ``x`` below is that radial coordinate, ``z`` the world height.
* Planar joint angles in joint coordinates, as in ``qpos``; the model's pitch axes are along -y of
  the plane, so a positive angle turns the next link counter-clockwise in (x, z), i.e. upwards.
* ``pitch`` (the rake angle ρ of §3.4.2.2, Fig. 18) is the angle of the tip frame's x axis (along
  the blade, heel to cutting edge) below the horizontal, measured towards the robot (-x): a blade
  pointing at the robot and down has positive pitch; a curled bucket holding soil has negative pitch.
* Every function is vectorized over leading dimensions: ``q`` is ``(..., 3)``, poses are
  ``(..., 3)`` arrays of ``(x, z, pitch)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from excavsim.handoff.goal import outline_points

_TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles into [-π, π)."""
    return (np.asarray(a) + np.pi) % _TWO_PI - np.pi


def rotate2(theta: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate 2-vectors ``v`` (shape (2,) or (..., 2)) counter-clockwise by ``theta`` (...)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _perp(v: np.ndarray) -> np.ndarray:
    """Rotate 2-vectors by +90 degrees: the velocity of a point at ``v`` for unit CCW rotation."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


@dataclasses.dataclass(frozen=True, eq=False)
class PlanarArm:
    """The planar digging chain as numbers: geometry, joint limits and link masses.

    Attributes:
        waist_axis_xy: world (x, y) of the vertical waist axis [m].
        waist_sign: +1 if the waist joint axis is +z, -1 if -z.
        plane_offset_y: lateral offset of the arm plane from the waist axis (along the plane's y) [m].
        shoulder_xz: shoulder axis in the arm plane [m], shape (2,).
        links: vectors shoulder->elbow, elbow->wrist pitch, wrist pitch->bucket tip at zero
            configuration, in the arm plane [m], shape (3, 2).
        joint_signs: +1 where a joint's positive angle turns counter-clockwise in (x, z), shape (3,).
        blade_angle0: counter-clockwise angle of the tip frame's x axis at zero configuration [rad].
        lower, upper: joint limits of shoulder, elbow, wrist pitch [rad], shape (3,).
        link_masses: mass carried by each planar joint's link (the bodies it moves before the next
            planar joint; the wrist link includes yaw, roll and bucket) [kg], shape (3,).
        link_coms: centre of mass of each link relative to its joint axis at zero configuration, in
            the arm plane [m], shape (3, 2).
        gravity: magnitude of gravity [m/s^2].
        bucket_outline: (m, 2) the bucket's profile in the tip frame, (along the blade from heel to
            cutting edge, normal to the blade into the bucket) [m]: where the bucket is around its
            tip (:meth:`bucket_points`); empty for an arm built without it (the tip alone).
    """

    waist_axis_xy: np.ndarray
    waist_sign: float
    plane_offset_y: float
    shoulder_xz: np.ndarray
    links: np.ndarray
    joint_signs: np.ndarray
    blade_angle0: float
    lower: np.ndarray
    upper: np.ndarray
    link_masses: np.ndarray
    link_coms: np.ndarray
    gravity: float
    bucket_outline: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))

    def fingerprint(self) -> bytes:
        """Bytes that change whenever any kinematic or limit parameter changes (for cache keys)."""
        parts = [np.asarray(getattr(self, f.name), dtype=float).tobytes() for f in dataclasses.fields(self)]
        return b"|".join(parts)

    def bucket_points(self, poses: np.ndarray) -> np.ndarray:
        """The bucket's outline in the arm plane at tip poses (..., 3): (..., m + 1, 2) [m], the tip first."""
        outline = np.concatenate([np.zeros((1, 2)), np.asarray(self.bucket_outline, dtype=float).reshape(-1, 2)])
        return outline_points(poses, outline)

    # ------------------------------------------------------------------ forward kinematics
    def _link_angles(self, q: np.ndarray) -> np.ndarray:
        """Cumulative counter-clockwise link angles (..., 3)."""
        return np.cumsum(np.asarray(q, dtype=float) * self.joint_signs, axis=-1)

    def joint_points(self, q: np.ndarray) -> np.ndarray:
        """Shoulder, elbow, wrist pitch and tip positions in the arm plane.

        Args:
            q: planar joint angles (..., 3) [rad].

        Returns:
            (..., 4, 2) positions (x, z) [m].
        """
        th = self._link_angles(q)
        steps = np.stack([rotate2(th[..., k], self.links[k]) for k in range(3)], axis=-2)
        base = np.broadcast_to(self.shoulder_xz, th.shape[:-1] + (2,))
        return np.concatenate([base[..., None, :], base[..., None, :] + np.cumsum(steps, axis=-2)], axis=-2)

    def forward(self, q: np.ndarray) -> np.ndarray:
        """Bucket tip pose in the arm plane.

        Args:
            q: planar joint angles (shoulder, elbow, wrist pitch), shape (..., 3) [rad].

        Returns:
            (..., 3) array of (x, z, pitch) [m, m, rad], pitch wrapped into [-π, π).
        """
        th = self._link_angles(q)
        p = self.shoulder_xz + sum(rotate2(th[..., k], self.links[k]) for k in range(3))
        pitch = wrap_angle(self.blade_angle0 + th[..., 2] - np.pi)
        return np.concatenate([p, pitch[..., None]], axis=-1)

    def plane_to_world(self, waist: np.ndarray, xz: np.ndarray) -> np.ndarray:
        """World coordinates of arm-plane points.

        Args:
            waist: waist angle(s) [rad], broadcastable against ``xz[..., 0]``.
            xz: points in the arm plane (..., 2) [m].

        Returns:
            (..., 3) world positions [m].
        """
        phi = self.waist_sign * np.asarray(waist, dtype=float)
        x, z = xz[..., 0], xz[..., 1]
        c, s = np.cos(phi), np.sin(phi)
        y0 = self.plane_offset_y
        wx = self.waist_axis_xy[0] + c * x - s * y0
        wy = self.waist_axis_xy[1] + s * x + c * y0
        return np.stack(np.broadcast_arrays(wx, wy, z), axis=-1)

    def tip_world(self, q_arm: np.ndarray) -> np.ndarray:
        """World position of the bucket tip for (waist, shoulder, elbow, wrist pitch), shape (..., 4)."""
        q_arm = np.asarray(q_arm, dtype=float)
        return self.plane_to_world(q_arm[..., 0], self.forward(q_arm[..., 1:4])[..., :2])

    # ------------------------------------------------------------------ inverse kinematics
    def inverse(self, pose: np.ndarray, *, elbow_up: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles that put the bucket tip at ``pose`` (App. A1-1.3, eqs. A1 11-19).

        Args:
            pose: (..., 3) array of (x, z, pitch) in the arm plane [m, m, rad].
            elbow_up: choose the elbow-up solution (the T3 digs elbow-up; App. A1 notes the other
                branch is typically outside the range of motion).

        Returns:
            ``(q, ok)``: ``q`` (..., 3) planar joint angles [rad] (NaN where unreachable) and ``ok``
            (...) bool, False where the pose is out of reach or needs a joint beyond its limits.
        """
        pose = np.asarray(pose, dtype=float)
        th3 = pose[..., 2] + np.pi - self.blade_angle0  # total CCW rotation of the wrist link
        wrist = pose[..., :2] - rotate2(th3, self.links[2])
        dvec = wrist - self.shoulder_xz
        l1, l2 = np.linalg.norm(self.links[0]), np.linalg.norm(self.links[1])
        r2 = np.einsum("...i,...i->...", dvec, dvec)
        cos_g = (r2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)  # eq. A1 13
        ok = np.abs(cos_g) <= 1.0
        gamma = np.arccos(np.clip(cos_g, -1.0, 1.0))  # angle of link 2 relative to link 1
        if elbow_up:
            gamma = -gamma  # link 2 turns clockwise: the elbow lies counter-clockwise of shoulder->wrist
        a1 = np.arctan2(dvec[..., 1], dvec[..., 0]) - np.arctan2(l2 * np.sin(gamma), l1 + l2 * np.cos(gamma))
        a2 = a1 + gamma
        beta = np.arctan2(self.links[:, 1], self.links[:, 0])
        t1 = a1 - beta[0]
        t2 = a2 - beta[1] - t1
        t3 = th3 - t1 - t2
        q = wrap_angle(np.stack([t1, t2, t3], axis=-1) * self.joint_signs)
        ok &= np.all((q >= self.lower - 1e-12) & (q <= self.upper + 1e-12), axis=-1)
        ok &= np.all(np.isfinite(pose), axis=-1)
        q = np.where(ok[..., None], q, np.nan)
        return q, ok

    def reachable(self, pose: np.ndarray) -> np.ndarray:
        """Exact reachability of poses (..., 3) by elbow-up IK within joint limits."""
        return self.inverse(pose)[1]

    # ------------------------------------------------------------------ differential kinematics
    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Jacobian of (x, z, pitch) with respect to (shoulder, elbow, wrist pitch).

        Args:
            q: (..., 3) planar joint angles [rad].

        Returns:
            (..., 3, 3): rows x, z, pitch; columns the joints [m/rad, m/rad, rad/rad].
        """
        pts = self.joint_points(q)
        tip = pts[..., 3, :]
        cols = _perp(tip[..., None, :] - pts[..., :3, :]) * self.joint_signs[:, None]  # (..., 3 joints, 2)
        jac = np.empty(q.shape[:-1] + (3, 3))
        jac[..., 0:2, :] = np.swapaxes(cols, -1, -2)
        jac[..., 2, :] = self.joint_signs
        return jac
