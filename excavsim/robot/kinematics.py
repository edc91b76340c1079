"""Planar kinematics of the T3 digging chain (shoulder, elbow, wrist pitch), from the compiled model.

Trenching is planar (000_a3ca905d8c6d92bf.txt §4.3.3): the waist fixes the arm's plane and only the
shoulder, elbow and wrist pitch move while digging; wrist yaw and roll are held at zero (App. A1,
"θ5 and θ6 are typically held constant"). :meth:`PlanarArm.from_model` reads the chain's geometry
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

from excavsim import constants
from excavsim.errors import ModelError

_TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles into [-π, π)."""
    return (np.asarray(a) + np.pi) % _TWO_PI - np.pi


def _rot(theta: np.ndarray, v: np.ndarray) -> np.ndarray:
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

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_model(cls, model, *, tol: float = 1e-9) -> PlanarArm:
        """Extract the planar chain from a compiled MuJoCo model.

        Args:
            model: a ``mujoco.MjModel`` or a dm_control ``Physics``/model wrapper holding the T3.
                Names may carry a PyMJCF attachment prefix (``t3/shoulder_joint``).
            tol: tolerance for the structural checks (parallel pitch axes, vertical waist).

        Raises:
            ModelError: a named element is missing or the chain is not planar as assumed.
        """
        import mujoco  # local: the rest of this module is numpy only

        m = _as_mjmodel(model)
        jids = [_named_id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in constants.JOINTS]
        waist, shoulder, elbow, wrist = jids[:4]
        tip_sid = _named_id(m, mujoco.mjtObj.mjOBJ_SITE, constants.BUCKET_TIP_SITE)
        for j in jids:
            if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                raise ModelError(f"joint {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)!r} must be a hinge")
        d = mujoco.MjData(m)
        d.qpos[:] = m.qpos0
        qadr = m.jnt_qposadr[jids]
        if np.any(np.abs(m.qpos0[qadr]) > 0):
            raise ModelError("the T3 joints must have zero reference positions (qpos0) for the planar extraction")
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)

        z_axis = d.xaxis[waist]
        if abs(abs(z_axis[2]) - 1.0) > tol:
            raise ModelError(f"waist_joint axis must be vertical, got {z_axis}")
        waist_sign = float(np.sign(z_axis[2]))
        origin = d.xanchor[waist].copy()
        normal = d.xaxis[shoulder].copy()  # the plane's -y: positive rotation about it is CCW in (x, z)
        if abs(normal[2]) > tol:
            raise ModelError(f"shoulder_joint axis must be horizontal, got {normal}")
        e_y = -normal / np.linalg.norm(normal)
        e_z = np.array([0.0, 0.0, 1.0])
        e_x = np.cross(e_y, e_z)
        signs = []
        for j, name in zip((shoulder, elbow, wrist), constants.PLANAR_JOINTS):
            dot = float(np.dot(d.xaxis[j], normal))
            if abs(abs(dot) - 1.0) > tol:
                raise ModelError(f"{name} axis {d.xaxis[j]} is not parallel to the shoulder axis")
            signs.append(np.sign(dot))

        def to_plane(p: np.ndarray) -> np.ndarray:
            r = p - origin
            return np.array([np.dot(r, e_x), p[2]])

        anchors = np.array([to_plane(d.xanchor[j]) for j in (shoulder, elbow, wrist)])
        tip = to_plane(d.site_xpos[tip_sid])
        links = np.array([anchors[1] - anchors[0], anchors[2] - anchors[1], tip - anchors[2]])
        plane_offset = float(np.dot(d.site_xpos[tip_sid] - origin, e_y))
        blade = d.site_xmat[tip_sid].reshape(3, 3)[:, 0]
        if abs(np.dot(blade, e_y)) > 1e-6:
            raise ModelError("the bucket_tip site's x axis must lie in the arm plane")
        blade_angle0 = float(np.arctan2(blade[2], np.dot(blade, e_x)))

        # Masses: every body moved by a planar joint belongs to the link of its nearest planar
        # ancestor joint (wrist yaw and roll held at zero, so the wrist link is rigid).
        owner = {}
        for b in range(1, m.nbody):
            k, a = None, b
            while a > 0 and k is None:
                for jj in range(m.body_jntadr[a], m.body_jntadr[a] + m.body_jntnum[a]):
                    if jj in (shoulder, elbow, wrist):
                        k = (shoulder, elbow, wrist).index(jj)
                a = m.body_parentid[a]
            if k is not None:
                owner[b] = k
        masses = np.zeros(3)
        moments = np.zeros((3, 2))
        for b, k in owner.items():
            masses[k] += m.body_mass[b]
            moments[k] += m.body_mass[b] * to_plane(d.xipos[b])
        coms = np.where(masses[:, None] > 0, moments / np.maximum(masses[:, None], 1e-300), anchors) - anchors

        gvec = m.opt.gravity
        if abs(gvec[0]) > tol or abs(gvec[1]) > tol:
            raise ModelError(f"gravity must be vertical, got {gvec}")
        return cls(
            waist_axis_xy=origin[:2].copy(),
            waist_sign=waist_sign,
            plane_offset_y=plane_offset,
            shoulder_xz=anchors[0],
            links=links,
            joint_signs=np.array(signs, dtype=float),
            blade_angle0=blade_angle0,
            lower=m.jnt_range[[shoulder, elbow, wrist], 0].copy(),
            upper=m.jnt_range[[shoulder, elbow, wrist], 1].copy(),
            link_masses=masses,
            link_coms=coms,
            gravity=float(-gvec[2]),
        )

    def fingerprint(self) -> bytes:
        """Bytes that change whenever any kinematic or limit parameter changes (for cache keys)."""
        parts = [np.asarray(getattr(self, f.name), dtype=float).tobytes() for f in dataclasses.fields(self)]
        return b"|".join(parts)

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
        steps = np.stack([_rot(th[..., k], self.links[k]) for k in range(3)], axis=-2)
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
        p = self.shoulder_xz + sum(_rot(th[..., k], self.links[k]) for k in range(3))
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
        wrist = pose[..., :2] - _rot(th3, self.links[2])
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


def _as_mjmodel(model):
    """Accept an MjModel, a dm_control Physics, or its model wrapper."""
    if hasattr(model, "model") and hasattr(model.model, "ptr"):
        return model.model.ptr
    return getattr(model, "ptr", model)


def _named_id(m, objtype, name: str) -> int:
    """Id of the element called ``name`` or ``<prefix>/name`` (PyMJCF attachment)."""
    import mujoco

    i = mujoco.mj_name2id(m, objtype, name)
    if i >= 0:
        return i
    n = {mujoco.mjtObj.mjOBJ_JOINT: m.njnt, mujoco.mjtObj.mjOBJ_SITE: m.nsite, mujoco.mjtObj.mjOBJ_BODY: m.nbody,
         mujoco.mjtObj.mjOBJ_ACTUATOR: m.nu}.get(objtype, 0)
    names = [mujoco.mj_id2name(m, objtype, k) or "" for k in range(n)]
    hits = [k for k, nm in enumerate(names) if nm.endswith("/" + name)]
    if len(hits) == 1:
        return hits[0]
    kind = str(objtype).split("_")[-1].lower()
    raise ModelError(f"{kind} {name!r} not found in the model. Available: {sorted(x for x in names if x)}")
