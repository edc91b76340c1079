"""Compiled inverse kinematics and static joint torques for many poses at once (numba).

The planner evaluates IK and ``tau = tau_grav - J^T F`` (eq. 28) at hundreds of thousands of
trajectory samples per plan. These scalar loops compute exactly what
:meth:`~excavsim.robot.kinematics.PlanarArm.inverse` and
:func:`~excavsim.robot.statics.static_joint_torques` compute with numpy broadcasting (a test holds
them equal, and those are tested against MuJoCo), an order of magnitude faster. The per-pose steps,
:func:`solve_pose` and :func:`pose_torques`, are compiled functions of their own so that other
compiled code (the planner's kernel, :mod:`excavsim.planning.kernel`) solves a pose once for both
its reachability and its torques, with the same arithmetic.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from excavsim.robot.kinematics import PlanarArm


def arm_params(arm: PlanarArm) -> np.ndarray:
    """The chain's numbers packed for :func:`ik_torques` (one float64 vector)."""
    return np.concatenate([
        arm.shoulder_xz, arm.links.ravel(), arm.joint_signs, [arm.blade_angle0], arm.lower, arm.upper,
        arm.link_masses, arm.link_coms.ravel(), [arm.gravity],
    ]).astype(np.float64)


@numba.njit(cache=True, inline="always")
def _wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True)
def chain_lengths(p):
    """The shoulder-elbow and elbow-wrist lengths and their angles at zero configuration, from :func:`arm_params`.

    Constant for an arm: callers of :func:`solve_pose` compute them once.
    """
    return math.hypot(p[2], p[3]), math.hypot(p[4], p[5]), math.atan2(p[3], p[2]), math.atan2(p[5], p[4])


@numba.njit(cache=True)
def solve_pose(p, l1, l2, b0, b1, x, z, pitch):
    """Elbow-up IK of one tip pose (x, z, pitch) within joint limits (App. A1-1.3, eqs. A1 11-19).

    Args:
        p: :func:`arm_params`; l1, l2, b0, b1: :func:`chain_lengths` of ``p``.

    Returns:
        ``(ok, q0, q1, q2)``: whether the pose is reachable, and its joint angles (meaningless where not).
    """
    th3 = pitch + math.pi - p[11]
    return solve_pose_turned(p, l1, l2, b0, b1, x, z, pitch, th3, math.cos(th3), math.sin(th3))


@numba.njit(cache=True)
def solve_pose_turned(p, l1, l2, b0, b1, x, z, pitch, th3, c3, s3):
    """:func:`solve_pose` given the wrist link's turn ``th3 = pitch + pi - blade_angle0`` and its cosine and
    sine (for callers that meet the same pitch many times)."""
    sx, sz = p[0], p[1]
    wx = x - (c3 * p[6] - s3 * p[7])
    wz = z - (s3 * p[6] + c3 * p[7])
    dx, dz = wx - sx, wz - sz
    cg = (dx * dx + dz * dz - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
    ok = abs(cg) <= 1.0 and math.isfinite(x) and math.isfinite(z) and math.isfinite(pitch)
    gam = -math.acos(min(max(cg, -1.0), 1.0))
    a1 = math.atan2(dz, dx) - math.atan2(l2 * math.sin(gam), l1 + l2 * math.cos(gam))
    t1 = a1 - b0
    t2 = a1 + gam - b1 - t1
    t3 = th3 - t1 - t2
    q0 = _wrap(t1 * p[8])
    q1 = _wrap(t2 * p[9])
    q2 = _wrap(t3 * p[10])
    ok = ok and p[12] - 1e-12 <= q0 <= p[15] + 1e-12 and p[13] - 1e-12 <= q1 <= p[16] + 1e-12 \
        and p[14] - 1e-12 <= q2 <= p[17] + 1e-12
    return ok, q0, q1, q2


@numba.njit(cache=True)
def pose_torques(p, q0, q1, q2, fx, fz, mom, w, load_tip):
    """Static joint torques ``tau = tau_grav - J^T F`` (eq. 28) at joint angles (q0, q1, q2).

    Args:
        p: :func:`arm_params`; fx, fz, mom: the soil wrench on the bucket at the tip [N, N, N m];
        w: load in the bucket [kg]; load_tip: (2,) its centre in the tip frame [m].

    Returns:
        ``(tau0, tau1, tau2)`` [N m].
    """
    sx, sz = p[0], p[1]
    sg0, sg1, sg2 = p[8], p[9], p[10]
    mass0, mass1, mass2 = p[18], p[19], p[20]
    # link angles and joint points from the wrapped joint angles (as PlanarArm does)
    h0 = q0 * sg0
    h1 = h0 + q1 * sg1
    h2 = h1 + q2 * sg2
    c0, s0 = math.cos(h0), math.sin(h0)
    c1, s1 = math.cos(h1), math.sin(h1)
    c2, s2 = math.cos(h2), math.sin(h2)
    p1x, p1z = sx + c0 * p[2] - s0 * p[3], sz + s0 * p[2] + c0 * p[3]
    p2x, p2z = p1x + c1 * p[4] - s1 * p[5], p1z + s1 * p[4] + c1 * p[5]
    p3x, p3z = p2x + c2 * p[6] - s2 * p[7], p2z + s2 * p[6] + c2 * p[7]
    m0 = mass0 * (sx + c0 * p[21] - s0 * p[22])
    m1 = mass1 * (p1x + c1 * p[23] - s1 * p[24])
    m2 = mass2 * (p2x + c2 * p[25] - s2 * p[26])
    a = math.pi + _wrap(p[11] + h2 - math.pi)
    load_x = p3x + math.cos(a) * load_tip[0] + math.sin(a) * load_tip[1]  # rot(pi + pitch) (x, -z)
    g = p[27]
    # joint j holds links n >= j and the payload: g sum m_n (x_com_n - x_j) (eq. 31)
    g2 = m2 + w * load_x - (mass2 + w) * p2x
    g1 = m1 + m2 + w * load_x - (mass1 + mass2 + w) * p1x
    g0 = m0 + m1 + m2 + w * load_x - (mass0 + mass1 + mass2 + w) * sx
    return (sg0 * (g * g0 - (-(p3z - sz) * fx + (p3x - sx) * fz + mom)),
            sg1 * (g * g1 - (-(p3z - p1z) * fx + (p3x - p1x) * fz + mom)),
            sg2 * (g * g2 - (-(p3z - p2z) * fx + (p3x - p2x) * fz + mom)))


@numba.njit(cache=True)
def ik_torques(p, poses, wrench, payload, load_tip, want_torques, q_out, ok_out, tau_out):
    """Elbow-up IK of ``poses`` (n, 3) and, where reachable and ``want_torques``, the static torques.

    Args:
        p: :func:`arm_params`.
        poses: (n, 3) tip poses (x, z, pitch).
        wrench: (n, 3) soil wrench on the bucket at the tip (F_x, F_z, M).
        payload: (n,) load in the bucket [kg]; load_tip: (2,) its centre in the tip frame.
        q_out, ok_out, tau_out: (n, 3), (n,), (n, 3) outputs (NaN where unreachable).
    """
    l1, l2, b0, b1 = chain_lengths(p)
    for i in range(poses.shape[0]):
        ok, q0, q1, q2 = solve_pose(p, l1, l2, b0, b1, poses[i, 0], poses[i, 1], poses[i, 2])
        ok_out[i] = ok
        if not ok:
            for j in range(3):
                q_out[i, j] = np.nan
                tau_out[i, j] = np.nan
            continue
        q_out[i, 0] = q0
        q_out[i, 1] = q1
        q_out[i, 2] = q2
        if not want_torques:
            continue
        t0, t1, t2 = pose_torques(p, q0, q1, q2, wrench[i, 0], wrench[i, 1], wrench[i, 2], payload[i], load_tip)
        tau_out[i, 0] = t0
        tau_out[i, 1] = t1
        tau_out[i, 2] = t2


@numba.njit(cache=True)
def forward_pose(p, q0, q1, q2):
    """The tip pose (x, z, pitch) at planar joint angles (q0, q1, q2), as
    :meth:`~excavsim.robot.kinematics.PlanarArm.forward` computes it (the same operations in the same
    order: cumulative link angles, the links' rotated vectors summed from the shoulder, the pitch wrapped).

    Args:
        p: :func:`arm_params`.
    """
    h0 = q0 * p[8]
    h1 = h0 + q1 * p[9]
    h2 = h1 + q2 * p[10]
    x = 0.0
    z = 0.0
    for k, h in enumerate((h0, h1, h2)):
        c, s = math.cos(h), math.sin(h)
        lx, lz = p[2 + 2 * k], p[3 + 2 * k]
        x, z = x + (c * lx - s * lz), z + (s * lx + c * lz)  # sum() starts from 0 too
    return p[0] + x, p[1] + z, _wrap(p[11] + h2 - math.pi)
