"""Reading the T3's planar digging chain out of a compiled MuJoCo model, once.

:func:`arm_from_model` measures the chain at the zero configuration (joint anchors and axes, the
``bucket_tip`` site, body masses and centres of mass) and returns a
:class:`~excavsim.robot.kinematics.PlanarArm`, which is numpy only from then on: the planner and
the learners use it without importing MuJoCo (this module is the only part of ``robot`` that does).
"""

from __future__ import annotations

import mujoco
import numpy as np

from excavsim import constants
from excavsim.errors import ModelError
from excavsim.robot.kinematics import PlanarArm


def arm_from_model(model, *, tol: float = 1e-9, joints: tuple[str, ...] | None = None) -> PlanarArm:
    """Extract the planar chain from a compiled MuJoCo model.

    Args:
        model: a ``mujoco.MjModel`` or a dm_control ``Physics``/model wrapper holding the T3.
            Names may carry a PyMJCF attachment prefix (``t3/shoulder_joint``).
        tol: tolerance for the structural checks (parallel pitch axes, vertical waist).
        joints: the chain's (waist, shoulder, elbow, wrist pitch) joint names, another machine's
            (an excavator's swing, boom, stick, bucket); the T3's when None. For another machine the
            chain is measured with those four joints at zero and every other joint at ``qpos0``
            (the T3's six must all have zero ``qpos0``).

    Raises:
        ModelError: a named element is missing or the chain is not planar as assumed.
    """
    m = _as_mjmodel(model)
    if joints is not None and len(joints) != 4:
        raise ModelError(f"joints must name (waist, shoulder, elbow, wrist pitch); given {joints!r}")
    jids = [_named_id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in (joints or constants.JOINTS)]
    waist, shoulder, elbow, wrist = jids[:4]
    tip_sid = _named_id(m, mujoco.mjtObj.mjOBJ_SITE, constants.BUCKET_TIP_SITE)
    for j in jids:
        if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
            raise ModelError(f"joint {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)!r} must be a hinge")
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    qadr = m.jnt_qposadr[jids]
    d.qpos[qadr] = 0.0
    if joints is None and np.any(np.abs(m.qpos0[qadr]) > 0):
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

    # The bucket's profile (the bucket_profile_* sites) in the tip frame, in the plane: at the zero
    # configuration the blade points along blade_angle0, i.e. pitch rho0 = blade_angle0 - pi.
    rho0 = blade_angle0 - np.pi
    x_t = np.array([-np.cos(rho0), -np.sin(rho0)])
    z_t = np.array([-np.sin(rho0), np.cos(rho0)])
    outline = []
    for i in range(constants.N_BUCKET_PROFILE_SITES):
        sid = _named_id(m, mujoco.mjtObj.mjOBJ_SITE, f"{constants.BUCKET_PROFILE_SITE_PREFIX}{i}")
        r = to_plane(d.site_xpos[sid]) - tip
        outline.append([float(r @ x_t), float(r @ z_t)])
    return PlanarArm(
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
        bucket_outline=np.array(outline),
    )


def _as_mjmodel(model):
    """Accept an MjModel, a dm_control Physics, or its model wrapper."""
    if hasattr(model, "model") and hasattr(model.model, "ptr"):
        return model.model.ptr
    return getattr(model, "ptr", model)


def _named_id(m, objtype, name: str) -> int:
    """Id of the element called ``name`` or ``<prefix>/name`` (PyMJCF attachment)."""
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
